#pragma once
// What drives a rig over time: blendshape weights and the body's pose at any moment. The animation
// chain's anim::Performance is one; the renderer and the video writer take any Motion, so they need
// nothing of speech.
#include <array>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace facecast::rig {

/// The pose beside the face: a small head rotation (radians, about the neck: yaw about +Y, pitch
/// about +X, roll about +Z, in that order, in the figure's own frame: facing +Z) and the idle
/// body. A renderer turns the skeleton's joints by it (see body.hpp); a rig without a skeleton
/// turns whole with the head and ignores the body.
struct BodyPose {
  float yaw = 0, pitch = 0, roll = 0;
  float breath = 0;  // the chest's rise, 0 (breathed out) to 1 (breathed in)
  float lean = 0;    // weight shift: the spine's sideways lean, radians, + to the figure's left
  float shrug = 0;   // the shoulders raised, 0 to 1

  /// The channels as streamed after the shapes' weights (the protocol's "extra"), in order.
  static constexpr std::array<std::string_view, 6> kChannels = {"headYaw", "headPitch", "headRoll",
                                                                "breath",  "lean",      "shrug"};
  std::array<float, 6> channels() const { return {yaw, pitch, roll, breath, lean, shrug}; }
  /// From kChannels.size() values in that order.
  static BodyPose from_channels(std::span<const float> v) {
    return {v[0], v[1], v[2], v[3], v[4], v[5]};
  }
};

/// Weights and body pose as functions of time.
class Motion {
 public:
  virtual ~Motion() = default;
  /// Seconds from the start to when the face is back at rest.
  virtual double duration() const = 0;
  /// The rig's shape names, in the order sample() writes them.
  virtual const std::vector<std::string>& shape_names() const = 0;
  /// Weights at time `t` seconds, one per shape; `pose` (optional) receives the body pose.
  /// Thread-safe (const).
  virtual void sample(double t, std::span<float> weights, BodyPose* pose = nullptr) const = 0;

 protected:
  Motion() = default;
  Motion(const Motion&) = default;
  Motion& operator=(const Motion&) = default;
};

}  // namespace facecast::rig
