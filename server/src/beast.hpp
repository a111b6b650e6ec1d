#pragma once
// Boost.Beast / Asio names used across the server.
#include <atomic>
#include <memory>

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

namespace facecast::server {

namespace net = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = net::ip::tcp;
using Request = http::request<http::string_body>;

/// Decrements the open-connection count when the socket's last owner goes away; moved from the
/// HTTP session to the WebSocket session on upgrade.
struct ConnectionSlot {
  std::atomic<long>* count = nullptr;
  std::shared_ptr<void> address;  // the client address's count (client_addresses.hpp), if held
  explicit ConnectionSlot(std::atomic<long>* c) : count(c) {}
  ConnectionSlot(const ConnectionSlot&) = delete;
  ConnectionSlot& operator=(const ConnectionSlot&) = delete;
  ~ConnectionSlot() {
    if (count) count->fetch_sub(1);
  }
};

}  // namespace facecast::server
