// The live-show messages of a WebSocket connection (docs/protocol.md, "Channels" and "Incremental
// text"): subscribe / unsubscribe, produce (the channel's producer token), and speak / append /
// end / cancel addressed to a channel (forwarded to its strand) or to this connection's queue.
#include "live_audio.hpp"
#include "log.hpp"
#include "services.hpp"
#include "websocket_session.hpp"

namespace facecast::server {
namespace {

const std::string& channel_of(const ClientMessage& m) {
  static const std::string none;
  return std::visit(
      [](const auto& r) -> const std::string& {
        if constexpr (requires { r.channel; }) {
          return r.channel;
        } else {
          return none;
        }
      },
      m);
}

}  // namespace

std::shared_ptr<Channel> WebSocketSession::channel_named(const std::string& name) const {
  auto c = services_->channels ? services_->channels->find(name) : nullptr;
  if (!c) throw Error("channel: '" + name + "' does not exist", ErrorCode::kNotFound);
  return c;
}

bool WebSocketSession::route_live(ClientMessage& m) {
  if (const auto* s = std::get_if<SubscribeRequest>(&m)) {
    auto c = channel_named(s->channel);
    if (subscribed_ != c) leave_channel();  // one channel per connection
    subscribed_ = c;
    c->subscribe(id_, weak_from_this());
    log::info("subscribe", {{"conn", conn_}, {"channel", s->channel}});
    return true;
  }
  if (const auto* u = std::get_if<UnsubscribeRequest>(&m)) {
    if (!subscribed_ || subscribed_->name() != u->channel)
      throw Error("unsubscribe: not subscribed to '" + u->channel + "'", ErrorCode::kNotFound);
    leave_channel();
    send(OutMessage::control(unsubscribed_message(u->channel)));
    return true;
  }
  if (const auto* p = std::get_if<ProduceRequest>(&m)) {
    const auto c = channel_named(p->channel);
    if (!c->producer_token_ok(p->token))
      throw RequestError(Code::kUnauthorized,
                         "produce: wrong producer token for channel '" + p->channel + "'");
    if (std::find(producing_.begin(), producing_.end(), p->channel) == producing_.end())
      producing_.push_back(p->channel);
    send(OutMessage::control(producing_message(p->channel)));
    return true;
  }
  const std::string& channel = channel_of(m);
  if (channel.empty()) {
    if (const auto* a = std::get_if<AppendRequest>(&m)) {
      speaks_->append(*a);
      return true;
    }
    if (const auto* e = std::get_if<EndRequest>(&m)) {
      speaks_->end(*e);
      return true;
    }
    if (const auto* x = std::get_if<ExpressionRequest>(&m)) {
      live_expressions(x->tags);
      return true;
    }
    if (const auto* t = std::get_if<AudioTextRequest>(&m)) {
      live_text(*t);
      return true;
    }
    return false;  // this connection's own speak / cancel / ping
  }
  if (std::find(producing_.begin(), producing_.end(), channel) == producing_.end())
    throw RequestError(Code::kForbidden, "channel '" + channel +
                                             "': send {\"type\": \"produce\"} with its producer "
                                             "token first");
  const auto c = channel_named(channel);
  std::string id = std::visit(
      [](const auto& r) -> std::string {
        if constexpr (requires { r.id; }) {
          return r.id;
        } else {
          return {};
        }
      },
      m);
  // The answer comes back on the channel's strand: errors return to this connection's strand.
  c->request(std::move(m), weak_from_this(),
             [self = weak_from_this(), id = std::move(id)](std::optional<Problem> problem) {
               if (!problem) return;
               if (const auto s = self.lock())
                 s->deliver_one(OutMessage::control(error_message(id, *problem)));
             });
  return true;
}

void WebSocketSession::leave_channel() {
  if (!subscribed_) return;
  subscribed_->unsubscribe(id_);
  subscribed_.reset();
}

void WebSocketSession::deliver(OutBatch batch) {
  net::post(ws_.get_executor(), [self = shared_from_this(), batch = std::move(batch)] {
    for (const OutMessage& m : *batch) self->enqueue(m);
    self->do_write();
  });
}

}  // namespace facecast::server
