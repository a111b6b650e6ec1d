#pragma once
// An asynchronous facecast.v1 WebSocket client (Boost.Beast) for the benchmarks: connect and
// handshake, a read loop, a write queue, close. A subclass says what a client sends and measures
// by overriding the handlers; every handler runs on the client's strand, and so must send() and
// close() (timers and posts of a subclass go through executor()).
#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/beast/core/tcp_stream.hpp>
#include <boost/beast/websocket/stream.hpp>
#include <chrono>
#include <deque>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace fctest {

class AsyncWsClient : public std::enable_shared_from_this<AsyncWsClient> {
 public:
  using Clock = std::chrono::steady_clock;
  struct Options {
    unsigned short port = 0;  // of the server on 127.0.0.1
    std::string target = "/ws";
    std::vector<std::pair<std::string, std::string>> headers{};  // added to the upgrade request
    std::string subprotocol = "facecast.v1";                     // empty: none offered
    bool no_delay = false;  // TCP_NODELAY: small messages go out without waiting (live audio)
    double timeout = 30;    // seconds for the connect and the handshake together
  };
  struct Message {
    bool text = false;
    std::string_view data;  // valid during on_message only
    Clock::time_point at;   // when its read completed
  };

  AsyncWsClient(boost::asio::io_context& ioc, Options options);
  virtual ~AsyncWsClient() = default;
  AsyncWsClient(const AsyncWsClient&) = delete;
  AsyncWsClient& operator=(const AsyncWsClient&) = delete;

  /// Connects and handshakes; then on_open(), or on_error() when either fails. The client must be
  /// owned by a shared_ptr: its operations hold it.
  void start();
  /// Queues one message: messages go out one at a time, in order. Ignored after close().
  void send(std::string data, bool text = true);
  /// Closes (1000) once the queue is written. From then on no message is delivered and no error
  /// reported.
  void close();
  /// The client's strand.
  boost::asio::any_io_executor executor() { return ws_.get_executor(); }

 protected:
  /// The handshake completed; the read loop runs.
  virtual void on_open() {}
  /// One message, in order of arrival.
  virtual void on_message(const Message& message) = 0;
  /// A queued message was written.
  virtual void on_sent() {}
  /// An operation failed (a timeout included): "connect: ...", "handshake: ...", "read: ..." or
  /// "write: ...". A failed read or write is not retried.
  virtual void on_error(const std::string& what) = 0;

 private:
  void on_connect(boost::beast::error_code ec);
  void on_handshake(boost::beast::error_code ec);
  void read();
  void on_read(boost::beast::error_code ec);
  void write_front();
  void on_write(boost::beast::error_code ec);
  void close_now();
  void fail(const char* operation, boost::beast::error_code ec);

  boost::beast::websocket::stream<boost::beast::tcp_stream> ws_;
  Options options_;
  boost::beast::flat_buffer buffer_;
  std::deque<std::pair<std::string, bool>> queue_;  // data, text; the front is being written
  bool closing_ = false;
};

}  // namespace fctest
