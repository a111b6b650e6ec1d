#pragma once
// One utterance streamed in real time (the timing rules are in docs/algorithms.md#stream-pacing):
// `stream_start`, then PCM audio one chunk ahead of the frames, frames sent `lead` seconds ahead of
// their presentation time, and `stream_end`.
//
// - weights: sampled on the strand (about a microsecond a frame); a wake-up also sends what falls
//   due before the next one (`min_tick`, or the sink's send_ahead(): a channel's channel_tick), in
//   messages of at most min_tick of frames, never late;
// - frames: JPEG frames are rendered on the worker pool (up to frames_in_flight at once) and sent
//   in frame order; a frame is skipped when the sink's queue is full or when the next frame's
//   presentation time passed before it could be rendered;
// - cancel: from the next frame the face fades to rest over cancel_fade, then the stream ends.
//
// Everything it sends goes to a StreamSink, so a stream does not depend on one socket. It runs on
// `strand` (its timer wakes there and renders report back there); every call must be made on it.
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "beast.hpp"
#include "clock.hpp"
#include "out_queue.hpp"
#include "speech.hpp"
#include "stream_services.hpp"

namespace facecast::server {

/// Where a stream's messages go (a WebSocket connection).
class StreamSink {
 public:
  virtual ~StreamSink() = default;
  /// Queues `message`; returns how many of the stream's media frames back-pressure dropped (of
  /// this message or of an older weights message it replaced).
  virtual std::uint32_t send(OutMessage message) = 0;
  /// True when media messages are not being read fast enough: frames mode skips the frame
  /// instead of rendering it. The sink starts its slow-client clock.
  virtual bool media_full() = 0;
  /// Sends an `error` message about utterance `id`.
  virtual void send_error(const std::optional<std::string>& id, const Problem& problem) = 0;
  /// A fanning-out sink's tick (seconds, 0: none): weights are sent once per tick (min_tick when
  /// larger), each frame one to two ticks before it is due.
  virtual double send_ahead() const { return 0; }
};

class StreamPacer : public std::enable_shared_from_this<StreamPacer> {
 public:
  /// `asked_at`: when the utterance was asked for or reached the front of its queue, the later
  /// (time to first frame counts from there). `on_end` runs after `stream_end` was queued.
  /// `open`: incremental text; append() adds pieces until close_text().
  StreamPacer(std::shared_ptr<const StreamServices> services, net::any_io_executor strand,
              StreamSink& sink, std::string conn, SpeakRequest request,
              std::shared_ptr<PreparedSpeech> prepared, Clock::time_point asked_at,
              std::function<void()> on_end, bool open = false);

  const std::string& id() const noexcept { return request_.id; }

  /// Sends `stream_start` and what falls due at once, then paces itself.
  void start();
  /// Fades to rest over cancel_fade from the next frame, then ends (cancelled: true). Once.
  void cancel();
  /// Ends at once, silently: nothing more is sent and on_end is not called.
  void stop();

  /// Incremental text (docs/algorithms.md#incremental-text): the next piece of an open stream
  /// starts when the previous piece's speech ends, or at the first time nothing was sent for
  /// yet (frames and audio), the later; until then the face keeps its idle life and the audio is
  /// silence. Sends a `segment` message.
  void append(std::shared_ptr<PreparedSpeech> piece);
  /// No more pieces: the stream ends when the last piece (and its tail) has been sent.
  void close_text();
  bool open() const noexcept { return open_; }

 private:
  struct Render {
    int frame = 0;
    bool done = false;
    std::shared_ptr<const std::string> message;  // null if it failed
  };

  void tick();
  void arm_timer(double at);
  double frame_due(int frame) const;
  double audio_due() const;
  void send_audio(double horizon);
  void send_weights(double horizon);
  void launch_renders(double elapsed);
  void skip_frame();
  void render(int frame);
  void on_rendered(int frame, std::shared_ptr<const std::string> message,
                   std::optional<Problem> problem);
  void frame_values(int frame, std::vector<float>& out);
  rig::JointTurns step_springs(int frame, const rig::BodyPose& body);
  void count_first_frame();
  void finish();

  std::shared_ptr<const StreamServices> services_;
  const ServerOptions& o_;
  net::any_io_executor strand_;
  net::steady_timer timer_;
  unsigned timer_generation_ = 0;
  StreamSink* sink_;
  std::string conn_;  // "c12", in every log line
  SpeakRequest request_;
  std::shared_ptr<PreparedSpeech> p_;
  Clock::time_point asked_at_;
  std::function<void()> on_end_;
  GaugeShare playing_;  // active_streams: 1 from start() to the end

  std::uint32_t stream_;
  Clock::time_point start_;
  double fps_;
  bool frames_mode_;
  int names_;           // blendshapes; the head pose (yaw, pitch, roll) follows them
  int end_frame_;       // frames [0, end_frame_) are sent (cancel changes it)
  int next_frame_ = 0;  // next frame to sample or render
  int sent_ = 0, dropped_ = 0;
  bool first_sent_ = false;
  std::size_t audio_next_ = 0, audio_chunk_ = 0;  // samples
  std::vector<float> last_;                       // values of the last frame sampled
  bool have_last_ = false;
  bool cancelling_ = false;
  int fade_start_ = 0;
  std::vector<float> fade_from_;
  std::deque<Render> in_flight_;           // launch order = frame order
  std::optional<rig::SpringSim> springs_;  // frames: the avatar's spring bones, stepped here
  std::optional<Problem> render_error_;
  bool stopped_ = false;

  struct Segment {
    double t0 = 0;  // seconds from the stream's start
    std::shared_ptr<PreparedSpeech> p;
  };
  std::vector<Segment> segments_;  // in time order; the first is p_ at 0
  std::size_t segment_ = 0;        // the segment of the last frame sampled
  bool open_ = false;
  double end_time_ = 0;  // end of the last segment (with its tail)
};

}  // namespace facecast::server
