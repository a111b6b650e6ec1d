#include "http_session.hpp"

#include <array>

#include "clock.hpp"
#include "guard.hpp"
#include "log.hpp"
#include "routes.hpp"
#include "services.hpp"
#include "websocket_session.hpp"

namespace facecast::server {
namespace {

std::string endpoint_string(const tcp::socket& socket) {
  beast::error_code ec;
  const auto ep = socket.remote_endpoint(ec);
  if (ec) return "?";
  return ep.address().to_string() + ":" + std::to_string(ep.port());
}

// True when the comma-separated header value lists `token`.
bool header_lists(std::string_view value, std::string_view token) {
  while (!value.empty()) {
    const auto comma = value.find(',');
    std::string_view item = value.substr(0, comma);
    while (!item.empty() && (item.front() == ' ' || item.front() == '\t')) item.remove_prefix(1);
    while (!item.empty() && (item.back() == ' ' || item.back() == '\t')) item.remove_suffix(1);
    if (item == token) return true;
    if (comma == std::string_view::npos) break;
    value.remove_prefix(comma + 1);
  }
  return false;
}

}  // namespace

HttpSession::HttpSession(tcp::socket&& socket, std::shared_ptr<Services> services,
                         std::unique_ptr<ConnectionSlot> slot, std::uint64_t id,
                         std::string refused)
    : stream_(std::move(socket)),
      services_(std::move(services)),
      slot_(std::move(slot)),
      id_(id),
      conn_("c" + std::to_string(id)),
      remote_(endpoint_string(stream_.socket())),
      refused_(std::move(refused)) {
  services_->metrics.http_connections.fetch_add(1);
}

HttpSession::~HttpSession() {
  services_->metrics.http_connections.fetch_sub(1);
  if (!upgraded_) services_->sessions.remove(id_);
}

void HttpSession::run() {
  services_->sessions.add(id_, weak_from_this());
  if (!refused_.empty()) {
    // Over a connection limit: answered at once, before anything is read, and closed.
    services_->metrics.connections_refused_total.fetch_add(1);
    net::dispatch(stream_.get_executor(), [self = shared_from_this()] {
      self->fail(Problem{Code::kUnavailable, self->refused_, 503}, false);
    });
    return;
  }
  net::dispatch(stream_.get_executor(),
                beast::bind_front_handler(&HttpSession::do_read, shared_from_this()));
}

void HttpSession::shut_down() {
  net::post(stream_.get_executor(), [self = shared_from_this()] {
    beast::error_code ec;
    self->stream_.socket().shutdown(tcp::socket::shutdown_both, ec);
    self->stream_.close();
  });
}

void HttpSession::do_read() {
  parser_.emplace();
  parser_->header_limit(16 * 1024);
  // The limit depends on the route, known once the header is read (on_header sets it).
  parser_->body_limit(boost::none);
  stream_.expires_after(from_seconds(services_->options.http_timeout));
  http::async_read_header(stream_, buffer_, *parser_,
                          beast::bind_front_handler(&HttpSession::on_header, shared_from_this()));
}

void HttpSession::on_header(beast::error_code ec, std::size_t) {
  if (ec == http::error::end_of_stream || ec == net::error::operation_aborted ||
      ec == beast::error::timeout || ec == net::error::eof) {
    do_close();
    return;
  }
  if (ec) {
    // Malformed request line or headers (or headers over the limit): answer and close.
    const bool too_big = ec == http::error::header_limit || ec == http::error::body_limit;
    fail(Problem{too_big ? Code::kLimit : Code::kInvalidInput,
                 std::string("bad request: ") + ec.message(),
                 ec == http::error::header_limit ? 431
                 : too_big                       ? 413
                                                 : 400},
         false);
    return;
  }
  started_ = Clock::now();
  services_->metrics.http_requests_total.fetch_add(1);
  auto& req = parser_->get();
  // Host, Origin and Content-Type (guard.hpp): refused before the body is read.
  if (const auto problem = check_request_header(services_->options, req)) {
    fail(*problem, false);
    return;
  }
  if (websocket::is_upgrade(req)) {
    upgrade();
    return;
  }
  const std::size_t limit = body_limit(services_->options, req);
  if (parser_->content_length() || parser_->chunked()) {
    if (parser_->content_length() && *parser_->content_length() > limit) {
      fail(Problem{Code::kLimit,
                   "request body of " + std::to_string(*parser_->content_length()) +
                       " bytes is over the limit of " + std::to_string(limit),
                   413},
           false);
      return;
    }
    parser_->body_limit(limit);
    // The body's bytes count against max_body_memory until it has been answered.
    const std::size_t bytes = parser_->content_length() ? *parser_->content_length() : limit;
    if (bytes > 0 && !(body_hold_ = services_->body_memory.reserve(bytes))) {
      fail(Problem{Code::kUnavailable,
                   "the server holds too many request bodies now (max_body_memory); retry later",
                   503},
           false);
      return;
    }
  }
  if (parser_->is_done()) {
    handle();
    return;
  }
  if (beast::iequals(req[http::field::expect], "100-continue")) {
    auto cont =
        std::make_shared<http::response<http::empty_body>>(http::status::continue_, req.version());
    http::async_write(stream_, *cont,
                      [self = shared_from_this(), cont](beast::error_code wec, std::size_t) {
                        if (wec) return self->do_close();
                        http::async_read(self->stream_, self->buffer_, *self->parser_,
                                         beast::bind_front_handler(&HttpSession::on_body, self));
                      });
    return;
  }
  http::async_read(stream_, buffer_, *parser_,
                   beast::bind_front_handler(&HttpSession::on_body, shared_from_this()));
}

void HttpSession::on_body(beast::error_code ec, std::size_t) {
  if (ec == http::error::body_limit) {
    fail(Problem{Code::kLimit,
                 "request body is over the limit of " +
                     std::to_string(body_limit(services_->options, parser_->get())) + " bytes",
                 413},
         false);
    return;
  }
  if (ec) {
    if (ec != net::error::operation_aborted && ec != beast::error::timeout &&
        ec != http::error::end_of_stream)
      log::info("http_read_failed", {{"conn", conn_}, {"error", ec.message()}});
    do_close();
    return;
  }
  handle();
}

void HttpSession::upgrade() {
  auto& req = parser_->get();
  const Target target = parse_target(req.target());
  const auto refuse = [&](Code code, std::string message, int status = 0) {
    fail(Problem{code, std::move(message), status ? status : http_status(code)}, false);
  };
  if (target.path != "/ws") return refuse(Code::kNotFound, "WebSocket endpoint is /ws");
  if (services_->sessions.stopping)
    return refuse(Code::kUnavailable, "the server is shutting down");
  if (!origin_ok(services_->options, req))
    return refuse(
        Code::kForbidden,
        "origin '" + std::string(req[http::field::origin].substr(0, 200)) + "' is not allowed");
  // Who connects (auth.hpp): a key or viewer token in the upgrade, or, offering the subprotocol
  // "facecast.token" alone, in the first message.
  std::optional<Principal> who;
  try {
    if (!services_->auth.enabled() || Auth::credential(req, target) ||
        !Auth::offers_first_message(req)) {
      who = services_->auth.identify(req, target);
      if (!who->can(kScopeSpeak) && !who->can(kScopeChannelsSubscribe) &&
          !who->can(kScopeChannelsProduce))
        throw RequestError(Code::kForbidden,
                           "/ws needs the scope speak, channels:subscribe or channels:produce");
    }
  } catch (...) {  // 401, 403, or a key store that cannot be read (500)
    const Problem p = describe(std::current_exception());
    return refuse(p.code, p.message, p.status);
  }
  bool subprotocol = false;
  if (req.count(http::field::sec_websocket_protocol)) {
    subprotocol = header_lists(req[http::field::sec_websocket_protocol], kSubprotocol);
    if (!subprotocol)
      return refuse(Code::kInvalidInput, "subprotocol: the server speaks facecast.v1");
  }
  if (!parser_->is_done()) return refuse(Code::kInvalidInput, "a WebSocket upgrade has no body");
  if (!slot_->address) {  // from a trusted proxy: count the client it forwards
    beast::error_code ec;
    const auto peer = stream_.socket().remote_endpoint(ec);
    const std::string client =
        ec ? "" : services_->addresses.client(peer.address(), req["X-Forwarded-For"]);
    if (!client.empty() && !(slot_->address = services_->addresses.hold(client))) {
      services_->metrics.connections_refused_total.fetch_add(1);
      return refuse(Code::kUnavailable,
                    "too many connections from " + client + " (max_connections_per_address)");
    }
  }
  upgraded_ = true;
  services_->sessions.remove(id_);
  auto ws = std::make_shared<WebSocketSession>(stream_.release_socket(), services_,
                                               std::move(slot_), id_, remote_);
  ws->run(parser_->release(), subprotocol, std::move(who));
}

void HttpSession::handle() {
  Request req = parser_->release();
  const bool keep_alive = req.keep_alive() && !services_->sessions.stopping;
  log::debug("http_request", {{"conn", conn_},
                              {"method", std::string(req.method_string())},
                              {"target", loggable_target(req.target())},
                              log::Field::if_set("forwarded_for", req["X-Forwarded-For"])});
  if (is_heavy(req)) {
    net::post(services_->workers, [self = shared_from_this(), req = std::move(req), keep_alive,
                                   hold = std::move(body_hold_)]() mutable {
      auto res = handle_request(*self->services_, std::move(req));
      hold.reset();
      net::post(self->stream_.get_executor(), [self, res = std::move(res), keep_alive]() mutable {
        self->send(std::move(res), keep_alive);
      });
    });
    return;
  }
  send(handle_request(*services_, std::move(req)), keep_alive);
  body_hold_.reset();
}

void HttpSession::fail(const Problem& problem, bool keep_alive) {
  const unsigned version = parser_ && parser_->is_header_done() ? parser_->get().version() : 11;
  const std::string_view forwarded =
      parser_ && parser_->is_header_done() ? parser_->get()["X-Forwarded-For"] : "";
  log::info("http_refused", {{"conn", conn_},
                             {"status", problem.status},
                             {"message", problem.message},
                             log::Field::if_set("forwarded_for", forwarded)});
  send(services_->responses.error(version, keep_alive, problem), keep_alive);
}

void HttpSession::send(http::message_generator message, bool keep_alive) {
  stream_.expires_after(from_seconds(services_->options.http_timeout));
  beast::async_write(
      stream_, std::move(message),
      beast::bind_front_handler(&HttpSession::on_write, shared_from_this(), keep_alive));
}

void HttpSession::on_write(bool keep_alive, beast::error_code ec, std::size_t) {
  if (started_.time_since_epoch().count()) {
    services_->metrics.http_request_seconds.observe(seconds(Clock::now() - started_));
  }
  if (ec) {
    log::debug("http_write_failed", {{"conn", conn_}, {"error", ec.message()}});
    do_close();
    return;
  }
  if (!keep_alive || services_->sessions.stopping) {
    do_close();
    return;
  }
  do_read();
}

void HttpSession::do_close() {
  body_hold_.reset();
  // Lingering close: stop sending, then read (and discard) what the client still sends for a
  // moment, so that an error answered before the body was read reaches the client instead of
  // being lost to a reset.
  beast::error_code ec;
  stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
  if (ec) {
    stream_.close();
    return;
  }
  stream_.expires_after(std::chrono::seconds(2));
  drain(0);
}

void HttpSession::drain(std::size_t total) {
  auto buf = std::make_shared<std::array<char, 16384>>();
  stream_.async_read_some(net::buffer(*buf), [self = shared_from_this(), buf, total](
                                                 beast::error_code ec, std::size_t n) {
    if (ec || total + n > (64u << 20)) {
      self->stream_.close();
      return;
    }
    self->drain(total + n);
  });
}

}  // namespace facecast::server
