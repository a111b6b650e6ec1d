#pragma once
// The byte stream under a WebSocket session: a beast::tcp_stream whose write side is one ordered
// queue, so a session can write its queued messages as ready-made WebSocket frames, several in one
// gather write (one sendmsg), while Beast keeps the handshake, the reading and its own control
// frames (pong, keep-alive ping, close), which come through async_write_some below and go out
// behind the frames being written.
//
// Why: a channel fans one message out to thousands of subscribers; through Beast's write path each
// message costs a composed operation, a handler allocation and a sendmsg per subscriber, which at
// 10,000 subscribers x 35 messages a second is more than two cores. Server frames are unmasked
// and permessage-deflate is off, so a message's frame is its 2-10 header bytes and the shared
// payload itself (docs/algorithms.md#stream-pacing, "Writing").
//
// Everything runs on the session's strand (the socket's executor).
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "beast.hpp"
#include "facecast/server/protocol.hpp"

namespace facecast::server {

class FrameStream {
 public:
  using executor_type = beast::tcp_stream::executor_type;
  using next_layer_type = beast::tcp_stream;

  explicit FrameStream(tcp::socket&& socket) : next_(std::move(socket)) {}

  executor_type get_executor() noexcept { return next_.get_executor(); }
  next_layer_type& next_layer() noexcept { return next_; }

  /// Frames of the session. Writes `buffers` (whole frames) if nothing else is being written:
  /// true when every byte went out at once (the common case: no allocation, no completion);
  /// otherwise the rest goes out asynchronously and on_written(ec, bytes) runs when it has.
  /// `buffers` and the memory they point to must stay valid until then. Not to be called while
  /// busy().
  bool write_frames(const std::vector<net::const_buffer>& buffers);
  void on_written(std::function<void(beast::error_code, std::size_t)> f) {
    on_written_ = std::move(f);
  }
  /// True while frames or Beast's bytes are being written; `on_idle` runs when that ends.
  bool busy() const noexcept { return writing_; }
  void on_idle(std::function<void()> f) { on_idle_ = std::move(f); }
  /// The object this stream lives in (the session): kept alive by every write in flight.
  void set_owner(std::weak_ptr<void> owner) { owner_ = std::move(owner); }

  // AsyncStream for Beast.
  template <class MutableBuffers, class Handler>
  auto async_read_some(const MutableBuffers& buffers, Handler&& handler) {
    return next_.async_read_some(buffers, std::forward<Handler>(handler));
  }
  /// Beast's own bytes (the 101 answer, control frames): copied behind what is being written and
  /// completed at once (they are a few dozen bytes; the order on the wire is what matters). A
  /// peer that sends pings without reading the pongs would grow them without bound: past
  /// `control_limit` bytes waiting, the write fails (no_buffer_space), which fails Beast's read
  /// and closes the connection.
  template <class ConstBuffers, class Handler>
  void async_write_some(const ConstBuffers& buffers, Handler&& handler) {
    const std::size_t n = net::buffer_size(buffers);
    if (beast_bytes_.size() + beast_writing_.size() + n > control_limit_) {
      control_overflow_ = true;
      net::post(get_executor(), beast::bind_front_handler(std::forward<Handler>(handler),
                                                          net::error::no_buffer_space, 0));
      return;
    }
    const std::size_t at = beast_bytes_.size();
    beast_bytes_.resize(at + n);
    net::buffer_copy(net::buffer(beast_bytes_.data() + at, n), buffers);
    net::post(get_executor(),
              beast::bind_front_handler(std::forward<Handler>(handler), beast::error_code{}, n));
    if (!writing_) write_beast_bytes();
  }

  /// Bytes of Beast's control frames that may wait unwritten (max_control_bytes).
  void limit_control_bytes(std::size_t limit) noexcept { control_limit_ = limit; }
  /// True once a control frame was refused for that limit.
  bool control_overflow() const noexcept { return control_overflow_; }

  /// Teardown (Beast's close): once every queued byte is out, `then` runs.
  void when_flushed(std::function<void()> then);

 private:
  void write_beast_bytes();
  void idle();

  beast::tcp_stream next_;
  bool writing_ = false;
  std::string beast_bytes_, beast_writing_;  // queued, and being written
  std::vector<net::const_buffer> rest_;      // frames not written at once
  std::size_t control_limit_ = 65536;
  bool control_overflow_ = false;
  std::function<void()> on_idle_, flushed_;
  std::function<void(beast::error_code, std::size_t)> on_written_;
  std::weak_ptr<void> owner_;
};

// Beast's teardown of a WebSocket over a FrameStream (found by argument-dependent lookup): the
// queued bytes (the close frame among them) first, then the TCP teardown.
void teardown(beast::role_type role, FrameStream& stream, beast::error_code& ec);

template <class TeardownHandler>
void async_teardown(beast::role_type role, FrameStream& stream, TeardownHandler&& handler) {
  auto h = std::make_shared<std::decay_t<TeardownHandler>>(std::forward<TeardownHandler>(handler));
  stream.when_flushed([role, &stream, h] {
    using websocket::async_teardown;
    async_teardown(role, stream.next_layer().socket(), std::move(*h));
  });
}

}  // namespace facecast::server
