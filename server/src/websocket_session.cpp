#include "websocket_session.hpp"

#include <algorithm>
#include <cstdio>

#include "access.hpp"
#include "facecast/core/json_limits.hpp"
#include "live_audio.hpp"
#include "log.hpp"
#include "services.hpp"

namespace facecast::server {

WebSocketSession::WebSocketSession(tcp::socket&& socket, std::shared_ptr<Services> services,
                                   std::unique_ptr<ConnectionSlot> slot, std::uint64_t id,
                                   std::string remote)
    : ws_(std::move(socket)),
      services_(std::move(services)),
      slot_(std::move(slot)),
      open_(services_->metrics.ws_connections, 1),
      id_(id),
      conn_("c" + std::to_string(id)),
      remote_(std::move(remote)),
      queue_(services_->metrics.write_queue_depth, services_->options.write_queue),
      message_tokens_(services_->options.message_burst),
      speaks_(std::make_shared<SpeakQueue>(share(services_, services_->streams), ws_.get_executor(),
                                           *this, conn_, id_)),
      watchdog_(ws_.get_executor()),
      close_timer_(ws_.get_executor()) {}

WebSocketSession::~WebSocketSession() {
  speaks_->close();
  leave_channel();
  services_->sessions.remove(id_);
}

void WebSocketSession::run(Request request, bool subprotocol, std::optional<Principal> who) {
  who_ = std::move(who);
  const auto& o = services_->options;
  beast::get_lowest_layer(ws_).expires_never();  // the websocket has its own timeouts
  websocket::stream_base::timeout t{};
  t.handshake_timeout = from_seconds(o.ws_handshake_timeout);
  t.idle_timeout = from_seconds(o.ws_idle_timeout);
  t.keep_alive_pings = true;
  ws_.set_option(t);
  ws_.set_option(websocket::stream_base::decorator([subprotocol](websocket::response_type& res) {
    res.set(http::field::server, "facecast");
    if (subprotocol) res.set(http::field::sec_websocket_protocol, kSubprotocol);
  }));
  forwarded_for_ = request["X-Forwarded-For"];  // the client behind a proxy, for the logs
  ws_.next_layer().set_owner(weak_from_this());
  ws_.next_layer().on_idle([this] { do_write(); });
  ws_.next_layer().on_written(
      [this](beast::error_code ec, std::size_t bytes) { on_write(ec, bytes); });
  ws_.next_layer().limit_control_bytes(o.max_control_bytes);
  ws_.read_message_max(o.max_message);
  ws_.auto_fragment(false);
  services_->sessions.add(id_, weak_from_this());
  ws_.async_accept(request,
                   beast::bind_front_handler(&WebSocketSession::on_accept, shared_from_this()));
}

void WebSocketSession::shut_down() {
  net::post(ws_.get_executor(), [self = shared_from_this()] {
    if (!self->accepted_) {
      beast::error_code ec;
      beast::get_lowest_layer(self->ws_).socket().close(ec);
      return;
    }
    self->close_with(websocket::close_code::going_away, "server shutting down");
  });
}

// ---- reading -----------------------------------------------------------------------------------

void WebSocketSession::on_accept(beast::error_code ec) {
  if (ec) {
    log::info("ws_handshake_failed", {{"conn", conn_}, {"error", ec.message()}});
    return;
  }
  accepted_ = true;
  if (services_->sessions.stopping) {
    close_with(websocket::close_code::going_away, "server shutting down");
    return;
  }
  log::info("ws_open", {{"conn", conn_},
                        {"remote", remote_},
                        log::Field::if_set("forwarded_for", forwarded_for_),
                        {"tenant", who_ ? who_->tenant : std::string("?")},
                        log::Field::if_set("key", who_ ? who_->key_id : std::string())});
  if (who_) {
    send_hello();
  } else {
    // Authentication in the first message: until then nothing else is read, nothing is sent.
    close_timer_.expires_after(from_seconds(services_->options.ws_handshake_timeout));
    close_timer_.async_wait([self = shared_from_this()](beast::error_code e) {
      if (!e && !self->who_)
        self->close_with(websocket::close_code::policy_error, "authenticate first");
    });
  }
  do_read();
}

void WebSocketSession::send_hello() {
  // The rig ids this caller may use: built-in and its tenant's (a viewer token: its own rig).
  std::vector<std::string> rigs;
  for (const auto& r : services_->rigs.list()) {
    const bool shown = !who_->viewer       ? rig_listed(*who_, r)
                       : who_->rig.empty() ? r.builtin
                                           : r.id == who_->rig;
    if (shown) rigs.push_back(r.id);
  }
  send(OutMessage::control(hello_message("facecast " FACECAST_VERSION, rigs, services_->options)));
}

void WebSocketSession::authenticate(std::string_view text) {
  try {
    check_json_depth(text, 4, "auth");
    const auto j = nlohmann::json::parse(text, nullptr, false);
    if (!j.is_object() || j.value("type", "") != "auth" || !j.contains("token") ||
        !j["token"].is_string())
      throw RequestError(Code::kUnauthorized,
                         "the first message must be {\"type\": \"auth\", \"token\": ...}");
    Principal who = services_->auth.identify(j["token"].get<std::string>());
    if (!who.can(kScopeSpeak) && !who.can(kScopeChannelsSubscribe) &&
        !who.can(kScopeChannelsProduce))
      throw RequestError(Code::kForbidden,
                         "/ws needs the scope speak, channels:subscribe or channels:produce");
    who_ = std::move(who);
    close_timer_.cancel();
    log::info("ws_authenticated",
              {{"conn", conn_}, {"tenant", who_->tenant}, log::Field::if_set("key", who_->key_id)});
    send_hello();
  } catch (...) {
    const Problem p = describe(std::current_exception());
    send_error(std::nullopt, p);
    close_with(websocket::close_code::policy_error, p.status == 403 ? "forbidden" : "unauthorized");
  }
}

void WebSocketSession::do_read() {
  ws_.async_read(buffer_,
                 beast::bind_front_handler(&WebSocketSession::on_read, shared_from_this()));
}

void WebSocketSession::on_read(beast::error_code ec, std::size_t) {
  if (ec) {
    if (ec == websocket::error::message_too_big) {
      log::warn("ws_message_too_big", {{"conn", conn_}, {"limit", services_->options.max_message}});
    } else if (ws_.next_layer().control_overflow()) {
      // Pings whose pongs the peer does not read: the socket is closed (no close frame fits).
      log::warn("ws_control_overflow",
                {{"conn", conn_}, {"limit", services_->options.max_control_bytes}});
      beast::error_code ignored;
      beast::get_lowest_layer(ws_).socket().close(ignored);
    }
    on_closed();
    return;
  }
  services_->metrics.ws_messages_received_total.fetch_add(1);
  if (!take_message_token()) {
    char reason[64];
    std::snprintf(reason, sizeof reason, "more than %g messages per second",
                  services_->options.messages_per_second);
    log::warn("ws_message_rate",
              {{"conn", conn_}, {"limit", services_->options.messages_per_second}});
    buffer_.consume(buffer_.size());
    close_with(websocket::close_code::policy_error, reason);
    do_read();  // until the close handshake ends
    return;
  }
  if (closing_) {
    buffer_.consume(buffer_.size());
    do_read();
    return;
  }
  if (ws_.got_text()) {
    const auto data = buffer_.data();
    handle_text(std::string_view(static_cast<const char*>(data.data()), data.size()));
  } else {
    const auto data = buffer_.data();
    handle_binary(std::string_view(static_cast<const char*>(data.data()), data.size()));
  }
  buffer_.consume(buffer_.size());
  do_read();
}

// The message rate limit: a token bucket of message_burst refilled at messages_per_second.
bool WebSocketSession::take_message_token() {
  const auto& o = services_->options;
  const auto now = Clock::now();
  message_tokens_ = std::min<double>(
      o.message_burst, message_tokens_ + seconds(now - message_tokens_at_) * o.messages_per_second);
  message_tokens_at_ = now;
  if (message_tokens_ < 1) return false;
  message_tokens_ -= 1;
  return true;
}

// Dispatches one client message; every failure becomes an `error` message.
void WebSocketSession::handle_text(std::string_view text) {
  if (!who_) return authenticate(text);
  std::string id;
  try {
    ClientMessage m = parse_client_message(text, services_->limits, &id);
    services_->access.authorize_message(*who_,
                                        m);  // scope, tenant, a viewer token's channel or rig
    if (route_live(m)) return;
    if (auto* speak = std::get_if<SpeakRequest>(&m)) {
      speaks_->speak(std::move(*speak));
    } else if (auto* cancel = std::get_if<CancelRequest>(&m)) {
      speaks_->cancel(*cancel);
    } else if (auto* ping = std::get_if<PingRequest>(&m)) {
      send(OutMessage::control(pong_message(ping->t, services_->sessions.uptime())));
    }
  } catch (...) {
    send_error(id.empty() ? std::nullopt : std::optional<std::string>(id),
               describe(std::current_exception()));
  }
}

// ---- writing -----------------------------------------------------------------------------------

std::uint32_t WebSocketSession::send(OutMessage message) {
  const std::uint32_t dropped = enqueue(std::move(message));
  do_write();
  return dropped;
}

std::uint32_t WebSocketSession::enqueue(OutMessage message) {
  if (closing_ || closed_) return 0;
  const int limit = services_->options.write_queue;
  if (!message.media()) {
    // Control messages are never dropped, but a client that sends requests without reading the
    // answers must not grow the queue without bound.
    if (queue_.control() >= 16 * limit) {
      close_slow_client();
      return 0;
    }
    if (queue_.control() >= limit) mark_stalled();
  }
  const bool full = message.kind == OutKind::kWeights && queue_.media_full();
  const OutQueue::Pushed pushed = queue_.push(std::move(message));
  if (full) mark_stalled();
  return pushed.dropped_frames;
}

bool WebSocketSession::media_full() {
  if (!queue_.media_full()) return false;
  mark_stalled();
  return true;
}

void WebSocketSession::send_error(const std::optional<std::string>& id, const Problem& problem) {
  services_->metrics.protocol_errors_total.fetch_add(1);
  log::info("ws_error", {{"conn", conn_},
                         {"id", id ? *id : std::string("null")},
                         {"code", to_string(problem.code)},
                         {"message", problem.message}});
  send(OutMessage::control(error_message(id, problem)));
}

// Writes what is queued (up to kMaxBatch messages) as WebSocket frames, in one gather write; again
// while more is queued and the socket takes it at once.
void WebSocketSession::do_write() {
  constexpr std::size_t kMaxBatch = 32;  // 64 buffers: Asio's most for one sendmsg
  auto& stream = ws_.next_layer();
  while (!queue_.empty() && queue_.writing() == 0 && !stream.busy() && !closed_) {
    const std::size_t n = queue_.start_write(kMaxBatch);
    heads_.resize(n);
    frames_.clear();
    std::size_t bytes = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const std::string& data = *queue_[i].data;
      frames_.push_back(
          net::buffer(heads_[i].data(), frame_header(heads_[i], !queue_[i].media(), data.size())));
      frames_.push_back(net::buffer(data));
      bytes += frames_[2 * i].size() + data.size();
    }
    if (!stream.write_frames(frames_)) return;  // on_write follows
    wrote(bytes);
  }
}

void WebSocketSession::on_write(beast::error_code ec, std::size_t bytes) {
  if (ec) {
    queue_.finish_write();
    log::debug("ws_write_failed", {{"conn", conn_}, {"error", ec.message()}});
    return;  // the read fails too and cleans up
  }
  wrote(bytes);
  do_write();
}

void WebSocketSession::wrote(std::size_t bytes) {
  queue_.finish_write();
  services_->metrics.ws_bytes_sent_total.fetch_add(bytes);
  if (queue_.empty()) stalled_since_.reset();
}

// ---- slow clients ------------------------------------------------------------------------------

// Starts the slow_client_grace clock (once until the queue drains).
void WebSocketSession::mark_stalled() {
  if (stalled_since_) return;
  stalled_since_ = Clock::now();
  watchdog_.expires_at(*stalled_since_ + from_seconds(services_->options.slow_client_grace));
  watchdog_.async_wait([self = shared_from_this()](beast::error_code ec) {
    if (!ec) self->on_watchdog();
  });
}

void WebSocketSession::on_watchdog() {
  if (!stalled_since_ || closing_ || closed_) return;
  const auto deadline = *stalled_since_ + from_seconds(services_->options.slow_client_grace);
  if (Clock::now() + std::chrono::milliseconds(1) < deadline) {
    watchdog_.expires_at(deadline);
    watchdog_.async_wait([self = shared_from_this()](beast::error_code ec) {
      if (!ec) self->on_watchdog();
    });
    return;
  }
  close_slow_client();
}

void WebSocketSession::close_slow_client() {
  services_->metrics.slow_clients_closed_total.fetch_add(1);
  log::warn("slow_client", {{"conn", conn_},
                            {"remote", remote_},
                            {"queued", queue_.size()},
                            {"grace_s", services_->options.slow_client_grace}});
  close_with(websocket::close_code::policy_error, "slow client: messages not read");
}

// ---- closing -----------------------------------------------------------------------------------

void WebSocketSession::close_with(websocket::close_code code, const char* reason) {
  if (closing_ || closed_) return;
  closing_ = true;
  speaks_->close();
  queue_.drop_unsent();  // the close frame follows the message being written
  watchdog_.cancel();
  log::info("ws_closing", {{"conn", conn_}, {"code", static_cast<int>(code)}, {"reason", reason}});
  ws_.async_close(
      websocket::close_reason(code, reason), [self = shared_from_this()](beast::error_code ec) {
        if (ec) log::debug("ws_close_failed", {{"conn", self->conn_}, {"error", ec.message()}});
      });
  // A peer that reads nothing never lets the close frame out: end it the hard way.
  close_timer_.expires_after(from_seconds(services_->options.close_timeout));
  close_timer_.async_wait([self = shared_from_this()](beast::error_code ec) {
    if (ec || self->closed_) return;
    log::info("ws_close_timeout", {{"conn", self->conn_}});
    beast::get_lowest_layer(self->ws_).close();
  });
}

void WebSocketSession::on_closed() {
  if (closed_) return;
  closed_ = true;
  speaks_->close();
  leave_channel();
  watchdog_.cancel();
  close_timer_.cancel();
  const auto reason = ws_.reason();
  log::info("ws_closed", {{"conn", conn_}, {"code", static_cast<int>(reason.code)}});
  services_->sessions.remove(id_);
}

}  // namespace facecast::server
