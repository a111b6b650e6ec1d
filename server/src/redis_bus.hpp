#pragma once
// Many instances through Redis (docs/protocol.md, "Many instances"): this instance's identity and
// heartbeat, channel messages between instances over pub/sub, and subscriber counts summed over
// the live instances. Keys (all under ServerOptions::redis.prefix, "facecast:" by default):
//
//   instances                  set of instance ids that registered
//   instance:<id>              heartbeat, expires after 3 heartbeats: gone means the instance died
//   presence:<channel>:<id>    that instance's local subscribers of the channel (same expiry)
//   ch:<channel>               pub/sub: every stream message the producing instance sends
//
// A published message is the channel's encoded message once (the same bytes every local
// subscriber gets) behind a small header (redis_bus.cpp, encode()); each instance fans it out to
// its own subscribers and skips its own messages. Publishing never blocks the channel: messages
// wait in a bounded queue that one thread sends as pipelined PUBLISH commands.
#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "facecast/server/options.hpp"
#include "out_queue.hpp"
#include "redis_client.hpp"

namespace facecast::server {

class ChannelRegistry;

class RedisBus {
 public:
  /// Parses the url (throws Error naming it) and checks that Redis answers (throws Error
  /// "redis host:port: Connection refused" when it does not).
  explicit RedisBus(const ServerOptions& options);
  ~RedisBus();
  RedisBus(const RedisBus&) = delete;
  RedisBus& operator=(const RedisBus&) = delete;

  const std::string& instance() const { return instance_; }
  const RedisUrl& url() const { return url_; }
  std::string key(std::string_view name) const { return prefix_ + std::string(name); }
  /// For quick commands from any thread.
  RedisClient& client() { return client_; }

  /// `dead`: called on the heartbeat thread with each instance whose heartbeat expired (its
  /// in-flight jobs must be requeued), before the instance is forgotten. With channels, returns
  /// once Redis has confirmed the subscription to their messages (or after 5 s, logged), so that
  /// no subscriber this instance accepts misses a stream another instance starts.
  void start(std::shared_ptr<ChannelRegistry> channels,
             std::function<void(const std::string&)> dead);
  void stop();

  /// Queues a channel message for the other instances (any thread; never waits for Redis).
  void publish(const std::string& channel, const OutMessage& message);

 private:
  void subscriber();
  void publisher();
  void heartbeat();
  void beat();
  void receive(const std::string& channel, const std::string& payload);
  void trouble(const std::string& where, const std::exception& e);

  RedisUrl url_;
  std::string prefix_, instance_;
  double interval_;
  RedisClient client_, publish_client_;
  std::shared_ptr<ChannelRegistry> channels_;
  std::function<void(const std::string&)> dead_;
  std::atomic<bool> stopping_{false}, healthy_{true};
  bool subscribed_ = false;  // under mutex_: Redis confirmed the PSUBSCRIBE
  std::mutex mutex_;
  // Two conditions on mutex_: the outbox has messages (the publisher alone waits for it), and
  // anything else (stop, the subscription confirmed). One shared condition lost wake-ups: a
  // publish's notify_one could wake the heartbeat instead of the publisher, and a stream's last
  // message (its stream_end) then waited for the next publish -- forever, when nothing followed.
  std::condition_variable outbox_ready_, cv_;
  std::deque<std::pair<std::string, std::string>> outbox_;  // (pub/sub channel, bytes)
  std::thread subscriber_, publisher_, heartbeat_;
};

}  // namespace facecast::server
