#include "rtmp_out.hpp"

#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>

#include "facecast/core/error.hpp"
#include "facecast/rig/motion.hpp"
#include "log.hpp"

namespace facecast::server {
namespace {

using Clock = std::chrono::steady_clock;

double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

std::string kbps(int k) {
  return std::to_string(k) + "k";
}

}  // namespace

RtmpOutput::RtmpOutput(std::shared_ptr<const StreamServices> services,
                       std::shared_ptr<Channel> channel, ServerOptions::Rtmp settings)
    : services_(std::move(services)),
      channel_(std::move(channel)),
      settings_(std::move(settings)),
      member_id_(services_->sessions.new_connection_id()),
      clock_start_(Clock::now()) {}

std::shared_ptr<RtmpOutput> RtmpOutput::start(std::shared_ptr<const StreamServices> services,
                                              std::shared_ptr<Channel> channel,
                                              const ServerOptions::Rtmp& settings) {
  auto out = std::make_shared<RtmpOutput>(std::move(services), std::move(channel), settings);
  out->channel_->subscribe(out->member_id_, out->weak_from_this());
  out->thread_ = std::thread([self = out.get()] { self->run(); });
  log::info("rtmp_start",
            {{"channel", out->channel_->name()},
             {"url", settings.url},
             {"size", std::to_string(settings.width) + "x" + std::to_string(settings.height)},
             {"fps", settings.fps}});
  return out;
}

RtmpOutput::~RtmpOutput() {
  stop();
}

void RtmpOutput::stop() {
  if (stopping_.exchange(true)) return;
  channel_->unsubscribe(member_id_);
  if (thread_.joinable()) thread_.join();
}

// ---- input: the channel's messages (on the channel's strand) -----------------------------------

void RtmpOutput::deliver(OutBatch batch) {
  for (const OutMessage& message : *batch) {
    if (stopping_) return;
    try {
      take(message);
    } catch (const std::exception& e) {  // a message this output cannot read: skip it
      log::warn("rtmp_message_skipped", {{"channel", channel_->name()}, {"error", e.what()}});
    }
  }
}

void RtmpOutput::take(const OutMessage& message) {
  const double now = since(clock_start_);
  std::lock_guard lock(mutex_);
  if (message.kind == OutKind::kControl) {
    if (message.boundary != Boundary::kStart) return;
    const auto j = nlohmann::json::parse(*message.data, nullptr, false);
    if (!j.is_object() || j.value("type", "") != "stream_start") return;
    Stream s;
    s.id = j["stream"].get<std::uint32_t>();
    s.rig = j["rig"].get<std::string>();
    s.names = j["names"].size();
    s.fps = j["fps"].get<double>();
    if (j["audio"].is_object()) s.rate = j["audio"]["sample_rate"].get<int>();
    for (const auto& old : streams_)
      if (old.id == s.id) return;  // a late join's repeat of what is on air
    streams_.push_back(std::move(s));
    return;
  }
  const MediaHeader h = read_header(*message.data);
  Stream* s = nullptr;
  for (auto it = streams_.rbegin(); it != streams_.rend() && !s; ++it)
    if (it->id == h.stream) s = &*it;
  if (!s) return;
  if (!s->placed) {
    // pts p arrives about p - lead after the stream began; `delay` covers the lead and jitter.
    const double fps = settings_.fps;
    s->t0 = std::ceil((now + settings_.delay - h.pts) * fps - 1e-9) / fps;
    s->placed = true;
  }
  const std::string_view payload = std::string_view(*message.data).substr(kHeaderSize);
  if (h.kind == MediaKind::kWeights) {
    const std::vector<float> v = read_floats(payload);
    const std::size_t per = s->names + rig::BodyPose::kChannels.size();
    for (std::uint32_t i = 0; i < h.count && (i + 1) * per <= v.size(); ++i)
      s->frames[h.first + i].assign(v.begin() + i * per, v.begin() + (i + 1) * per);
  } else if (h.kind == MediaKind::kAudio) {
    const std::size_t n = std::min<std::size_t>(h.count, payload.size() / 2);
    if (s->pcm.size() < h.first + n) s->pcm.resize(h.first + n, 0);
    for (std::size_t i = 0; i < n; ++i) {
      const auto lo = static_cast<unsigned char>(payload[2 * i]);
      const auto hi = static_cast<unsigned char>(payload[2 * i + 1]);
      s->pcm[h.first + i] = static_cast<std::int16_t>(lo | (hi << 8));
    }
  }
}

// ---- output: one clock for picture and sound ----------------------------------------------------

RtmpOutput::Pose RtmpOutput::sample(double t, std::int64_t first, std::size_t count,
                                    std::vector<std::int16_t>& pcm) {
  std::lock_guard lock(mutex_);
  pcm.assign(count, 0);
  // The stream on air at t: the latest placed one that has begun (streams begin on frames).
  auto active = streams_.end();
  for (auto it = streams_.begin(); it != streams_.end(); ++it)
    if (it->placed && it->t0 <= t + 1e-9) active = it;
  if (active == streams_.end()) return last_;
  streams_.erase(streams_.begin(), active);  // earlier streams are over
  Stream& s = streams_.front();
  const auto f = static_cast<std::uint32_t>(std::floor((t - s.t0) * s.fps + 1e-6));
  auto it = s.frames.upper_bound(f);
  if (it != s.frames.begin()) {
    --it;
    last_ = Pose{s.rig, it->second};
    s.frames.erase(s.frames.begin(), it);  // keep the one shown, drop what is past
  }
  if (s.rate > 0) {
    // Output sample j plays at j / kRate; the stream's sample at (j / kRate - t0) * rate,
    // interpolated linearly.
    for (std::size_t i = 0; i < count; ++i) {
      const double x =
          (static_cast<double>(first + static_cast<std::int64_t>(i)) / kRate - s.t0) * s.rate;
      if (x < 0) continue;
      const auto i0 = static_cast<std::size_t>(x);
      if (i0 >= s.pcm.size()) break;
      const double a = s.pcm[i0];
      const double b = i0 + 1 < s.pcm.size() ? s.pcm[i0 + 1] : a;
      pcm[i] = static_cast<std::int16_t>(std::lround(a + (b - a) * (x - static_cast<double>(i0))));
    }
  }
  return last_;
}

render::Image RtmpOutput::render(const Pose& pose, double time) {
  try {
    const auto rig =
        services_->rigs.load(pose.rig.empty() ? services_->options.default_rig : pose.rig);
    const auto renderer =
        services_->rendering.renderers.get(*rig, settings_.width, settings_.height);
    const std::size_t n = rig->mapping.shape_names().size();
    std::vector<float> v = pose.values;
    v.resize(n + rig::BodyPose::kChannels.size(), 0.0f);
    const rig::BodyPose body = rig::BodyPose::from_channels(std::span(v).subspan(n));
    v.resize(n);
    // The springs step with the channel's clock; another avatar starts them afresh.
    if (springs_renderer_ != renderer) {
      springs_ = renderer->spring_sim();
      springs_renderer_ = renderer;
    }
    return renderer->render(v, body, springs_.advance(body, time));
  } catch (const std::exception& e) {
    log::warn("rtmp_render_failed", {{"channel", channel_->name()}, {"error", e.what()}});
    if (!last_image_.pixels.empty()) return last_image_;
    render::Image black;
    black.width = settings_.width;
    black.height = settings_.height;
    black.pixels.assign(static_cast<std::size_t>(black.width * black.height * 3), 0);
    return black;
  }
}

void RtmpOutput::run() {
  // Writing into a pipe whose reader died (ffmpeg) must give EPIPE, not kill the server.
  sigset_t pipe_signal;
  sigemptyset(&pipe_signal);
  sigaddset(&pipe_signal, SIGPIPE);
  pthread_sigmask(SIG_BLOCK, &pipe_signal, nullptr);
  const double fps = settings_.fps;
  const auto period = std::chrono::duration<double>(1.0 / fps);
  auto next_spawn = Clock::now();
  std::vector<std::int16_t> pcm;
  for (std::int64_t k = 0; !stopping_; ++k) {
    const auto deadline =
        clock_start_ + std::chrono::duration_cast<Clock::duration>(
                           std::chrono::duration<double>(static_cast<double>(k) / fps));
    std::this_thread::sleep_until(deadline);
    if (!ffmpeg_ && Clock::now() >= next_spawn && !spawn())
      next_spawn = Clock::now() + std::chrono::seconds(static_cast<int>(kRestartSeconds));
    const auto s0 = static_cast<std::int64_t>(std::llround(static_cast<double>(k) * kRate / fps));
    const auto s1 =
        static_cast<std::int64_t>(std::llround(static_cast<double>(k + 1) * kRate / fps));
    const Pose pose =
        sample(static_cast<double>(k) / fps, s0, static_cast<std::size_t>(s1 - s0), pcm);
    if (!ffmpeg_) continue;
    // Behind by more than a frame: repeat the last picture (the timeline stays whole).
    const bool late = Clock::now() - deadline > period && !last_image_.pixels.empty();
    if (!late) last_image_ = render(pose, static_cast<double>(k) / fps);
    if (!write_all(ffmpeg_->pipe_fd(3), pcm.data(), pcm.size() * sizeof(std::int16_t)) ||
        !write_all(ffmpeg_->pipe_fd(0), last_image_.pixels.data(), last_image_.pixels.size())) {
      log::warn("rtmp_ffmpeg_ended", {{"channel", channel_->name()}, {"frame", k}});
      end_ffmpeg();
      next_spawn = Clock::now() + std::chrono::seconds(static_cast<int>(kRestartSeconds));
    }
  }
  end_ffmpeg();
}

// ---- the ffmpeg child
// -----------------------------------------------------------------------------

bool RtmpOutput::write_all(int fd, const void* data, std::size_t size) {
  // The pipes do not block: a stalled ffmpeg (or one still starting) is waited for up to
  // kStallSeconds, a second once the output stops, then given up (and restarted).
  const auto* p = static_cast<const char*>(data);
  const auto since_progress = Clock::now();
  while (size > 0) {
    const ssize_t n = ::write(fd, p, size);
    if (n > 0) {
      p += n;
      size -= static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && errno != EAGAIN) return false;
    const double stalled = since(since_progress);
    if (stalled > kStallSeconds || (stopping_ && stalled > 1.0)) return false;
    pollfd pfd{fd, POLLOUT, 0};
    poll(&pfd, 1, 100);
  }
  return true;
}

bool RtmpOutput::spawn() {
  const auto& r = settings_;
  const std::string fps = std::to_string(r.fps);
  std::vector<std::string> args = {
      services_->rendering.video.ffmpeg, "-hide_banner", "-loglevel", "warning",
      // Input 0: the pictures, raw RGB at the output rate.
      "-f", "rawvideo", "-pix_fmt", "rgb24", "-video_size",
      std::to_string(r.width) + "x" + std::to_string(r.height), "-framerate", fps, "-probesize",
      "32", "-analyzeduration", "0", "-thread_queue_size", "64", "-i", "pipe:0",
      // Input 1: the sound, PCM16 mono.
      "-f", "s16le", "-ar", std::to_string(kRate), "-ac", "1", "-probesize", "32",
      "-analyzeduration", "0", "-thread_queue_size", "1024", "-i", "pipe:3", "-map", "0:v:0",
      "-map", "1:a:0",
      // H.264 with a keyframe every 2 s, constant bitrate, no B-frame delay; AAC.
      "-c:v", "libx264", "-preset", "veryfast", "-tune", "zerolatency", "-pix_fmt", "yuv420p", "-g",
      std::to_string(static_cast<int>(std::lround(2 * r.fps))), "-b:v", kbps(r.video_kbps),
      "-maxrate", kbps(r.video_kbps), "-bufsize", kbps(2 * r.video_kbps), "-c:a", "aac", "-b:a",
      kbps(r.audio_kbps), "-ar", std::to_string(kRate), "-f", "flv", r.url};
  const std::string log_path =
      (services_->options.data / ("rtmp-" + channel_->name() + ".log")).string();
  const int log_fd = open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  const ChildFd log = log_fd >= 0 ? ChildFd{1, ChildFd::Kind::kFd, log_fd} : ChildFd{1};
  ChildFd log_err = log;
  log_err.target = 2;
  try {
    // Only these descriptors reach it: no listening socket or client connection goes with it.
    ffmpeg_.emplace(
        args,
        std::vector<ChildFd>{{0, ChildFd::Kind::kWrite}, {3, ChildFd::Kind::kWrite}, log, log_err});
  } catch (const std::exception& e) {
    if (log_fd >= 0) close(log_fd);
    log::warn("rtmp_spawn_failed", {{"channel", channel_->name()}, {"error", e.what()}});
    return false;
  }
  if (log_fd >= 0) close(log_fd);
  // Room for whole frames and seconds of sound (best effort); the writing ends do not block.
  fcntl(ffmpeg_->pipe_fd(0), F_SETPIPE_SZ, 1 << 20);
  fcntl(ffmpeg_->pipe_fd(3), F_SETPIPE_SZ, 1 << 20);
  log::info("rtmp_publishing",
            {{"channel", channel_->name()}, {"pid", ffmpeg_->pid()}, {"log", log_path}});
  return true;
}

void RtmpOutput::end_ffmpeg() {
  if (!ffmpeg_) return;
  // End of input: ffmpeg flushes the encoders and closes the FLV stream (5 s, then killed).
  const ExitStatus status = ffmpeg_->finish(5.0);
  log::info("rtmp_ended",
            {{"channel", channel_->name()},
             {"status", status.code},
             log::Field::if_set("signal", status.signal ? std::to_string(status.signal) : "")});
  ffmpeg_.reset();
}

std::vector<std::shared_ptr<RtmpOutput>> start_rtmp_outputs(
    const std::shared_ptr<const StreamServices>& services, const ChannelRegistry& channels) {
  std::vector<std::shared_ptr<RtmpOutput>> out;
  for (const auto& [name, settings] : services->options.rtmp) {
    if (const auto channel = channels.find(name))
      out.push_back(RtmpOutput::start(services, channel, settings));
  }
  return out;
}

}  // namespace facecast::server
