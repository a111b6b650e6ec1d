#pragma once
// Streams mirrored to VMC receivers (desktop VTuber apps showing the same performance): a channel
// (channels.<name>.vmc) through VmcMirror, a subscriber like any viewer, and a private utterance
// that names a receiver of the vmc_targets allow-list through VmcTee, a StreamSink in front of
// the connection's. Each weights frame is sent as one VMC bundle (facecast/server/vmc.hpp) to
// every target when it is due -- at the arrival of the stream's first frame plus the server's
// lead, plus the frame's pts -- so the burst of the first `lead` seconds plays out at the frame
// rate.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "channel.hpp"
#include "facecast/server/vmc.hpp"
#include "stream_pacer.hpp"

namespace facecast::server {

/// Where the frames of a stream's messages are due (shared by the two mirrors).
class VmcTimeline {
 public:
  using Clock = std::chrono::steady_clock;
  struct Frame {
    Clock::time_point due;
    std::shared_ptr<const std::vector<std::string>> names;
    std::vector<float> values;  // weights, then yaw, pitch, roll
    double t = 0;               // pts
  };
  /// Appends the frames of `message` (a weights stream's stream_start or weights) to `out`;
  /// anything else is ignored. Throws on a message it cannot read.
  void take(const OutMessage& message, std::deque<Frame>& out);

 private:
  // The stream on air: its id, names, lead and where its pts 0 lies.
  std::uint32_t stream_ = 0;
  std::shared_ptr<const std::vector<std::string>> names_;
  double lead_ = 0, fps_ = 30;
  bool placed_ = false;
  Clock::time_point zero_;
};

/// The senders of a VMC setting (throws Error for a target that does not resolve) and its label.
std::vector<std::unique_ptr<VmcSender>> vmc_senders(const ServerOptions::Channel::Vmc& settings,
                                                    std::string& label);
/// One frame to every sender; a receiver that is not there is logged at debug level.
void send_vmc_frame(const std::vector<std::unique_ptr<VmcSender>>& senders,
                    const VmcTimeline::Frame& frame, const std::string& where);

class VmcMirror final : public ChannelMember, public std::enable_shared_from_this<VmcMirror> {
 public:
  /// Subscribes to `channel` and starts the sending thread; throws Error for a target that does
  /// not resolve.
  static std::shared_ptr<VmcMirror> start(std::shared_ptr<const StreamServices> services,
                                          std::shared_ptr<Channel> channel,
                                          const ServerOptions::Channel::Vmc& settings);
  VmcMirror(std::shared_ptr<const StreamServices> services, std::shared_ptr<Channel> channel,
            const ServerOptions::Channel::Vmc& settings);
  ~VmcMirror() override;

  void deliver(OutBatch batch) override;
  /// Unsubscribes and joins the thread; idempotent.
  void stop();

 private:
  void run();

  std::shared_ptr<const StreamServices> services_;
  std::shared_ptr<Channel> channel_;
  std::uint64_t member_id_;
  std::vector<std::unique_ptr<VmcSender>> senders_;
  std::string label_;  // the targets, for the logs
  std::mutex mutex_;
  std::condition_variable wake_;
  VmcTimeline timeline_;
  std::deque<VmcTimeline::Frame> frames_;
  std::atomic<bool> stopping_{false};
  std::thread thread_;
};

/// A private utterance mirrored to the named receiver of vmc_targets: passes every message on to
/// the connection's sink and sends the weights frames at their time from a timer on the
/// connection's strand. Owned by the utterance's StreamPacer (through its end callback) and by
/// its pending timer, so the last `lead` seconds still play after the stream has been sent.
class VmcTee final : public StreamSink, public std::enable_shared_from_this<VmcTee> {
 public:
  VmcTee(net::any_io_executor strand, StreamSink& inner, const ServerOptions::Channel::Vmc& target,
         std::string conn);

  std::uint32_t send(OutMessage message) override;
  bool media_full() override { return inner_.media_full(); }
  void send_error(const std::optional<std::string>& id, const Problem& problem) override {
    inner_.send_error(id, problem);
  }
  double send_ahead() const override { return inner_.send_ahead(); }

 private:
  void arm();

  StreamSink& inner_;
  net::steady_timer timer_;
  std::vector<std::unique_ptr<VmcSender>> senders_;
  std::string conn_;
  VmcTimeline timeline_;
  std::deque<VmcTimeline::Frame> frames_;
  bool armed_ = false;
};

/// Starts the VMC mirrors of the configured channels (ServerOptions::Channel::vmc).
std::vector<std::shared_ptr<VmcMirror>> start_vmc_mirrors(
    const std::shared_ptr<const StreamServices>& services, const ChannelRegistry& channels);

}  // namespace facecast::server
