#pragma once
// Offline video: a motion (e.g. a speech performance) rendered frame by frame and piped as raw RGB
// into ffmpeg (H.264 yuv420p + AAC audio in MP4), or written as a PNG sequence plus a WAV. No
// per-frame image files on the MP4 path.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "facecast/core/progress.hpp"
#include "facecast/render/renderer.hpp"
#include "facecast/rig/motion.hpp"

namespace facecast::render {

/// Defaults mirrored in configs/render/render.json ("video").
struct VideoOptions {
  double fps = 30;
  int crf = 20;                     // x264 quality (lower is better)
  std::string preset = "veryfast";  // x264 speed/size trade-off
  int audio_bitrate_kbps = 128;     // AAC
  int pipeline = 3;                 // frames rendered ahead of the encoder
  std::string ffmpeg = "ffmpeg";    // the executable (looked up on PATH)
  /// H.264 encoder: auto (NVENC when the renderer draws on an NVIDIA GPU and ffmpeg's h264_nvenc
  /// encodes there, x264 otherwise), x264, or nvenc.
  enum class Encoder { kAuto, kX264, kNvenc } encoder = Encoder::kAuto;
};

/// VideoOptions from configs/render/render.json ("video").
VideoOptions load_video_options();

/// What was written.
struct VideoResult {
  int frames = 0;
  double duration = 0;        // frames / fps
  double render_seconds = 0;  // wall time
  std::string encoder;        // ffmpeg's encoder ("libx264", "h264_nvenc"); empty for frames
};

/// Renders `motion` with `renderer` into `out`:
///  - "*.mp4" / "*.mkv" / "*.mov": ffmpeg, H.264 yuv420p (+ AAC when `pcm` is not empty). Written
///  to
///    a temporary name next to `out` and renamed when ffmpeg succeeded.
///  - a path with a printf frame pattern ("frames/%05d.png", .png/.jpg/.exr): one image per frame,
///    plus "audio.wav" in the same folder when there is audio.
/// Frames cover the audio when there is audio (ceil(audio seconds * fps)), else the whole
/// motion. Throws facecast::Error naming ffmpeg's last error line or the file.
VideoResult write_video(const Renderer& renderer, const rig::Motion& motion,
                        const std::vector<int16_t>& pcm, int sample_rate,
                        const std::filesystem::path& out, const VideoOptions& options = {},
                        const ProgressFn& progress = {});

}  // namespace facecast::render
