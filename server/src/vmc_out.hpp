#pragma once
// A channel mirrored to VMC receivers (channels.<name>.vmc: desktop VTuber apps showing the same
// performance as the channel's viewers). A subscriber like any viewer: each weights frame is sent
// as one VMC bundle (facecast/server/vmc.hpp) to every target when it is due -- at the arrival of
// the stream's first frame plus the server's lead, plus the frame's pts -- so the burst of the
// first `lead` seconds plays out at the frame rate.
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

namespace facecast::server {

class VmcMirror final : public ChannelMember, public std::enable_shared_from_this<VmcMirror> {
 public:
  /// Subscribes to `channel` and starts the sending thread; throws Error for a target that does
  /// not resolve.
  static std::shared_ptr<VmcMirror> start(std::shared_ptr<State> state,
                                          std::shared_ptr<Channel> channel,
                                          const ServerOptions::Channel::Vmc& settings);
  VmcMirror(std::shared_ptr<State> state, std::shared_ptr<Channel> channel,
            const ServerOptions::Channel::Vmc& settings);
  ~VmcMirror() override;

  void deliver(OutBatch batch) override;
  /// Unsubscribes and joins the thread; idempotent.
  void stop();

 private:
  using Clock = std::chrono::steady_clock;
  struct Frame {
    Clock::time_point due;
    std::shared_ptr<const std::vector<std::string>> names;
    std::vector<float> values;  // weights, then yaw, pitch, roll
    double t = 0;               // pts
  };
  void take(const OutMessage& message);
  void run();

  std::shared_ptr<State> state_;
  std::shared_ptr<Channel> channel_;
  std::uint64_t member_id_;
  std::vector<std::unique_ptr<VmcSender>> senders_;
  std::string label_;  // the targets, for the logs
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Frame> frames_;
  // The stream on air: its id, names, lead and where its pts 0 lies.
  std::uint32_t stream_ = 0;
  std::shared_ptr<const std::vector<std::string>> names_;
  double lead_ = 0, fps_ = 30;
  bool placed_ = false;
  Clock::time_point zero_;
  std::atomic<bool> stopping_{false};
  std::thread thread_;
};

/// Starts the VMC mirrors of the configured channels (ServerOptions::Channel::vmc).
std::vector<std::shared_ptr<VmcMirror>> start_vmc_mirrors(const std::shared_ptr<State>& state);

}  // namespace facecast::server
