#pragma once
// One WebSocket connection (Beast chat-multi / advanced server shape): everything runs on the
// connection's strand (the socket's executor); one async_read and at most one async_write in
// flight; outgoing messages wait in a bounded queue.
//
// Streaming: speak requests queue in order; each is prepared (analysis, animation, renderer) on
// the worker pool as soon as it arrives, then streamed when it reaches the front. A stream sends
// `stream_start`, then frames `lead` seconds ahead of real time (a timer on the strand wakes at the
// next frame's send time), PCM audio one chunk ahead of the frames, and `stream_end`. Weights are
// sampled on the strand (about a microsecond a frame); JPEG frames are rendered on the worker pool
// (up to frames_in_flight per stream) and sent in frame order.
//
// Back-pressure: when `write_queue` media messages are waiting, a new weights message replaces the
// oldest queued one of its stream (drop oldest) and a frame is skipped; frames whose presentation
// time has passed before they could be rendered are skipped too. Both count as `dropped`. A queue
// that is not drained for `slow_client_grace` closes the connection with 1008.
#include <chrono>
#include <deque>
#include <memory>
#include <optional>
#include <string>

#include "beast.hpp"
#include "speech.hpp"
#include "state.hpp"

namespace facecast::server {

class WebSocketSession : public std::enable_shared_from_this<WebSocketSession>, public Closable {
 public:
  WebSocketSession(tcp::socket&& socket, std::shared_ptr<State> state,
                   std::unique_ptr<ConnectionSlot> slot, std::uint64_t id, std::string remote);
  ~WebSocketSession();

  /// Completes the upgrade of `request` (already checked: path, token, Origin, subprotocol).
  void run(Request request, bool subprotocol);
  /// Thread-safe: closes with 1001 (going away).
  void shut_down() override;

 private:
  using Clock = std::chrono::steady_clock;
  struct Item;
  struct Stream;
  enum class OutKind { kControl, kAudio, kWeights, kJpeg };
  struct Out {
    std::shared_ptr<const std::string> data;
    OutKind kind = OutKind::kControl;
    std::uint32_t stream = 0;
    std::uint32_t frames = 0;  // media frames in it
  };

  void on_accept(beast::error_code ec);
  void do_read();
  void on_read(beast::error_code ec, std::size_t bytes);
  void handle_text(std::string_view text);
  void on_speak(SpeakRequest&& request);
  void on_cancel(const CancelRequest& request);
  void send_error(const std::optional<std::string>& id, const Problem& problem);

  void prepare(const std::shared_ptr<Item>& item);
  void on_prepared(const std::shared_ptr<Item>& item, std::shared_ptr<PreparedSpeech> prepared,
                   std::optional<Problem> problem);
  void start_next();
  void start_stream(std::shared_ptr<Item> item);
  void begin_cancel();
  void tick();
  void arm_timer(Clock::time_point when);
  void frame_values(Stream& s, int frame, std::vector<float>& out);
  void send_weights(Stream& s, double horizon);
  void launch_renders(Stream& s, double elapsed);
  void on_rendered(std::uint32_t stream, int frame, std::shared_ptr<const std::string> message,
                   std::optional<Problem> problem);
  void finish_stream();

  void send_control(std::string text);
  void enqueue(Out out);
  void do_write();
  void on_write(beast::error_code ec, std::size_t bytes);
  void mark_stalled();
  void on_watchdog();
  void close_with(websocket::close_code code, const char* reason);
  void on_closed();
  void clear_streams();

  websocket::stream<beast::tcp_stream> ws_;
  std::shared_ptr<State> state_;
  std::unique_ptr<ConnectionSlot> slot_;
  std::uint64_t id_;
  std::string conn_;    // "c12", in every log line
  std::string remote_;  // address:port
  beast::flat_buffer buffer_;

  std::deque<Out> queue_;
  bool writing_ = false;
  int media_queued_ = 0;

  std::deque<std::shared_ptr<Item>> pending_;  // waiting utterances, in order
  std::unique_ptr<Stream> active_;
  net::steady_timer timer_;
  unsigned timer_generation_ = 0;
  net::steady_timer watchdog_;
  std::optional<Clock::time_point> stalled_since_;
  net::steady_timer close_timer_;

  bool accepted_ = false, closing_ = false, closed_ = false;
  double tokens_;  // speak rate limit (token bucket)
  Clock::time_point tokens_at_ = Clock::now();
};

}  // namespace facecast::server
