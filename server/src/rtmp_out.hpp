#pragma once
// A channel published as a live video: RTMP (H.264 + AAC in FLV, what streaming platforms ingest)
// through an ffmpeg child process fed raw RGB frames on its stdin and PCM16 on fd 3.
//
// The output is a subscriber of the channel (it receives the same stream_start, weights and audio
// messages as any viewer) that places every stream on one output timeline: a stream starts at
// t0 = the output frame on or after (arrival of its first media + delay - that media's pts), its
// weights frame f is shown at t0 + f / fps_stream and its audio sample s is played at
// t0 + s / rate_stream. Output frame k covers [k / fps, (k + 1) / fps) and carries the samples
// [round(k * R / fps), round((k + 1) * R / fps)) of the output rate R, so audio and video advance
// from one clock and the mouth keeps within a frame of the sound however late the messages come
// (docs/algorithms.md#rtmp-out). Between streams the face holds the last pose with silence; a
// frame whose deadline passed by more than a frame repeats the last picture. When ffmpeg
// exits (the ingest server went away) it is started again after `kRestartSeconds`.
#include <atomic>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "channel.hpp"
#include "facecast/core/subprocess.hpp"
#include "facecast/render/image.hpp"
#include "facecast/render/renderer.hpp"

namespace facecast::server {

class RtmpOutput final : public ChannelMember, public std::enable_shared_from_this<RtmpOutput> {
 public:
  /// Subscribes to `channel` and starts publishing to settings.url.
  static std::shared_ptr<RtmpOutput> start(std::shared_ptr<const StreamServices> services,
                                           std::shared_ptr<Channel> channel,
                                           const ServerOptions::Rtmp& settings);
  ~RtmpOutput() override;

  void deliver(OutBatch batch) override;
  /// Unsubscribes, lets ffmpeg finish the stream (FLV trailer) and joins; idempotent.
  void stop();

  /// The output sample rate (AAC).
  static constexpr int kRate = 48000;
  static constexpr double kRestartSeconds = 2.0;
  static constexpr double kStallSeconds = 5.0;  // ffmpeg not reading this long: restarted

  RtmpOutput(std::shared_ptr<const StreamServices> services, std::shared_ptr<Channel> channel,
             ServerOptions::Rtmp settings);

 private:
  struct Stream {
    std::uint32_t id = 0;
    std::string rig;
    std::size_t names = 0;  // shape weights per frame (then 3 head angles)
    double fps = 30;
    int rate = 0;  // audio sample rate, 0: none
    bool placed = false;
    double t0 = 0;                                       // output seconds of its pts 0
    std::map<std::uint32_t, std::vector<float>> frames;  // frame -> weights + head
    std::vector<std::int16_t> pcm;                       // from sample 0
  };
  struct Pose {
    std::string rig;
    std::vector<float> values;  // weights + head
  };

  void take(const OutMessage& message);  // deliver()'s work (throws on a malformed message)
  void run();
  /// The pose at output time t and the samples of [first, first + count) (output rate).
  Pose sample(double t, std::int64_t first, std::size_t count, std::vector<std::int16_t>& pcm);
  /// The picture of `pose` at output time `time` (the spring bones step to it).
  render::Image render(const Pose& pose, double time);
  bool spawn();
  void end_ffmpeg();
  bool write_all(int fd, const void* data, std::size_t size);

  std::shared_ptr<const StreamServices> services_;
  std::shared_ptr<Channel> channel_;
  ServerOptions::Rtmp settings_;
  std::uint64_t member_id_;
  std::chrono::steady_clock::time_point clock_start_;

  std::mutex mutex_;            // streams_, last_
  std::deque<Stream> streams_;  // in order of start
  Pose last_;

  std::atomic<bool> stopping_{false};
  std::thread thread_;
  std::optional<Child> ffmpeg_;  // pictures on its stdin, sound on its descriptor 3
  render::Image last_image_;
  std::shared_ptr<render::Renderer> springs_renderer_;  // the renderer springs_ simulates for
  rig::SpringSim springs_;
};

/// Starts the RTMP outputs of the configured channels (ServerOptions::rtmp).
std::vector<std::shared_ptr<RtmpOutput>> start_rtmp_outputs(
    const std::shared_ptr<const StreamServices>& services, const ChannelRegistry& channels);

}  // namespace facecast::server
