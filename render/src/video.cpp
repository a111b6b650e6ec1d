// Offline video through ffmpeg (raw RGB on a pipe) or as an image sequence.
#include "facecast/render/video.hpp"

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <deque>
#include <fstream>
#include <future>
#include <map>
#include <mutex>

#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/core/random.hpp"
#include "facecast/core/subprocess.hpp"
#include "facecast/core/wav.hpp"
#include "facecast/render/image.hpp"

namespace facecast::render {
namespace {

namespace fs = std::filesystem;

// A stalled encoder (nothing taken for this long) or one that does not finish is killed.
constexpr double kStallSeconds = 60;
constexpr double kFinishSeconds = 300;

bool is_pattern(const fs::path& out) {
  return out.filename().string().find('%') != std::string::npos;
}

// Renders frames [0, frames) keeping `depth` in flight (the renderer's context pool does the work
// in parallel) and hands them to `sink` in order. The spring bones step here, in frame order.
template <class Sink>
void render_frames(const Renderer& renderer, const rig::Motion& motion, double fps, int frames,
                   int depth, const ProgressFn& progress, Sink&& sink) {
  const size_t shapes = motion.shape_names().size();
  rig::SpringSim springs = renderer.spring_sim();
  std::deque<std::future<Image>> inflight;
  int next = 0;
  for (int done = 0; done < frames;) {
    while (next < frames && static_cast<int>(inflight.size()) < std::max(1, depth)) {
      const double t = next / fps;
      std::vector<float> w(shapes);
      rig::BodyPose body;
      motion.sample(t, w, &body);
      inflight.push_back(std::async(std::launch::async, [&renderer, w = std::move(w), body,
                                                         turns = springs.advance(body, t)] {
        return renderer.render(w, body, turns);
      }));
      ++next;
    }
    sink(done, inflight.front().get());
    inflight.pop_front();
    ++done;
    report(progress, "render", static_cast<double>(done) / frames);
  }
}

// Whether ffmpeg's h264_nvenc encodes here (a GPU with NVENC and its driver): a fifth of a second
// of black, once per process and ffmpeg.
bool nvenc_works(const std::string& ffmpeg) {
  static std::mutex mutex;
  static std::map<std::string, bool> known;
  std::lock_guard lock(mutex);
  if (const auto it = known.find(ffmpeg); it != known.end()) return it->second;
  bool ok = false;
  try {
    Child probe({ffmpeg, "-nostdin", "-hide_banner", "-loglevel", "error", "-f", "lavfi", "-i",
                 "color=c=black:s=256x256:r=30:d=0.2", "-c:v", "h264_nvenc", "-f", "null", "-"},
                {{2, ChildFd::Kind::kRead, -1, 4096, true}});
    ok = probe.finish(20).ok();
  } catch (const Error&) {
    ok = false;
  }
  return known[ffmpeg] = ok;
}

// The encoder's ffmpeg arguments: NVENC (constant quality `crf`, preset p4) when asked for, or
// asked for automatically with the renderer on an NVIDIA GPU where NVENC works; else x264.
std::vector<std::string> encoder_args(const Renderer& renderer, const VideoOptions& o) {
  using E = VideoOptions::Encoder;
  const bool nvenc =
      o.encoder == E::kNvenc ||
      (o.encoder == E::kAuto && renderer.backend().find("NVIDIA") != std::string::npos &&
       nvenc_works(o.ffmpeg));
  if (nvenc)
    return {"-c:v", "h264_nvenc",          "-preset", "p4", "-rc", "vbr",
            "-cq",  std::to_string(o.crf), "-b:v",    "0"};
  return {"-c:v", "libx264", "-preset", o.preset, "-crf", std::to_string(o.crf)};
}

}  // namespace

VideoResult write_video(const Renderer& renderer, const rig::Motion& motion,
                        const std::vector<int16_t>& pcm, int sample_rate, const fs::path& out,
                        const VideoOptions& options, const ProgressFn& progress) {
  if (!(options.fps > 0 && options.fps <= 240))
    throw Error("video: fps " + std::to_string(options.fps) + " is out of range (0, 240]");
  const bool audio = !pcm.empty() && sample_rate > 0;
  const double seconds = audio ? static_cast<double>(pcm.size()) / sample_rate : motion.duration();
  VideoResult result;
  result.frames = std::max(1, static_cast<int>(std::ceil(seconds * options.fps - 1e-9)));
  result.duration = result.frames / options.fps;
  const auto t0 = std::chrono::steady_clock::now();
  const int w = renderer.options().width, h = renderer.options().height;
  if (out.has_parent_path()) fs::create_directories(out.parent_path());

  if (is_pattern(out)) {
    std::vector<char> name(out.string().size() + 32);
    render_frames(renderer, motion, options.fps, result.frames, options.pipeline, progress,
                  [&](int f, const Image& image) {
                    std::snprintf(name.data(), name.size(), out.string().c_str(), f);
                    write_image(name.data(), image);
                  });
    if (audio)
      write_file_atomic(out.parent_path() / "audio.wav", facecast::encode_wav(pcm, sample_rate));
  } else {
    const std::string ext = out.extension().string();
    if (ext != ".mp4" && ext != ".mkv" && ext != ".mov")
      throw Error(out.string() +
                  ": a video needs .mp4, .mkv or .mov, or a frame pattern like "
                  "frames/%05d.png");
    // Temporaries named for the sweep at start (is_temp_name) should this process be killed.
    const std::string tag = ".tmp-" + out.stem().string() + "-" + random_hex(6);
    const fs::path tmp = out.parent_path() / (tag + ext);
    const fs::path wav = out.parent_path() / (tag + ".wav");
    struct Cleanup {
      std::vector<fs::path> files;
      ~Cleanup() {
        std::error_code ec;
        for (const auto& f : files) fs::remove(f, ec);
      }
    } cleanup{{tmp, wav}};
    std::vector<std::string> args = {options.ffmpeg, "-nostdin",
                                     "-hide_banner", "-loglevel",
                                     "error",        "-y",
                                     "-f",           "rawvideo",
                                     "-pix_fmt",     "rgb24",
                                     "-s",           std::to_string(w) + "x" + std::to_string(h),
                                     "-framerate",   std::to_string(options.fps),
                                     "-i",           "pipe:0"};
    if (audio) {
      write_file_atomic(wav, facecast::encode_wav(pcm, sample_rate));
      args.insert(args.end(), {"-i", wav.string()});
    }
    const std::vector<std::string> encoder = encoder_args(renderer, options);
    result.encoder = encoder[1];
    args.insert(args.end(), {"-map", "0:v"});
    args.insert(args.end(), encoder.begin(), encoder.end());
    args.insert(args.end(), {"-pix_fmt", "yuv420p", "-movflags", "+faststart"});
    if (audio)
      args.insert(args.end(), {"-map", "1:a", "-c:a", "aac", "-b:a",
                               std::to_string(options.audio_bitrate_kbps) + "k"});
    args.push_back(tmp.string());
    // stdin: the frames; stderr: kept (its end) for the error message; nothing else inherited.
    Child ffmpeg(args, {{0, ChildFd::Kind::kWrite}, {2, ChildFd::Kind::kRead, -1, 16384, true}});
    bool alive = true;
    render_frames(renderer, motion, options.fps, result.frames, options.pipeline, progress,
                  [&](int, const Image& image) {
                    if (alive)
                      alive = ffmpeg.write(
                          0,
                          std::string_view(reinterpret_cast<const char*>(image.pixels.data()),
                                           image.pixels.size()),
                          kStallSeconds);
                  });
    // An encoder that stopped taking frames has ended or is ending: a few seconds to say why.
    const ExitStatus status = ffmpeg.finish(alive ? kFinishSeconds : 5);
    if (!status.ok() || !alive) {
      RunResult r;  // for its one-line description, naming ffmpeg and its last error line
      r.program = ffmpeg.program();
      r.status = status;
      r.err = ffmpeg.output(2);
      r.timeout = alive ? kFinishSeconds : 5;
      const std::string why = r.last_error_line();
      throw Error(status.ok() ? r.program + " stopped reading the frames" +
                                    (why.empty() ? std::string() : ": " + why)
                              : r.describe(),
                  ErrorCode::kInternal);
    }
    commit_file(tmp, out);  // flushed, renamed, the folder flushed
  }
  result.render_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  report(progress, "done", 1.0);
  return result;
}

}  // namespace facecast::render
