#include "ws_client.hpp"

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/http/field.hpp>

namespace fctest {

namespace net = boost::asio;
namespace beast = boost::beast;
namespace websocket = beast::websocket;
using tcp = net::ip::tcp;

namespace {

AsyncWsClient::Clock::duration seconds(double s) {
  return std::chrono::duration_cast<AsyncWsClient::Clock::duration>(
      std::chrono::duration<double>(s));
}

}  // namespace

AsyncWsClient::AsyncWsClient(net::io_context& ioc, Options options)
    : ws_(net::make_strand(ioc)), options_(std::move(options)) {}

void AsyncWsClient::start() {
  auto& stream = beast::get_lowest_layer(ws_);
  stream.expires_after(seconds(options_.timeout));
  stream.async_connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), options_.port),
                       [self = shared_from_this()](beast::error_code ec) { self->on_connect(ec); });
}

void AsyncWsClient::on_connect(beast::error_code ec) {
  if (ec) return fail("connect", ec);
  if (options_.no_delay) beast::get_lowest_layer(ws_).socket().set_option(tcp::no_delay(true), ec);
  ws_.set_option(websocket::stream_base::decorator(
      [headers = options_.headers, protocol = options_.subprotocol](websocket::request_type& req) {
        if (!protocol.empty()) req.set(beast::http::field::sec_websocket_protocol, protocol);
        for (const auto& [name, value] : headers) req.set(name, value);
      }));
  // The connect's deadline holds for the handshake as well: the TCP stream's timer is armed only
  // while an operation runs, so a failed client leaves none pending (a WebSocket timeout option
  // would, keeping its io_context running).
  ws_.async_handshake("127.0.0.1:" + std::to_string(options_.port), options_.target,
                      [self = shared_from_this()](beast::error_code e) { self->on_handshake(e); });
}

void AsyncWsClient::on_handshake(beast::error_code ec) {
  if (ec) return fail("handshake", ec);
  beast::get_lowest_layer(ws_).expires_never();  // open: streams run as long as they like
  read();
  on_open();
}

void AsyncWsClient::read() {
  ws_.async_read(buffer_, [self = shared_from_this()](beast::error_code ec, std::size_t) {
    self->on_read(ec);
  });
}

void AsyncWsClient::on_read(beast::error_code ec) {
  const auto at = Clock::now();
  if (closing_) return;  // the close reads what is left
  if (ec) return fail("read", ec);
  const auto data = buffer_.data();
  on_message({ws_.got_text(), {static_cast<const char*>(data.data()), data.size()}, at});
  buffer_.consume(buffer_.size());
  if (!closing_) read();
}

void AsyncWsClient::send(std::string data, bool text) {
  if (closing_) return;
  queue_.emplace_back(std::move(data), text);
  if (queue_.size() == 1) write_front();
}

void AsyncWsClient::write_front() {
  ws_.text(queue_.front().second);
  ws_.async_write(
      net::buffer(queue_.front().first),
      [self = shared_from_this()](beast::error_code ec, std::size_t) { self->on_write(ec); });
}

void AsyncWsClient::on_write(beast::error_code ec) {
  if (ec) return fail("write", ec);  // the queue stays blocked: nothing more is written
  queue_.pop_front();
  on_sent();
  if (!queue_.empty()) {
    write_front();
  } else if (closing_) {
    close_now();
  }
}

void AsyncWsClient::close() {
  if (closing_) return;
  closing_ = true;
  if (queue_.empty()) close_now();  // else once the queue is written (on_write)
}

void AsyncWsClient::close_now() {
  ws_.async_close(websocket::close_code::normal, [self = shared_from_this()](beast::error_code) {});
}

void AsyncWsClient::fail(const char* operation, beast::error_code ec) {
  if (!closing_) on_error(std::string(operation) + ": " + ec.message());
}

}  // namespace fctest
