#pragma once
// One WebSocket connection, the transport (Beast chat-multi / advanced server shape): everything
// runs on the connection's strand (the socket's executor); one async_read in flight; outgoing
// messages wait in an OutQueue and go out as ready-made frames, all that is queued in one gather
// write (frame_stream.hpp). Text messages are parsed here and
// handed to the connection's SpeakQueue (speak, cancel) or answered (ping); the streams it plays
// send through this session as their StreamSink.
//
// Slow clients (docs/algorithms.md#stream-pacing): once its queue overflows (write_queue media
// messages, or write_queue unread control messages), a client has slow_client_grace to drain the
// queue completely, or it is closed with 1008; 16 x write_queue unread control messages close it
// at once.
#include <memory>
#include <optional>
#include <string>

#include "auth.hpp"
#include "beast.hpp"
#include "channel.hpp"
#include "clock.hpp"
#include "frame_stream.hpp"
#include "out_queue.hpp"
#include "sessions.hpp"
#include "speak_queue.hpp"

namespace facecast::server {

struct Services;

struct LiveAudio;

class WebSocketSession : public std::enable_shared_from_this<WebSocketSession>,
                         public Closable,
                         public StreamSink,
                         public ChannelMember {
 public:
  WebSocketSession(tcp::socket&& socket, std::shared_ptr<Services> services,
                   std::unique_ptr<ConnectionSlot> slot, std::uint64_t id, std::string remote);
  ~WebSocketSession();

  /// Completes the upgrade of `request` (already checked: path, Host, Origin, subprotocol) for
  /// `who`; nullopt: the first message must be {"type": "auth", "token": ...} (auth.hpp).
  void run(Request request, bool subprotocol, std::optional<Principal> who);
  /// Thread-safe: closes with 1001 (going away).
  void shut_down() override;

  // StreamSink (on the strand)
  std::uint32_t send(OutMessage message) override;
  bool media_full() override;
  void send_error(const std::optional<std::string>& id, const Problem& problem) override;
  // ChannelMember (thread-safe)
  void deliver(OutBatch batch) override;

 private:
  // Channels and incremental text (websocket_live.cpp): true when `m` was one of theirs.
  bool route_live(ClientMessage& m);
  std::shared_ptr<Channel> channel_named(const std::string& name) const;
  void leave_channel();

  void on_accept(beast::error_code ec);
  void send_hello();
  // The first message of a connection that authenticates in it.
  void authenticate(std::string_view text);
  void do_read();
  void on_read(beast::error_code ec, std::size_t bytes);
  bool take_message_token();
  void handle_text(std::string_view text);
  // Live audio in (websocket_audio.cpp).
  void handle_binary(std::string_view bytes);
  // Live audio in (websocket_audio.cpp): the analysis runs on the stream's worker strand.
  void open_audio(int rate, bool aligned);
  void post_audio_weights(std::uint32_t stream, int first, int count, double fps,
                          std::vector<float> values);
  void end_audio();
  void live_expressions(const std::string& tags);
  void live_text(const AudioTextRequest& text);
  // Runs `change(LiveLipsync&)` on the open stream's strand; what it throws goes back as an error
  // message. `what`: the message's type, for the error when no stream is open.
  template <class Change>
  void change_live_audio(const char* what, Change change);

  // Queues `message` (drop and slow-client rules); do_write() sends what is queued.
  std::uint32_t enqueue(OutMessage message);
  void do_write();
  void on_write(beast::error_code ec, std::size_t bytes);
  void wrote(std::size_t bytes);
  void mark_stalled();
  void on_watchdog();
  void close_slow_client();
  void close_with(websocket::close_code code, const char* reason);
  void on_closed();

  websocket::stream<FrameStream> ws_;
  std::shared_ptr<Services> services_;
  std::unique_ptr<ConnectionSlot> slot_;
  GaugeShare open_;  // ws_connections: 1
  std::uint64_t id_;
  std::string conn_;           // "c12", in every log line
  std::string remote_;         // address:port
  std::string forwarded_for_;  // X-Forwarded-For of the upgrade request ("" without a proxy)
  beast::flat_buffer buffer_;
  OutQueue queue_;
  double message_tokens_;  // messages_per_second bucket
  Clock::time_point message_tokens_at_ = Clock::now();
  std::vector<std::array<std::uint8_t, 10>> heads_;  // frame headers of the messages being written
  std::vector<net::const_buffer> frames_;            // their headers and payloads
  std::shared_ptr<SpeakQueue> speaks_;
  std::shared_ptr<Channel> subscribed_;  // the channel this connection watches
  std::vector<std::string> producing_;   // channels whose producer token it gave
  std::unique_ptr<LiveAudio> audio_;     // the open live audio stream, if any
  std::optional<Principal> who_;         // who connected (nullopt until the auth message)

  net::steady_timer watchdog_;
  std::optional<Clock::time_point> stalled_since_;
  net::steady_timer close_timer_;
  bool accepted_ = false, closing_ = false, closed_ = false;
};

}  // namespace facecast::server
