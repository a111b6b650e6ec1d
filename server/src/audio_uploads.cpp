#include "audio_uploads.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>

#include "facecast/core/error.hpp"
#include "facecast/core/random.hpp"
#include "jobs.hpp"
#include "responses.hpp"
#include "routes.hpp"

namespace facecast::server {
namespace fs = std::filesystem;

AudioUploads::AudioUploads(AudioUploadOptions options)
    : tmp_dir_(std::move(options.tmp_dir)),
      max_count_(options.max_count),
      ttl_(options.ttl),
      audio_(viseme::load_audio_options()),
      align_(viseme::load_align_options()),
      lipsync_(viseme::load_lipsync_options()) {
  // An upload is either aligned (align.max_seconds bounds the DTW's memory) or lip-synced.
  audio_.untrusted = true;
  audio_.decode_timeout = options.decode_timeout;
  audio_.limit_name = "max_audio_seconds";
  if (align_.max_seconds < options.max_seconds) audio_.limit_name = "align.max_seconds";
  audio_.max_seconds = std::min({audio_.max_seconds, align_.max_seconds, options.max_seconds});
}

viseme::Audio AudioUploads::decode(std::string_view bytes) const {
  if (bytes.empty()) throw Error("uploaded audio: empty body");
  // ffmpeg reads a file (MP4/M4A needs to seek): the body goes to a private temporary file.
  const fs::path dir = tmp_dir_.empty() ? fs::temp_directory_path() : tmp_dir_;
  std::error_code ec;
  fs::create_directories(dir, ec);
  const fs::path path = dir / ("upload-" + random_hex(8) + ".tmp");
  struct Remove {
    fs::path p;
    ~Remove() {
      std::error_code ignored;
      fs::remove(p, ignored);
    }
  } remove{path};
  {
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
    if (fd < 0)
      throw Error("uploaded audio: cannot write a temporary file: " + std::string(strerror(errno)),
                  ErrorCode::kInternal);
    const char* p = bytes.data();
    std::size_t left = bytes.size();
    while (left > 0) {
      const ssize_t n = ::write(fd, p, left);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        ::close(fd);
        throw Error("uploaded audio: cannot write a temporary file", ErrorCode::kInternal);
      }
      p += n;
      left -= static_cast<std::size_t>(n);
    }
    ::close(fd);
  }
  try {
    return viseme::read_audio(path.string(), audio_);
  } catch (const Error& e) {
    // read_audio names the file: name the upload instead of the temporary path.
    std::string message = e.what();
    const std::string p = path.string();
    for (auto at = message.find(p); at != std::string::npos; at = message.find(p, at))
      message.replace(at, p.size(), "uploaded audio");
    throw Error(message, e.code());
  }
}

std::string AudioUploads::put(viseme::Audio audio, const std::string& tenant) {
  auto shared = std::make_shared<const viseme::Audio>(std::move(audio));
  std::lock_guard lock(mutex_);
  const auto now = Clock::now();
  expire(now);
  while (entries_.size() >= max_count_) {
    auto oldest = entries_.begin();
    for (auto it = entries_.begin(); it != entries_.end(); ++it)
      if (it->second.at < oldest->second.at) oldest = it;
    entries_.erase(oldest);
  }
  std::string id;
  do {
    id = "a" + random_hex(8);
  } while (entries_.contains(id));
  entries_.emplace(id, Entry{std::move(shared), now, tenant});
  return id;
}

std::optional<std::string> AudioUploads::owner(const std::string& id) {
  std::lock_guard lock(mutex_);
  expire(Clock::now());
  const auto it = entries_.find(id);
  if (it == entries_.end()) return std::nullopt;
  return it->second.tenant;
}

std::shared_ptr<const viseme::Audio> AudioUploads::get(const std::string& id) {
  std::lock_guard lock(mutex_);
  expire(Clock::now());
  const auto it = entries_.find(id);
  return it == entries_.end() ? nullptr : it->second.audio;
}

void AudioUploads::expire(Clock::time_point now) {
  const auto ttl = std::chrono::duration<double>(ttl_);
  std::erase_if(entries_, [&](const auto& e) { return now - e.second.at > ttl; });
}

http::message_generator post_audio(const Responses& reply, Jobs& jobs, AudioUploads& uploads,
                                   const Request& req, const std::string& tenant) {
  const auto job = jobs.hold("audio decode");
  viseme::Audio audio = uploads.decode(req.body());
  const double seconds = audio.seconds();
  const std::string id = uploads.put(std::move(audio), tenant);
  return reply.json(req, http::status::created,
                    {{"audio_id", id}, {"seconds", seconds}, {"expires_in", uploads.ttl()}});
}

}  // namespace facecast::server
