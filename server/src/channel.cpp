#include "channel.hpp"

#include <future>

#include "facecast/server/keys.hpp"
#include "log.hpp"
#include "redis_bus.hpp"

namespace facecast::server {

Channel::Channel(std::shared_ptr<const StreamServices> services, net::any_io_executor strand,
                 std::string name, std::string producer_token, std::string tenant)
    : services_(std::move(services)),
      strand_(std::move(strand)),
      name_(std::move(name)),
      token_(std::move(producer_token)),
      tenant_(std::move(tenant)),
      presence_timer_(strand_) {
  queue_ = std::make_shared<SpeakQueue>(services_, strand_, *this, "ch:" + name_,
                                        std::hash<std::string>{}(name_));
}

bool Channel::producer_token_ok(std::string_view token) const noexcept {
  return constant_time_equal(token, token_);
}

void Channel::subscribe(std::uint64_t member, std::weak_ptr<ChannelMember> who) {
  net::post(strand_, [self = shared_from_this(), member, who = std::move(who)] {
    const auto m = who.lock();
    if (!m || self->closed_) return;
    self->flush();  // what was sent before it joined is not its
    if (!self->index_.contains(member)) {
      self->index_[member] = self->members_.size();
      self->members_.emplace_back(member, who);
      self->count_.store(static_cast<long>(self->members_.size()));
      self->presence_changed();
    }
    std::vector<OutMessage> hello{OutMessage::control(
        subscribed_message(self->name_, self->total_subscribers(), self->on_air_id_))};
    // A late joiner starts at the current frame: the stream_start, then what comes next.
    if (self->on_air_)
      hello.push_back(*self->on_air_);
    else if (self->remote_on_air_)
      hello.push_back(*self->remote_on_air_);
    m->deliver(std::make_shared<const std::vector<OutMessage>>(std::move(hello)));
    self->maybe_idle();
  });
}

void Channel::unsubscribe(std::uint64_t member) {
  net::post(strand_, [self = shared_from_this(), member] {
    const auto it = self->index_.find(member);
    if (it == self->index_.end()) return;
    const std::size_t at = it->second;
    self->index_.erase(it);
    if (at + 1 != self->members_.size()) {  // swap-remove: O(1)
      self->members_[at] = std::move(self->members_.back());
      self->index_[self->members_[at].first] = at;
    }
    self->members_.pop_back();
    self->count_.store(static_cast<long>(self->members_.size()));
    self->presence_changed();
  });
}

void Channel::request(ClientMessage message, std::weak_ptr<ChannelMember> producer, Reply reply) {
  net::post(strand_, [self = shared_from_this(), message = std::move(message),
                      producer = std::move(producer), reply = std::move(reply)]() mutable {
    try {
      if (self->closed_)
        throw RequestError(Code::kUnavailable, "channel '" + self->name_ + "' is closed");
      if (auto* speak = std::get_if<SpeakRequest>(&message)) {
        if (!speak->vmc.empty())
          throw Error("vmc: a channel's VMC receivers are in its configuration (channels." +
                      self->name_ + ".vmc)");
        if (!producer.expired()) self->producer_ = producer;
        self->queue_->speak(std::move(*speak));
        // Idle life gives way: it fades to rest, then the utterance starts.
        if (self->on_air_id_ == kIdleId)
          self->queue_->cancel(CancelRequest{std::string(kIdleId), {}});
      } else if (auto* append = std::get_if<AppendRequest>(&message)) {
        self->queue_->append(*append);
      } else if (auto* end = std::get_if<EndRequest>(&message)) {
        self->queue_->end(*end);
      } else if (auto* cancel = std::get_if<CancelRequest>(&message)) {
        self->queue_->cancel(*cancel);
      } else {
        throw Error("channel: not a producer request");
      }
    } catch (...) {
      reply(describe(std::current_exception()));
      return;
    }
    reply(std::nullopt);
  });
}

void Channel::close() {
  net::post(strand_, [self = shared_from_this()] {
    self->closed_ = true;
    self->queue_->close();
    self->presence_timer_.cancel();
    self->on_air_.reset();
    self->on_air_id_.reset();
  });
}

void Channel::stop_idle() {
  net::post(strand_, [self = shared_from_this()] {
    if (self->on_air_id_ == kIdleId) self->queue_->cancel(CancelRequest{std::string(kIdleId), {}});
  });
}

// ---- fan-out (on the strand) -------------------------------------------------------------------

std::uint32_t Channel::send(OutMessage message) {
  if (message.boundary == Boundary::kStart) {
    on_air_ = message;
    on_air_id_ = nlohmann::json::parse(*message.data).value("id", "");
  }
  // Idle life stays on each instance; utterances reach the other instances' subscribers too.
  if (services_->redis && on_air_id_ != kIdleId) services_->redis->publish(name_, message);
  if (message.boundary == Boundary::kEnd) {
    on_air_.reset();
    on_air_id_.reset();
    // After the queue moved on (it does so right after this call): idle life if nothing plays.
    net::post(strand_, [self = shared_from_this()] { self->maybe_idle(); });
  }
  broadcast(std::move(message));
  return 0;  // drops happen per subscriber; stream_end counts what the channel sent
}

void Channel::send_error(const std::optional<std::string>& id, const Problem& problem) {
  services_->metrics.protocol_errors_total.fetch_add(1);
  log::info("channel_error", {{"channel", name_},
                              {"id", id ? *id : std::string("null")},
                              {"code", to_string(problem.code)},
                              {"message", problem.message}});
  const auto message = OutMessage::control(error_message(id, problem));
  broadcast(message);
  if (const auto p = producer_.lock()) p->deliver_one(message);
}

void Channel::remote(OutMessage message) {
  net::post(strand_, [self = shared_from_this(), message = std::move(message)] {
    if (self->closed_) return;
    self->remote_last_ = std::chrono::steady_clock::now();
    if (message.boundary != Boundary::kNone)
      log::info(message.boundary == Boundary::kStart ? "remote_stream_start" : "remote_stream_end",
                {{"channel", self->name_},
                 {"stream", std::to_string(message.stream)},
                 {"subscribers", std::to_string(self->members_.size())}});
    if (message.boundary == Boundary::kStart) {
      self->remote_on_air_ = message;
      // This instance's idle life gives way to the other instance's utterance.
      if (self->on_air_id_ == kIdleId)
        self->queue_->cancel(CancelRequest{std::string(kIdleId), {}});
    } else if (message.boundary == Boundary::kEnd) {
      self->remote_on_air_.reset();
      net::post(self->strand_, [self] { self->maybe_idle(); });
    }
    self->broadcast(std::move(message));
  });
}

void Channel::set_remote_subscribers(long n) {
  net::post(strand_, [self = shared_from_this(), n] {
    // A producing instance that died mid-stream sends no stream_end: forget its stream after 3 s.
    if (self->remote_on_air_ &&
        std::chrono::steady_clock::now() - self->remote_last_ > std::chrono::seconds(3)) {
      self->remote_on_air_.reset();
      self->maybe_idle();
    }
    if (self->remote_count_.exchange(n) != n) self->presence_changed();
  });
}

// One shared buffer for everyone: delivering copies the OutMessage (a shared_ptr), never the
// bytes. Members that are gone are skipped; they unsubscribe when they close.
void Channel::broadcast(OutMessage message) {
  pending_.push_back(std::move(message));
  if (flush_posted_) return;
  flush_posted_ = true;
  net::post(strand_, [self = shared_from_this()] { self->flush(); });
}

void Channel::flush() {
  flush_posted_ = false;
  if (pending_.empty()) return;
  const auto batch = std::make_shared<const std::vector<OutMessage>>(std::move(pending_));
  pending_.clear();
  for (const auto& [id, who] : members_) {
    if (const auto m = who.lock()) m->deliver(batch);
  }
}

// At most one `presence` per presence_interval, and only when the count changed.
void Channel::presence_changed() {
  if (presence_armed_ || closed_) return;
  presence_armed_ = true;
  presence_timer_.expires_after(from_seconds(services_->options.presence_interval));
  presence_timer_.async_wait([self = shared_from_this()](beast::error_code ec) {
    self->presence_armed_ = false;
    if (ec || self->closed_) return;
    const long n = self->total_subscribers();
    if (n == self->presence_sent_) return;
    self->presence_sent_ = n;
    self->broadcast(OutMessage::control(presence_message(self->name_, n)));
  });
}

// Between utterances a channel with subscribers plays idle life (blinks, small head and eye
// motion) in streams of channel_idle seconds, so viewers never see a frozen face.
void Channel::maybe_idle() {
  const double seconds = services_->options.channel_idle;
  if (closed_ || seconds <= 0 || members_.empty() || idle_preparing_ || queue_->busy() ||
      remote_on_air_ || services_->sessions.stopping)
    return;
  idle_preparing_ = true;
  SpeakRequest r;
  r.id = std::string(kIdleId);
  r.audio = false;
  r.timing = viseme::Timing::kModel;
  const std::uint32_t seed =
      static_cast<std::uint32_t>(std::hash<std::string>{}(name_)) + ++idle_count_;
  net::post(services_->workers, [self = shared_from_this(), r, seconds, seed]() mutable {
    std::shared_ptr<PreparedSpeech> prepared;
    try {
      prepared = self->services_->speech.prepare_idle(r, seconds, seed);
    } catch (const std::exception& e) {
      log::warn("channel_idle_failed", {{"channel", self->name_}, {"error", e.what()}});
    }
    net::post(self->strand_, [self, r = std::move(r), prepared = std::move(prepared)]() mutable {
      self->idle_preparing_ = false;
      if (!prepared || self->closed_ || self->queue_->busy() || self->services_->sessions.stopping)
        return;
      self->queue_->speak_prepared(std::move(r), std::move(prepared));
    });
  });
}

// ---- registry ----------------------------------------------------------------------------------

ChannelRegistry::ChannelRegistry(const std::shared_ptr<const StreamServices>& services,
                                 net::io_context& io) {
  // A strand of the io_context's own executor (not of a polymorphic one): it fits inside an
  // any_io_executor without a shared, fence-counted target (ThreadSanitizer cannot model fences).
  for (const auto& c : services->options.channels) {
    channels_.push_back(std::make_shared<Channel>(services, net::make_strand(io), c.name,
                                                  c.producer_token, c.tenant));
  }
}

std::shared_ptr<Channel> ChannelRegistry::find(std::string_view name) const {
  for (const auto& c : channels_) {
    if (c->name() == name) return c;
  }
  return nullptr;
}

void ChannelRegistry::close_all() {
  for (const auto& c : channels_) c->close();
}

void ChannelRegistry::stop_idle() {
  for (const auto& c : channels_) c->stop_idle();
}

std::string channel_metrics(const ChannelRegistry& channels) {
  if (channels.all().empty()) return {};
  std::string out =
      "# HELP facecast_channel_subscribers Subscribers of a channel.\n"
      "# TYPE facecast_channel_subscribers gauge\n";
  for (const auto& c : channels.all())  // names are [A-Za-z0-9_.-]: no label escaping needed
    out += "facecast_channel_subscribers{channel=\"" + c->name() + "\"} " +
           std::to_string(c->subscribers()) + "\n";
  return out;
}

}  // namespace facecast::server
