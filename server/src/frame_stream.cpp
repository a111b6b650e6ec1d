#include "frame_stream.hpp"

namespace facecast::server {

bool FrameStream::write_frames(const std::vector<net::const_buffer>& buffers) {
  auto& socket = next_.socket();
  beast::error_code ec;
  if (!socket.non_blocking()) socket.non_blocking(true, ec);
  const std::size_t total = net::buffer_size(buffers);
  std::size_t sent = ec ? 0 : socket.write_some(buffers, ec);
  if (ec == net::error::would_block || ec == net::error::try_again) {
    ec = {};
    sent = 0;
  }
  if (!ec && sent == total) return true;
  // The rest when the socket can take it (or the error, reported from the strand).
  writing_ = true;
  rest_.clear();
  beast::buffers_suffix<std::vector<net::const_buffer>> left(buffers);
  left.consume(sent);
  for (const auto b : left) rest_.push_back(b);
  const auto finish = [this, sent, owner = owner_.lock()](beast::error_code e, std::size_t n) {
    writing_ = false;
    write_beast_bytes();  // what Beast queued meanwhile goes next
    on_written_(e, sent + n);
    if (!writing_) idle();
  };
  if (ec) {
    net::post(get_executor(), [finish, ec] { finish(ec, 0); });
  } else {
    net::async_write(socket, rest_, finish);
  }
  return false;
}

void FrameStream::write_beast_bytes() {
  auto owner = owner_.lock();
  if (beast_bytes_.empty() || !owner) return;
  writing_ = true;
  beast_writing_.swap(beast_bytes_);
  beast_bytes_.clear();
  net::async_write(next_.socket(), net::buffer(beast_writing_),
                   [this, owner = std::move(owner)](beast::error_code, std::size_t) {
                     // A failed write shows on the read side too, which ends the session.
                     writing_ = false;
                     beast_writing_.clear();
                     write_beast_bytes();
                     if (!writing_) idle();
                   });
}

// Nothing is being written: the session's next frames, or the teardown waiting for the last byte.
void FrameStream::idle() {
  if (on_idle_) on_idle_();
  if (!writing_ && beast_bytes_.empty() && flushed_) std::exchange(flushed_, nullptr)();
}

void FrameStream::when_flushed(std::function<void()> then) {
  flushed_ = std::move(then);
  if (!writing_ && beast_bytes_.empty())
    net::post(get_executor(), [this, owner = owner_.lock()] {
      if (!writing_) idle();
    });
}

void teardown(beast::role_type role, FrameStream& stream, beast::error_code& ec) {
  using websocket::teardown;
  teardown(role, stream.next_layer().socket(), ec);
}

}  // namespace facecast::server
