#pragma once
// Offline video rendering for POST /api/render: text -> utterance (with espeak-ng audio) ->
// performance -> render::write_video (frames rendered headless, piped into ffmpeg: H.264 + AAC).
#include <string>

#include <nlohmann/json.hpp>

#include "facecast/viseme/options.hpp"
#include "jobs.hpp"
#include "stream_services.hpp"

namespace facecast::server {

struct VideoRequest {
  std::string text, rig;
  double fps = 30;
  int width = 1280, height = 720;
  bool audio = true;
  viseme::LangMode lang = viseme::LangMode::kAuto;
  std::string voice = "en-us";
  double rate = 4.5;
  bool idle = true;
};

/// Runs in a job; the MP4 goes to <data>/renders/<job>.mp4 (written under a temporary name) and is
/// registered as
/// the job's "video.mp4". Returns {url, frames, fps, duration, size}.
nlohmann::json render_video(const StreamServices& services, const VideoRequest& request,
                            JobContext& ctx);

}  // namespace facecast::server
