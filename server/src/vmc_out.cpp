#include "vmc_out.hpp"

#include <nlohmann/json.hpp>

#include "facecast/rig/motion.hpp"
#include "facecast/server/protocol.hpp"
#include "log.hpp"
#include "stream_services.hpp"

namespace facecast::server {

std::shared_ptr<VmcMirror> VmcMirror::start(std::shared_ptr<const StreamServices> services,
                                            std::shared_ptr<Channel> channel,
                                            const ServerOptions::Channel::Vmc& settings) {
  auto out = std::make_shared<VmcMirror>(std::move(services), std::move(channel), settings);
  out->channel_->subscribe(out->member_id_, out->weak_from_this());
  out->thread_ = std::thread([self = out.get()] { self->run(); });
  log::info(
      "vmc_start",
      {{"channel", out->channel_->name()}, {"targets", out->label_}, {"names", settings.names}});
  return out;
}

std::vector<std::unique_ptr<VmcSender>> vmc_senders(const ServerOptions::Channel::Vmc& settings,
                                                    std::string& label) {
  const VmcNames names = parse_vmc_names(settings.names);
  std::vector<std::unique_ptr<VmcSender>> out;
  for (const auto& t : settings.targets) {
    out.push_back(std::make_unique<VmcSender>(parse_vmc_target(t), names));
    label += (label.empty() ? "" : " ") + t;
  }
  return out;
}

void send_vmc_frame(const std::vector<std::unique_ptr<VmcSender>>& senders,
                    const VmcTimeline::Frame& f, const std::string& where) {
  const std::size_t n = f.names->size();
  const rig::BodyPose head = rig::BodyPose::from_channels(std::span(f.values).subspan(n));
  for (const auto& s : senders) {
    try {
      s->send(*f.names, std::span<const float>(f.values.data(), n), head, f.t);
    } catch (const std::exception& e) {  // the receiver is not there (yet): UDP goes on
      log::debug("vmc_send_failed", {{"to", where}, {"error", e.what()}});
    }
  }
}

VmcMirror::VmcMirror(std::shared_ptr<const StreamServices> services,
                     std::shared_ptr<Channel> channel, const ServerOptions::Channel::Vmc& settings)
    : services_(std::move(services)),
      channel_(std::move(channel)),
      member_id_(services_->sessions.new_connection_id()) {
  senders_ = vmc_senders(settings, label_);  // label_ is declared after senders_
}

VmcMirror::~VmcMirror() {
  stop();
}

void VmcMirror::stop() {
  if (stopping_.exchange(true)) return;
  channel_->unsubscribe(member_id_);
  { std::lock_guard lock(mutex_); }  // run() between its check and its wait sees the flag
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void VmcMirror::deliver(OutBatch batch) {
  for (const OutMessage& message : *batch) {
    if (stopping_) return;
    try {
      std::lock_guard lock(mutex_);
      timeline_.take(message, frames_);
      wake_.notify_one();
    } catch (const std::exception& e) {  // a message this mirror cannot read: skip it
      log::warn("vmc_message_skipped", {{"channel", channel_->name()}, {"error", e.what()}});
    }
  }
}

void VmcTimeline::take(const OutMessage& message, std::deque<Frame>& out) {
  if (message.kind == OutKind::kControl) {
    if (message.boundary != Boundary::kStart) return;
    const auto j = nlohmann::json::parse(*message.data, nullptr, false);
    if (!j.is_object() || j.value("type", "") != "stream_start" ||
        j.value("output", "") != "weights")
      return;
    const auto id = j["stream"].get<std::uint32_t>();
    if (id == stream_) return;  // a late join's repeat of what is on air
    stream_ = id;
    names_ = std::make_shared<const std::vector<std::string>>(
        j["names"].get<std::vector<std::string>>());
    lead_ = j.value("lead", 0.0);
    fps_ = j.value("fps", 30.0);
    placed_ = false;
    return;
  }
  const MediaHeader h = read_header(*message.data);
  if (h.kind != MediaKind::kWeights || h.stream != stream_ || !names_) return;
  const auto now = Clock::now();
  if (!placed_) {
    // pts p arrives about `lead` before its time: the stream's zero is then now + lead - p.
    zero_ = now + std::chrono::duration_cast<Clock::duration>(
                      std::chrono::duration<double>(lead_ - h.pts));
    placed_ = true;
  }
  const std::vector<float> v = read_floats(std::string_view(*message.data).substr(kHeaderSize));
  const std::size_t per = names_->size() + rig::BodyPose::kChannels.size();
  for (std::uint32_t i = 0; i < h.count && (i + 1) * per <= v.size(); ++i) {
    Frame f;
    f.names = names_;
    f.values.assign(v.begin() + i * per, v.begin() + (i + 1) * per);
    f.t = h.pts + i / fps_;
    f.due = zero_ + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(f.t));
    out.push_back(std::move(f));
  }
}

void VmcMirror::run() {
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    if (frames_.empty()) {
      wake_.wait(lock);
      continue;
    }
    if (wake_.wait_until(lock, frames_.front().due, [&] { return stopping_.load(); })) break;
    const VmcTimeline::Frame f = std::move(frames_.front());
    frames_.pop_front();
    lock.unlock();
    send_vmc_frame(senders_, f, channel_->name());
    lock.lock();
  }
}

VmcTee::VmcTee(net::any_io_executor strand, StreamSink& inner,
               const ServerOptions::Channel::Vmc& target, std::string conn)
    : inner_(inner), timer_(std::move(strand)), conn_(std::move(conn)) {
  std::string label;
  senders_ = vmc_senders(target, label);
  log::info("vmc_speak", {{"conn", conn_}, {"targets", label}, {"names", target.names}});
}

std::uint32_t VmcTee::send(OutMessage message) {
  try {
    timeline_.take(message, frames_);
  } catch (const std::exception& e) {  // a message this mirror cannot read: skip it
    log::warn("vmc_message_skipped", {{"conn", conn_}, {"error", e.what()}});
  }
  arm();
  return inner_.send(std::move(message));
}

// Sends what is due, then waits for the next frame (on the strand: no thread, no lock).
void VmcTee::arm() {
  if (armed_ || frames_.empty()) return;
  armed_ = true;
  timer_.expires_at(frames_.front().due);
  timer_.async_wait([self = shared_from_this()](beast::error_code ec) {
    self->armed_ = false;
    if (ec) return;
    while (!self->frames_.empty() && self->frames_.front().due <= VmcTimeline::Clock::now()) {
      send_vmc_frame(self->senders_, self->frames_.front(), self->conn_);
      self->frames_.pop_front();
    }
    self->arm();
  });
}

std::vector<std::shared_ptr<VmcMirror>> start_vmc_mirrors(
    const std::shared_ptr<const StreamServices>& services, const ChannelRegistry& channels) {
  std::vector<std::shared_ptr<VmcMirror>> out;
  for (const auto& ch : services->options.channels)
    if (ch.vmc && !ch.vmc->targets.empty())
      if (const auto channel = channels.find(ch.name))
        out.push_back(VmcMirror::start(services, channel, *ch.vmc));
  return out;
}

}  // namespace facecast::server
