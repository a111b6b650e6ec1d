// Offline video through ffmpeg (raw RGB on a pipe) or as an image sequence.
#include "facecast/render/video.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <deque>
#include <fstream>
#include <future>

#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/render/image.hpp"
#include "facecast/viseme/wav.hpp"

namespace facecast::render {
namespace {

namespace fs = std::filesystem;

// A child process with its stdin on a pipe and its stderr in a file (for the error message).
class Child {
 public:
  Child(const std::vector<std::string>& args, const fs::path& stderr_file) : args_(args) {
    // Everything the child needs is prepared before fork(): between fork and exec only
    // async-signal-safe calls (the parent may be a multi-threaded server).
    std::vector<char*> argv;
    for (const auto& a : args_) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    int fds[2];
    if (pipe2(fds, O_CLOEXEC) != 0)
      throw Error("pipe: " + std::string(std::strerror(errno)), ErrorCode::kInternal);
    pid_ = fork();
    if (pid_ < 0) throw Error("fork: " + std::string(std::strerror(errno)), ErrorCode::kInternal);
    if (pid_ == 0) {
      dup2(fds[0], STDIN_FILENO);
      const int err = open(stderr_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      if (err >= 0) dup2(err, STDERR_FILENO);
      execvp(argv[0], argv.data());
      _exit(127);
    }
    close(fds[0]);
    in_ = fds[1];
  }
  ~Child() {
    if (in_ >= 0) close(in_);
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  /// false when the child has gone (EPIPE).
  bool write(const void* data, size_t n) {
    const char* p = static_cast<const char*>(data);
    while (n > 0) {
      const ssize_t w = ::write(in_, p, n);
      if (w < 0) {
        if (errno == EINTR) continue;
        return false;
      }
      p += w;
      n -= static_cast<size_t>(w);
    }
    return true;
  }
  /// Closes stdin and waits; the exit status (or 128 + signal).
  int finish() {
    close(in_);
    in_ = -1;
    int status = 0;
    while (waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
    }
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }

 private:
  std::vector<std::string> args_;
  pid_t pid_ = -1;
  int in_ = -1;
};

std::string last_line(const fs::path& file) {
  std::ifstream in(file);
  std::string line, last;
  while (std::getline(in, line))
    if (!line.empty()) last = line;
  return last;
}

bool is_pattern(const fs::path& out) {
  return out.filename().string().find('%') != std::string::npos;
}

// Renders frames [0, frames) keeping `depth` in flight (the renderer's context pool does the work
// in parallel) and hands them to `sink` in order.
template <class Sink>
void render_frames(const Renderer& renderer, const anim::Performance& performance, double fps,
                   int frames, int depth, const ProgressFn& progress, Sink&& sink) {
  const size_t shapes = performance.shape_names().size();
  std::deque<std::future<Image>> inflight;
  int next = 0;
  for (int done = 0; done < frames;) {
    while (next < frames && static_cast<int>(inflight.size()) < std::max(1, depth)) {
      const double t = next / fps;
      inflight.push_back(std::async(std::launch::async, [&renderer, &performance, shapes, t] {
        std::vector<float> w(shapes);
        anim::HeadPose head;
        performance.sample(t, w, &head);
        return renderer.render(w, head);
      }));
      ++next;
    }
    sink(done, inflight.front().get());
    inflight.pop_front();
    ++done;
    report(progress, "render", static_cast<double>(done) / frames);
  }
}

}  // namespace

VideoResult write_video(const Renderer& renderer, const anim::Performance& performance,
                        const std::vector<int16_t>& pcm, int sample_rate, const fs::path& out,
                        const VideoOptions& options, const ProgressFn& progress) {
  if (!(options.fps > 0 && options.fps <= 240))
    throw Error("video: fps " + std::to_string(options.fps) + " is out of range (0, 240]");
  const bool audio = !pcm.empty() && sample_rate > 0;
  const double seconds =
      audio ? static_cast<double>(pcm.size()) / sample_rate : performance.duration();
  VideoResult result;
  result.frames = std::max(1, static_cast<int>(std::ceil(seconds * options.fps - 1e-9)));
  result.duration = result.frames / options.fps;
  const auto t0 = std::chrono::steady_clock::now();
  const int w = renderer.options().width, h = renderer.options().height;
  if (out.has_parent_path()) fs::create_directories(out.parent_path());

  if (is_pattern(out)) {
    std::vector<char> name(out.string().size() + 32);
    render_frames(renderer, performance, options.fps, result.frames, options.pipeline, progress,
                  [&](int f, const Image& image) {
                    std::snprintf(name.data(), name.size(), out.string().c_str(), f);
                    write_image(name.data(), image);
                  });
    if (audio)
      write_file_atomic(out.parent_path() / "audio.wav", viseme::encode_wav(pcm, sample_rate));
  } else {
    const std::string ext = out.extension().string();
    if (ext != ".mp4" && ext != ".mkv" && ext != ".mov")
      throw Error(out.string() +
                  ": a video needs .mp4, .mkv or .mov, or a frame pattern like "
                  "frames/%05d.png");
    // Writing into a pipe whose reader died must give EPIPE, not kill the process.
    signal(SIGPIPE, SIG_IGN);
    const fs::path tmp =
        out.parent_path() / (".tmp-" + out.stem().string() + "-" + std::to_string(getpid()) + ext);
    const fs::path wav = out.parent_path() /
                         (".tmp-" + out.stem().string() + "-" + std::to_string(getpid()) + ".wav");
    const fs::path log = out.parent_path() /
                         (".tmp-" + out.stem().string() + "-" + std::to_string(getpid()) + ".log");
    struct Cleanup {
      std::vector<fs::path> files;
      ~Cleanup() {
        std::error_code ec;
        for (const auto& f : files) fs::remove(f, ec);
      }
    } cleanup{{tmp, wav, log}};
    std::vector<std::string> args = {options.ffmpeg, "-nostdin",
                                     "-hide_banner", "-loglevel",
                                     "error",        "-y",
                                     "-f",           "rawvideo",
                                     "-pix_fmt",     "rgb24",
                                     "-s",           std::to_string(w) + "x" + std::to_string(h),
                                     "-framerate",   std::to_string(options.fps),
                                     "-i",           "pipe:0"};
    if (audio) {
      write_file_atomic(wav, viseme::encode_wav(pcm, sample_rate));
      args.insert(args.end(), {"-i", wav.string()});
    }
    args.insert(args.end(),
                {"-map", "0:v", "-c:v", "libx264", "-preset", options.preset, "-crf",
                 std::to_string(options.crf), "-pix_fmt", "yuv420p", "-movflags", "+faststart"});
    if (audio)
      args.insert(args.end(), {"-map", "1:a", "-c:a", "aac", "-b:a",
                               std::to_string(options.audio_bitrate_kbps) + "k"});
    args.push_back(tmp.string());
    Child ffmpeg(args, log);
    bool alive = true;
    render_frames(renderer, performance, options.fps, result.frames, options.pipeline, progress,
                  [&](int, const Image& image) {
                    if (alive) alive = ffmpeg.write(image.pixels.data(), image.pixels.size());
                  });
    const int status = ffmpeg.finish();
    if (status != 0 || !alive) {
      const std::string why = last_line(log);
      throw Error("ffmpeg failed (exit " + std::to_string(status) + ")" +
                      (why.empty() ? std::string() : ": " + why),
                  ErrorCode::kInternal);
    }
    fs::rename(tmp, out);
  }
  result.render_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  report(progress, "done", 1.0);
  return result;
}

}  // namespace facecast::render
