#include "audio_uploads.hpp"

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "facecast/core/error.hpp"
#include "routes.hpp"
#include "state.hpp"

namespace facecast::server {
namespace fs = std::filesystem;

AudioUploads::AudioUploads(std::size_t max_count, double ttl)
    : max_count_(max_count),
      ttl_(ttl),
      audio_(viseme::load_audio_options()),
      align_(viseme::load_align_options()),
      lipsync_(viseme::load_lipsync_options()) {
  // An upload is either aligned (align.max_seconds bounds the DTW's memory) or lip-synced.
  audio_.max_seconds = std::min(audio_.max_seconds, align_.max_seconds);
}

viseme::Audio AudioUploads::decode(std::string_view bytes) const {
  if (bytes.empty()) throw Error("uploaded audio: empty body");
  // libsndfile and ffmpeg read files: the body goes to a private temporary file for the decoding.
  std::string name;
  {
    std::mt19937_64 r{std::random_device{}()};
    char buf[48];
    std::snprintf(buf, sizeof buf, "facecast-upload-%016llx", static_cast<unsigned long long>(r()));
    name = buf;
  }
  const fs::path path = fs::temp_directory_path() / name;
  struct Remove {
    fs::path p;
    ~Remove() {
      std::error_code ec;
      fs::remove(p, ec);
    }
  } remove{path};
  {
    std::ofstream out(path, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!out) throw Error("uploaded audio: cannot write a temporary file", ErrorCode::kInternal);
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
  char id[24];
  do {
    std::snprintf(id, sizeof id, "a%016llx", static_cast<unsigned long long>(random_()));
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

http::message_generator post_audio(State& state, const Request& req, const std::string& tenant) {
  viseme::Audio audio = state.audio_uploads.decode(req.body());
  const double seconds = audio.seconds();
  const std::string id = state.audio_uploads.put(std::move(audio), tenant);
  return json_response(
      state, req, http::status::created,
      {{"audio_id", id}, {"seconds", seconds}, {"expires_in", state.audio_uploads.ttl()}});
}

}  // namespace facecast::server
