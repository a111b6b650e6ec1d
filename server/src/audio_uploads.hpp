#pragma once
// Uploaded speech audio (docs/protocol.md, "POST /api/audio" and `speak` with `audio_id`): decoded
// once when it arrives (any format libsndfile or ffmpeg reads), kept in memory for a while, and
// spoken by a `speak` that names it: its text aligned to it (docs/algorithms.md#forced-alignment)
// or, without text, the face from the audio alone (#audio-lipsync).
#include <chrono>
#include <cstddef>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "beast.hpp"
#include "facecast/viseme/align.hpp"
#include "facecast/viseme/audio.hpp"
#include "facecast/viseme/lipsync.hpp"

namespace facecast::server {

class Jobs;
class Responses;

struct AudioUploadOptions {
  // Where an upload waits while ffmpeg decodes it (a private file, removed after; one a killed
  // server left is swept at the next start). Empty: the system's temporary folder.
  std::filesystem::path tmp_dir;
  double max_seconds = 120;    // max_audio_seconds (and at most align.max_seconds)
  double decode_timeout = 10;  // audio_decode_timeout: ffmpeg is killed after this long
  std::size_t max_count = 64;  // uploads kept (the oldest goes first)...
  double ttl = 600;            // ...each for this many seconds
};

class AudioUploads {
 public:
  explicit AudioUploads(AudioUploadOptions options = {});

  /// Decodes an uploaded file, only in an ffmpeg child (viseme::AudioOptions::untrusted: file
  /// protocol, allow-listed demuxers, decode_timeout); throws a one-line Error ("uploaded audio:
  /// ...") when it is empty, not audio ("ffmpeg could not decode the audio: <ffmpeg's reason>"),
  /// shorter than audio.min_seconds, longer than the limit (kLimit), or too slow to decode.
  viseme::Audio decode(std::string_view bytes) const;
  /// Keeps `audio`, owned by `tenant`; returns its id ("a" + 16 random hex digits from the kernel).
  std::string put(viseme::Audio audio, const std::string& tenant = "default");
  /// The tenant of upload `id`, or nullopt when there is none.
  std::optional<std::string> owner(const std::string& id);
  /// The upload `id`, or nullptr when there is none (never uploaded, expired or evicted).
  std::shared_ptr<const viseme::Audio> get(const std::string& id);

  const viseme::AlignOptions& align_options() const { return align_; }
  const viseme::LipsyncOptions& lipsync_options() const { return lipsync_; }
  double ttl() const { return ttl_; }

 private:
  using Clock = std::chrono::steady_clock;
  struct Entry {
    std::shared_ptr<const viseme::Audio> audio;
    Clock::time_point at;
    std::string tenant;
  };
  void expire(Clock::time_point now);  // with mutex_ held

  std::filesystem::path tmp_dir_;
  std::size_t max_count_;
  double ttl_;
  viseme::AudioOptions audio_;
  viseme::AlignOptions align_;
  viseme::LipsyncOptions lipsync_;
  std::mutex mutex_;
  std::map<std::string, Entry> entries_;
};

/// POST /api/audio: the body is an audio file, kept for `tenant`; answers {"audio_id", "seconds",
/// "expires_in"}.
http::message_generator post_audio(const Responses& reply, Jobs& jobs, AudioUploads& uploads,
                                   const Request& req, const std::string& tenant);

}  // namespace facecast::server
