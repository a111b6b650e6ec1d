#pragma once
// One HTTP connection (Beast advanced server shape): reads a request header, checks it, reads the
// body under the limit for its route, answers, and repeats while keep-alive; hands the socket to a
// WebSocketSession on a valid upgrade of /ws. Light requests are answered on the strand; request
// bodies (rig uploads, render jobs) and GLB downloads are handled on the worker pool.
#include <chrono>
#include <memory>
#include <optional>

#include "beast.hpp"
#include "facecast/server/protocol.hpp"
#include "peer_limits.hpp"
#include "sessions.hpp"

namespace facecast::server {

struct Services;

class HttpSession : public std::enable_shared_from_this<HttpSession>, public Closable {
 public:
  HttpSession(tcp::socket&& socket, std::shared_ptr<Services> services,
              std::unique_ptr<ConnectionSlot> slot, std::uint64_t id, std::string refused);
  ~HttpSession();
  void run();
  void shut_down() override;

 private:
  void do_read();
  void on_header(beast::error_code ec, std::size_t bytes);
  void on_body(beast::error_code ec, std::size_t bytes);
  void upgrade();
  void handle();
  void send(http::message_generator message, bool keep_alive);
  void on_write(bool keep_alive, beast::error_code ec, std::size_t bytes);
  void fail(const Problem& problem, bool keep_alive);
  void do_close();
  void drain(std::size_t total);

  beast::tcp_stream stream_;
  std::shared_ptr<Services> services_;
  std::unique_ptr<ConnectionSlot> slot_;
  std::uint64_t id_;
  std::string conn_, remote_;
  std::string refused_;              // why every request is answered 503 ("" when not)
  std::shared_ptr<void> body_hold_;  // the request body's share of max_body_memory
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
  std::chrono::steady_clock::time_point started_;
  bool upgraded_ = false;
};

}  // namespace facecast::server
