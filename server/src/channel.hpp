#pragma once
// Channels (docs/protocol.md, "Channels"): a named show whose utterances are animated and encoded
// once, on the channel's own strand, and fanned out to every subscriber. Each message is one shared
// buffer that every subscriber's OutQueue references (no copy per subscriber); each subscriber's
// queue applies its own drop policy, so a slow subscriber never slows the others. The channel is
// the StreamSink of its own SpeakQueue (queue, rate limit, incremental text, cancel with a fade).
// What is sent in one turn of the strand goes to each subscriber as one batch: one post, and one
// gather write on the subscriber's socket.
//
// Threads: members_, on_air_ and the SpeakQueue live on the channel's strand; every public call
// posts there. A subscriber receives through deliver(), which posts to the subscriber's strand.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "beast.hpp"
#include "speak_queue.hpp"
#include "stream_services.hpp"

namespace facecast::server {

/// Messages a channel hands to every member at once, in order (one shared list per fan-out).
using OutBatch = std::shared_ptr<const std::vector<OutMessage>>;

/// A subscriber (or producer) of a channel.
class ChannelMember {
 public:
  virtual ~ChannelMember() = default;
  /// Thread-safe: queues `batch` on the member's own strand.
  virtual void deliver(OutBatch batch) = 0;
  void deliver_one(OutMessage message) {
    deliver(std::make_shared<const std::vector<OutMessage>>(1, std::move(message)));
  }
};

class Channel : public StreamSink, public std::enable_shared_from_this<Channel> {
 public:
  Channel(std::shared_ptr<const StreamServices> services, net::any_io_executor strand,
          std::string name, std::string producer_token, std::string tenant = "default");

  const std::string& name() const noexcept { return name_; }
  /// Whose channel (ServerOptions::Channel::tenant): other tenants' keys cannot use it.
  const std::string& tenant() const noexcept { return tenant_; }
  bool producer_token_ok(std::string_view token) const noexcept;
  /// Subscribers on this instance now (any thread; for /metrics and the API).
  long subscribers() const noexcept { return count_.load(); }
  /// Subscribers on every instance (with Redis: this one's plus the others' last heartbeat).
  long total_subscribers() const noexcept { return count_.load() + remote_count_.load(); }

  // Many instances (redis_bus.hpp); thread-safe, each runs on the channel's strand.
  /// A message another instance's producer sent: fanned out to this instance's subscribers.
  void remote(OutMessage message);
  /// The other instances' subscribers (summed from their heartbeats).
  void set_remote_subscribers(long n);

  // Thread-safe; each runs on the channel's strand.
  void subscribe(std::uint64_t member, std::weak_ptr<ChannelMember> who);
  void unsubscribe(std::uint64_t member);
  /// A producer's speak, append, end or cancel. `reply` runs on the channel's strand with the
  /// problem, or nullopt once the request was accepted. `producer` (optional) receives the
  /// preparation errors of its utterances.
  using Reply = std::function<void(std::optional<Problem>)>;
  void request(ClientMessage message, std::weak_ptr<ChannelMember> producer, Reply reply);
  /// Stops what plays and forgets the queue (server shutdown).
  void close();
  /// Fades out an idle-life stream (server draining; none starts while the server stops).
  void stop_idle();

  // StreamSink (on the strand)
  std::uint32_t send(OutMessage message) override;
  bool media_full() override { return false; }  // each subscriber drops for itself
  double send_ahead() const override { return services_->options.channel_tick; }
  void send_error(const std::optional<std::string>& id, const Problem& problem) override;

 private:
  // Messages sent in one turn of the strand (a pacer's wake-up) reach each member as one batch.
  void broadcast(OutMessage message);
  void flush();
  void presence_changed();
  void maybe_idle();

  std::shared_ptr<const StreamServices> services_;
  net::any_io_executor strand_;
  std::string name_, token_, tenant_;
  std::shared_ptr<SpeakQueue> queue_;
  std::vector<std::pair<std::uint64_t, std::weak_ptr<ChannelMember>>> members_;
  std::unordered_map<std::uint64_t, std::size_t> index_;  // member id -> position in members_
  std::optional<OutMessage> on_air_;                      // stream_start of what plays
  std::optional<std::string> on_air_id_;                  // its utterance id
  std::optional<OutMessage> remote_on_air_;  // stream_start of what another instance plays
  std::chrono::steady_clock::time_point remote_last_;  // its last message
  std::weak_ptr<ChannelMember> producer_;              // the last WebSocket producer
  std::uint64_t producer_id_ = 0;
  std::atomic<long> count_{0}, remote_count_{0};
  long presence_sent_ = 0;
  net::steady_timer presence_timer_;
  bool presence_armed_ = false, closed_ = false;
  bool idle_preparing_ = false;
  std::vector<OutMessage> pending_;  // broadcast, not yet handed to the members
  bool flush_posted_ = false;
  std::uint32_t idle_count_ = 0;
};

/// The id of a channel's idle-life streams (between utterances).
inline constexpr std::string_view kIdleId = "~idle";

/// The configured channels (ServerOptions::channels); the set is fixed at start.
class ChannelRegistry {
 public:
  ChannelRegistry(const std::shared_ptr<const StreamServices>& services, net::io_context& io);
  /// Null when there is no channel `name`.
  std::shared_ptr<Channel> find(std::string_view name) const;
  const std::vector<std::shared_ptr<Channel>>& all() const { return channels_; }
  void close_all();
  /// Draining: idle life stops (fades out) and does not start again.
  void stop_idle();

 private:
  std::vector<std::shared_ptr<Channel>> channels_;
};

/// Prometheus lines: facecast_channel_subscribers{channel="show"} per channel.
std::string channel_metrics(const ChannelRegistry& channels);

}  // namespace facecast::server
