#include "stream_pacer.hpp"

#include <cmath>

#include "clock.hpp"
#include "facecast/render/image.hpp"
#include "facecast/rig/motion.hpp"
#include "log.hpp"

namespace facecast::server {
namespace {

// Frames whose send time is within this of "now" go out in this wake-up.
constexpr double kSlack = 0.0005;

}  // namespace

StreamPacer::StreamPacer(std::shared_ptr<const StreamServices> services,
                         net::any_io_executor strand, StreamSink& sink, std::string conn,
                         SpeakRequest request, std::shared_ptr<PreparedSpeech> prepared,
                         Clock::time_point asked_at, std::function<void()> on_end, bool open)
    : services_(std::move(services)),
      o_(services_->options),
      strand_(std::move(strand)),
      timer_(strand_),
      sink_(&sink),
      conn_(std::move(conn)),
      request_(std::move(request)),
      p_(std::move(prepared)),
      asked_at_(asked_at),
      on_end_(std::move(on_end)),
      playing_(services_->metrics.active_streams),
      stream_(services_->sessions.new_stream_id()),
      fps_(request_.fps),
      frames_mode_(request_.output == Output::kFrames),
      names_(static_cast<int>(p_->rig->mapping.shape_names().size())),
      end_frame_(p_->frames),
      last_(static_cast<std::size_t>(names_) + rig::BodyPose::kChannels.size(), 0.0f),
      open_(open),
      end_time_(p_->duration) {
  segments_.push_back(Segment{0.0, p_});
  if (open_) end_frame_ = std::numeric_limits<int>::max();
  if (p_->sample_rate > 0)
    audio_chunk_ =
        std::max<std::size_t>(1, static_cast<std::size_t>(o_.audio_chunk * p_->sample_rate));
}

void StreamPacer::start() {
  const auto keep = shared_from_this();  // on_end may drop the owner's reference
  StreamStart s;
  s.id = request_.id;
  s.stream = stream_;
  s.output = request_.output;
  s.fps = fps_;
  s.frames = p_->frames;
  s.duration = p_->duration;
  s.speech_duration = p_->speech_duration;
  s.sample_rate = p_->sample_rate;
  s.samples = p_->pcm.size();
  s.width = request_.width;
  s.height = request_.height;
  s.rig = p_->rig->id;
  s.lead = o_.lead;
  auto start_message =
      OutMessage::control(stream_start_message(s, p_->rig->mapping.shape_names(), p_->utterance));
  if (open_)
    start_message.data =
        std::make_shared<const std::string>(open_stream_start(*start_message.data));
  start_message.boundary = Boundary::kStart;
  sink_->send(std::move(start_message));
  if (stopped_) return;
  start_ = Clock::now();
  playing_.set(1);
  services_->metrics.streams_total.fetch_add(1);
  log::info("stream_start", {{"conn", conn_},
                             {"id", request_.id},
                             {"stream", stream_},
                             {"frames", p_->frames},
                             {"duration", p_->duration}});
  tick();
}

void StreamPacer::cancel() {
  if (cancelling_ || stopped_) return;
  const auto keep = shared_from_this();
  cancelling_ = true;
  open_ = false;
  fade_start_ = next_frame_;
  fade_from_ = last_;
  const int fade_frames =
      have_last_ ? static_cast<int>(std::ceil(o_.cancel_fade * fps_ - 1e-9)) : 0;
  end_frame_ = next_frame_ + fade_frames;
  log::info("cancel",
            {{"conn", conn_}, {"id", request_.id}, {"stream", stream_}, {"at_frame", next_frame_}});
  tick();
}

void StreamPacer::stop() {
  if (stopped_) return;
  stopped_ = true;
  ++timer_generation_;  // a pending wake-up is for nothing
  timer_.cancel();
  playing_.set(0);
}

// ---- incremental text ------------------------------------------------------------------------

void StreamPacer::append(std::shared_ptr<PreparedSpeech> piece) {
  if (stopped_ || !open_) return;
  const auto keep = shared_from_this();
  const Segment& last = segments_.back();
  const int rate = p_->sample_rate;
  // Nothing already sent may change: the piece starts after the sent frames and audio.
  double t0 = std::max(last.t0 + last.p->speech_duration, next_frame_ / fps_);
  if (rate > 0) t0 = std::max(t0, static_cast<double>(audio_next_) / rate);
  SegmentInfo info;
  info.id = request_.id;
  info.stream = stream_;
  info.index = static_cast<int>(segments_.size());
  info.start = t0;
  info.duration = piece->duration;
  info.first_frame = static_cast<int>(std::ceil(t0 * fps_ - 1e-9));
  info.end_frame = static_cast<int>(std::ceil((t0 + piece->duration) * fps_ - 1e-9));
  if (rate > 0) {
    auto& pcm = p_->pcm;
    const auto first = static_cast<std::size_t>(std::llround(t0 * rate));
    pcm.resize(first, 0);  // silence up to the piece (or cut the silence sent ahead of it)
    pcm.insert(pcm.end(), piece->pcm.begin(), piece->pcm.end());
    info.first_sample = first;
    info.end_sample = pcm.size();
  }
  end_time_ = t0 + piece->duration;
  sink_->send(OutMessage::control(segment_message(info, piece->utterance)));
  segments_.push_back(Segment{t0, std::move(piece)});
  if (!stopped_) tick();
}

void StreamPacer::close_text() {
  if (stopped_ || !open_) return;
  const auto keep = shared_from_this();
  open_ = false;
  end_frame_ = std::max(next_frame_, static_cast<int>(std::ceil(end_time_ * fps_ - 1e-9)));
  if (p_->pcm.size() < audio_next_) p_->pcm.resize(audio_next_);
  tick();
}

// ---- timing ------------------------------------------------------------------------------------

// Send times, in seconds since the stream's start: frame f at f / fps - lead, the audio chunk that
// starts at sample i one chunk earlier than the frames it belongs to.
double StreamPacer::frame_due(int frame) const {
  return frame / fps_ - o_.lead;
}

double StreamPacer::audio_due() const {
  return audio_next_ / static_cast<double>(p_->sample_rate) - o_.lead - o_.audio_chunk;
}

void StreamPacer::tick() {
  if (stopped_) return;
  const double elapsed = seconds(Clock::now() - start_);
  // With min_tick > 0 a wake-up also sends what falls due before the next one (never late, at
  // most min_tick early), so a stream writes one message per min_tick instead of one per frame.
  // A sink that fans out may ask for more (a channel: channel_tick): a wake-up per send_ahead,
  // sending what falls due before the wake-up after next, so its thousands of subscribers are
  // written to a few times a second and the last one still gets each frame before it is due (the
  // fan-out has a whole tick). The messages still carry at most min_tick of frames.
  const double spacing = frames_mode_ ? o_.min_tick : std::max(o_.min_tick, sink_->send_ahead());
  const double ahead = frames_mode_ ? 0.0 : spacing + sink_->send_ahead();
  if (!cancelling_) send_audio(elapsed + ahead);
  if (frames_mode_) {
    launch_renders(elapsed);
  } else {
    send_weights(elapsed + ahead);
  }
  if (stopped_) return;
  if (next_frame_ >= end_frame_ && in_flight_.empty()) {
    finish();
    return;
  }
  double next = INFINITY;
  const bool renders_full =
      frames_mode_ && static_cast<int>(in_flight_.size()) >= o_.frames_in_flight;
  if (next_frame_ < end_frame_ && !renders_full) next = frame_due(next_frame_) - ahead;
  if (!cancelling_ && (audio_next_ < p_->pcm.size() || open_))
    next = std::min(next, audio_due() - ahead);
  if (std::isinf(next)) return;  // waiting for renders; on_rendered ticks
  arm_timer(std::max(next, elapsed + spacing));
}

void StreamPacer::arm_timer(double at) {
  const unsigned generation = ++timer_generation_;
  timer_.expires_at(start_ + from_seconds(at));
  timer_.async_wait([self = shared_from_this(), generation](beast::error_code ec) {
    if (ec || generation != self->timer_generation_) return;
    self->tick();
  });
}

// ---- sending -----------------------------------------------------------------------------------

// Sends every audio chunk whose send time is at or before `horizon` (seconds since start).
void StreamPacer::send_audio(double horizon) {
  auto& pcm = p_->pcm;
  if (p_->sample_rate <= 0) return;
  while ((audio_next_ < pcm.size() || open_) && audio_due() <= horizon + kSlack) {
    // An open stream waiting for text sends silence, so the client's audio clock keeps running.
    if (open_ && pcm.size() < audio_next_ + audio_chunk_) pcm.resize(audio_next_ + audio_chunk_);
    const std::size_t n = std::min(audio_chunk_, pcm.size() - audio_next_);
    auto msg = std::make_shared<const std::string>(
        audio_message(stream_, static_cast<std::uint32_t>(audio_next_), p_->sample_rate,
                      pcm.data() + audio_next_, n));
    sink_->send(OutMessage{std::move(msg), OutKind::kAudio, stream_, 0});
    services_->metrics.audio_samples_sent_total.fetch_add(n);
    audio_next_ += n;
  }
}

// Sends every frame whose send time is at or before `horizon`, in messages of at most min_tick
// of frames (at least one).
void StreamPacer::send_weights(double horizon) {
  const int most = std::max(1, static_cast<int>(std::floor(o_.min_tick * fps_ + 1e-6)));
  thread_local std::vector<float> values, frame;
  while (next_frame_ < end_frame_ && frame_due(next_frame_) <= horizon + kSlack) {
    const int first = next_frame_;
    values.clear();
    while (next_frame_ < end_frame_ && next_frame_ - first < most &&
           frame_due(next_frame_) <= horizon + kSlack) {
      frame_values(next_frame_, frame);
      values.insert(values.end(), frame.begin(), frame.end());
      ++next_frame_;
    }
    const auto count = static_cast<std::uint32_t>(next_frame_ - first);
    auto msg = std::make_shared<const std::string>(weights_message(
        stream_, static_cast<std::uint32_t>(first), fps_, count, values.data(), values.size()));
    count_first_frame();
    const std::uint32_t dropped =
        sink_->send(OutMessage{std::move(msg), OutKind::kWeights, stream_, count});
    sent_ += static_cast<int>(count - dropped);
    dropped_ += static_cast<int>(dropped);
    services_->metrics.frames_dropped.weights.fetch_add(dropped);
    if (stopped_) return;
  }
}

void StreamPacer::count_first_frame() {
  if (first_sent_) return;
  first_sent_ = true;
  services_->metrics.time_to_first_frame_seconds.observe(seconds(Clock::now() - asked_at_));
}

// Starts the renders of the frames due by `elapsed`, skipping those nobody would see in time.
void StreamPacer::launch_renders(double elapsed) {
  while (next_frame_ < end_frame_ && static_cast<int>(in_flight_.size()) < o_.frames_in_flight &&
         frame_due(next_frame_) <= elapsed + kSlack) {
    if (sink_->media_full()) {  // the client is not reading: skip (late or not)
      skip_frame();
      continue;
    }
    // A frame is useless once the next frame's presentation time has passed: skip it.
    if ((next_frame_ + 1) / fps_ < elapsed && next_frame_ + 1 < end_frame_) {
      log::debug("frame_skipped", {{"conn", conn_},
                                   {"stream", stream_},
                                   {"frame", next_frame_},
                                   {"late_s", elapsed - next_frame_ / fps_}});
      skip_frame();
      continue;
    }
    render(next_frame_++);
  }
}

void StreamPacer::skip_frame() {
  if (!springs_) springs_ = p_->renderer->spring_sim();
  if (!springs_->empty()) {  // the springs step through dropped frames too (the first ones too)
    std::vector<float> values;
    frame_values(next_frame_, values);
    step_springs(next_frame_, rig::BodyPose::from_channels(
                                  std::span(values).subspan(static_cast<std::size_t>(names_))));
  }
  ++dropped_;
  ++next_frame_;
  services_->metrics.frames_dropped.frames.fetch_add(1);
}

// Renders `frame` on the worker pool; on_rendered gets the JPEG message on the strand.
void StreamPacer::render(int frame) {
  std::vector<float> values;
  frame_values(frame, values);
  const std::size_t n = static_cast<std::size_t>(names_);
  const rig::BodyPose head = rig::BodyPose::from_channels(std::span(values).subspan(n));
  values.resize(n);  // the renderer takes the shapes, and the body pose apart
  in_flight_.push_back(Render{frame, false, nullptr});
  net::post(services_->workers,
            [self = shared_from_this(), strand = strand_, renderer = p_->renderer,
             values = std::move(values), head, springs = step_springs(frame, head),
             stream = stream_, frame, fps = fps_, quality = o_.jpeg_quality] {
              std::shared_ptr<const std::string> msg;
              std::optional<Problem> problem;
              try {
                const auto t0 = Clock::now();
                const render::Image image = renderer->render(values, head, springs);
                const std::string jpeg = render::encode_jpeg(image, quality);
                msg = std::make_shared<const std::string>(
                    jpeg_message(stream, static_cast<std::uint32_t>(frame), fps, jpeg));
                self->services_->metrics.render_seconds.observe(seconds(Clock::now() - t0));
              } catch (...) {
                problem = describe(std::current_exception());
              }
              net::post(strand, [self, frame, msg = std::move(msg), problem] {
                self->on_rendered(frame, msg, problem);
              });
            });
}

void StreamPacer::on_rendered(int frame, std::shared_ptr<const std::string> message,
                              std::optional<Problem> problem) {
  if (stopped_) return;
  for (auto& r : in_flight_) {
    if (r.frame == frame) {
      r.done = true;
      r.message = std::move(message);
    }
  }
  if (problem && !render_error_) render_error_ = problem;
  while (!in_flight_.empty() && in_flight_.front().done) {
    auto r = std::move(in_flight_.front());
    in_flight_.pop_front();
    if (!r.message) continue;
    if (sink_->media_full()) {
      ++dropped_;
      services_->metrics.frames_dropped.frames.fetch_add(1);
      continue;
    }
    count_first_frame();
    ++sent_;
    sink_->send(OutMessage{std::move(r.message), OutKind::kJpeg, stream_, 1});
  }
  if (render_error_) {
    // Rendering failed (GL): report it and end the stream with what was sent.
    const Problem p = *render_error_;
    render_error_.reset();
    sink_->send_error(request_.id, p);
    if (stopped_) return;
    end_frame_ = next_frame_;
    if (in_flight_.empty()) {
      finish();
      return;
    }
  }
  tick();
}

// The spring bones' turns at `frame`, stepped on the strand in frame order: a stream's hair moves
// the same whichever frames the pool finishes first.
rig::JointTurns StreamPacer::step_springs(int frame, const rig::BodyPose& body) {
  if (!springs_) springs_ = p_->renderer->spring_sim();
  return springs_->advance(body, frame / fps_);
}

// The blendshape weights of `frame`, then the body pose's channels (rig::BodyPose::kChannels).
void StreamPacer::frame_values(int frame, std::vector<float>& out) {
  out.resize(last_.size());
  if (cancelling_ && frame >= fade_start_) {
    // Frame fade_start_ is one step into the fade, the last fade frame is at rest.
    anim::fade_to_rest(fade_from_, (frame - fade_start_ + 1) / fps_, o_.cancel_fade, out);
  } else {
    const auto n = static_cast<std::size_t>(names_);
    const double t = frame / fps_;
    while (segment_ + 1 < segments_.size() && segments_[segment_ + 1].t0 <= t) ++segment_;
    const Segment& seg = segments_[segment_];
    rig::BodyPose pose;
    seg.p->performance->sample(t - seg.t0, std::span<float>(out.data(), n), &pose);
    std::ranges::copy(pose.channels(), out.begin() + static_cast<std::ptrdiff_t>(n));
  }
  last_ = out;
  have_last_ = true;
}

void StreamPacer::finish() {
  // Counted before the client can see the end (its next request may read the metrics).
  services_->metrics.frames_sent.of(frames_mode_).fetch_add(static_cast<std::uint64_t>(sent_));
  if (cancelling_) services_->metrics.streams_cancelled_total.fetch_add(1);
  const StreamEnd end{request_.id, stream_, sent_, dropped_, cancelling_};
  auto end_message = OutMessage::control(stream_end_message(end));
  end_message.boundary = Boundary::kEnd;
  sink_->send(std::move(end_message));
  log::info("stream_end", {{"conn", conn_},
                           {"id", request_.id},
                           {"stream", stream_},
                           {"frames", sent_},
                           {"dropped", dropped_},
                           {"cancelled", cancelling_}});
  const bool ended_here = !stopped_;
  stop();
  if (ended_here) on_end_();
}

}  // namespace facecast::server
