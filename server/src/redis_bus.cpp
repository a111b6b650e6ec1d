#include "redis_bus.hpp"

#include <hiredis/hiredis.h>
#include <poll.h>

#include <cstring>

#include "channel.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/random.hpp"
#include "log.hpp"

namespace facecast::server {
namespace {

constexpr std::size_t kOutboxLimit = 4096;  // messages waiting for Redis; beyond: dropped

// The pub/sub message: 'F', kind, boundary, frames (u32 LE), stream (u32 LE), instance id length
// (u8), instance id, then the message bytes exactly as a WebSocket subscriber receives them.
std::string encode(const std::string& instance, const OutMessage& m) {
  std::string out;
  out.reserve(12 + instance.size() + m.data->size());
  out += 'F';
  out += static_cast<char>(m.kind);
  out += static_cast<char>(m.boundary);
  for (std::uint32_t v : {m.frames, m.stream})
    for (int i = 0; i < 4; ++i) out += static_cast<char>((v >> (8 * i)) & 0xFF);
  out += static_cast<char>(instance.size());
  out += instance;
  out += *m.data;
  return out;
}

// Nullopt for a message that is not ours or that this instance sent itself.
std::optional<OutMessage> decode(const std::string& self, const std::string& bytes) {
  if (bytes.size() < 12 || bytes[0] != 'F') return std::nullopt;
  const auto u8 = [&](std::size_t i) { return static_cast<std::uint8_t>(bytes[i]); };
  if (u8(1) > static_cast<std::uint8_t>(OutKind::kJpeg) ||
      u8(2) > static_cast<std::uint8_t>(Boundary::kEnd))
    return std::nullopt;
  const auto u32 = [&](std::size_t i) {
    return static_cast<std::uint32_t>(u8(i)) | static_cast<std::uint32_t>(u8(i + 1)) << 8 |
           static_cast<std::uint32_t>(u8(i + 2)) << 16 |
           static_cast<std::uint32_t>(u8(i + 3)) << 24;
  };
  const std::size_t n = u8(11);
  if (bytes.size() < 12 + n || (n == self.size() && bytes.compare(12, n, self) == 0))
    return std::nullopt;
  OutMessage m;
  m.kind = static_cast<OutKind>(u8(1));
  m.boundary = static_cast<Boundary>(u8(2));
  m.frames = u32(3);
  m.stream = u32(7);
  m.data = std::make_shared<const std::string>(bytes.substr(12 + n));
  return m;
}

}  // namespace

RedisBus::RedisBus(const ServerOptions& options)
    : url_(RedisUrl::parse(options.redis.url)),
      prefix_(options.redis.prefix),
      instance_(random_hex(6)),
      interval_(options.redis.heartbeat),
      client_(url_),
      publish_client_(url_) {
  client_.command({"PING"});  // fail at start, with the address, when Redis is not there
  log::info("redis_connected", {{"redis", url_.where()}, {"instance", instance_}});
}

RedisBus::~RedisBus() {
  stop();
}

void RedisBus::start(std::shared_ptr<ChannelRegistry> channels,
                     std::function<void(const std::string&)> dead) {
  channels_ = std::move(channels);
  dead_ = std::move(dead);
  beat();  // registered before the first job or subscriber arrives
  heartbeat_ = std::thread([this] { heartbeat(); });
  publisher_ = std::thread([this] { publisher(); });
  if (channels_->all().empty()) return;
  subscriber_ = std::thread([this] { subscriber(); });
  std::unique_lock lock(mutex_);
  if (!cv_.wait_for(lock, std::chrono::seconds(5), [&] { return subscribed_; }))
    log::warn("redis_subscribe_slow", {{"redis", url_.where()}, {"waited_s", "5"}});
}

void RedisBus::stop() {
  if (stopping_.exchange(true)) return;
  { std::lock_guard lock(mutex_); }  // a waiter between its check and its sleep sees the flag
  cv_.notify_all();
  outbox_ready_.notify_all();
  for (auto* t : {&subscriber_, &publisher_, &heartbeat_})
    if (t->joinable()) t->join();
  try {  // a clean stop: the others need not wait for the heartbeat to expire
    client_.command({"DEL", key("instance:" + instance_)});
  } catch (const std::exception&) {
  }
  channels_.reset();  // the channels hold the services that hold this bus
}

// One line when Redis becomes unreachable, one when it answers again.
void RedisBus::trouble(const std::string& where, const std::exception& e) {
  if (healthy_.exchange(false))
    log::error("redis_unreachable", {{"redis", url_.where()}, {"in", where}, {"error", e.what()}});
}

void RedisBus::publish(const std::string& channel, const OutMessage& message) {
  std::string bytes = encode(instance_, message);
  {
    std::lock_guard lock(mutex_);
    if (outbox_.size() >= kOutboxLimit) return;  // Redis is gone or far behind: drop, not grow
    outbox_.emplace_back(key("ch:" + channel), std::move(bytes));
  }
  outbox_ready_.notify_one();
}

void RedisBus::publisher() {
  for (;;) {
    std::vector<std::vector<std::string>> batch;
    {
      std::unique_lock lock(mutex_);
      outbox_ready_.wait(lock, [&] { return stopping_ || !outbox_.empty(); });
      if (stopping_) return;
      while (!outbox_.empty()) {
        batch.push_back(
            {"PUBLISH", std::move(outbox_.front().first), std::move(outbox_.front().second)});
        outbox_.pop_front();
      }
    }
    try {
      publish_client_.pipeline(batch);
    } catch (const std::exception& e) {
      trouble("publish", e);
    }
  }
}

// PSUBSCRIBE <prefix>ch:* on a connection of its own; polls so that stop() is seen within 200 ms.
void RedisBus::subscriber() {
  const std::string pattern = key("ch:*");
  const std::size_t skip = key("ch:").size();
  while (!stopping_) {
    redisContext* c = nullptr;
    try {
      c = RedisClient::connect(url_, 2.0);
      if (redisAppendCommand(c, "PSUBSCRIBE %b", pattern.data(), pattern.size()) != REDIS_OK)
        throw Error("redis " + url_.where() + ": PSUBSCRIBE failed");
      int done = 0;
      while (!done) redisBufferWrite(c, &done);
      while (!stopping_) {
        void* raw = nullptr;
        if (redisReaderGetReply(c->reader, &raw) != REDIS_OK)
          throw Error("redis " + url_.where() + ": malformed reply");
        if (!raw) {
          pollfd p{c->fd, POLLIN, 0};
          if (poll(&p, 1, 200) > 0 && redisBufferRead(c) != REDIS_OK)
            throw Error("redis " + url_.where() + ": " + c->errstr);
          continue;
        }
        auto* r = static_cast<redisReply*>(raw);
        const auto kind = [&] {
          return r->type == REDIS_REPLY_ARRAY && r->elements >= 1 &&
                         r->element[0]->type == REDIS_REPLY_STRING
                     ? std::string_view(r->element[0]->str, r->element[0]->len)
                     : std::string_view();
        };
        if (kind() == "psubscribe") {
          log::info("redis_subscribed", {{"redis", url_.where()}, {"pattern", pattern}});
          {
            std::lock_guard lock(mutex_);
            subscribed_ = true;
          }
          cv_.notify_all();
        } else if (r->elements == 4 && kind() == "pmessage") {
          healthy_ = true;
          const std::string channel(r->element[2]->str, r->element[2]->len);
          receive(channel.substr(skip), std::string(r->element[3]->str, r->element[3]->len));
        }
        freeReplyObject(r);
      }
    } catch (const std::exception& e) {
      trouble("subscribe", e);
      std::unique_lock lock(mutex_);
      cv_.wait_for(lock, std::chrono::milliseconds(500), [&] { return stopping_.load(); });
    }
    if (c) redisFree(c);
  }
}

void RedisBus::receive(const std::string& channel, const std::string& payload) {
  const auto ch = channels_->find(channel);
  if (!ch) return;  // a channel another instance has and this one does not
  if (auto m = decode(instance_, payload)) ch->remote(std::move(*m));
}

void RedisBus::heartbeat() {
  while (!stopping_) {
    {
      std::unique_lock lock(mutex_);
      cv_.wait_for(lock, std::chrono::duration<double>(interval_),
                   [&] { return stopping_.load(); });
    }
    if (stopping_) return;
    beat();
  }
}

// Refreshes this instance's keys, sums the others' subscribers per channel and requeues the jobs
// of instances whose heartbeat expired.
void RedisBus::beat() {
  const std::string ttl = std::to_string(static_cast<long>(interval_ * 3000));
  try {
    std::vector<std::vector<std::string>> cmds = {
        {"SET", key("instance:" + instance_), "1", "PX", ttl},
        {"SADD", key("instances"), instance_},
        {"SMEMBERS", key("instances")}};
    const auto& channels = channels_ ? channels_->all() : std::vector<std::shared_ptr<Channel>>{};
    for (const auto& ch : channels)
      cmds.push_back({"SET", key("presence:" + ch->name() + ":" + instance_),
                      std::to_string(ch->subscribers()), "PX", ttl});
    const auto replies = client_.pipeline(cmds);
    std::vector<std::string> others;
    for (const auto& e : replies[2].elements)
      if (e.str != instance_) others.push_back(e.str);
    if (!others.empty()) {
      std::vector<std::vector<std::string>> ask;
      for (const auto& o : others) ask.push_back({"EXISTS", key("instance:" + o)});
      for (const auto& ch : channels)
        for (const auto& o : others)
          ask.push_back({"GET", key("presence:" + ch->name() + ":" + o)});
      const auto got = client_.pipeline(ask);
      for (std::size_t c = 0; c < channels.size(); ++c) {
        long sum = 0;
        for (std::size_t i = 0; i < others.size(); ++i) {
          const auto& v = got[others.size() + c * others.size() + i];
          if (!v.nil()) sum += std::atol(v.str.c_str());
        }
        channels[c]->set_remote_subscribers(sum);
      }
      for (std::size_t i = 0; i < others.size(); ++i) {
        if (got[i].integer != 0) continue;
        log::warn("redis_instance_dead", {{"instance", others[i]}});
        if (dead_) dead_(others[i]);
        client_.command({"SREM", key("instances"), others[i]});
      }
    } else {
      for (const auto& ch : channels) ch->set_remote_subscribers(0);
    }
    if (!healthy_.exchange(true)) log::info("redis_reconnected", {{"redis", url_.where()}});
  } catch (const std::exception& e) {
    trouble("heartbeat", e);
  }
}

}  // namespace facecast::server
