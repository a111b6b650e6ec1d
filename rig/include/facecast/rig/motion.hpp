#pragma once
// What drives a rig over time: blendshape weights and the head's turn at any moment. The animation
// chain's anim::Performance is one; the renderer and the video writer take any Motion, so they need
// nothing of speech.
#include <span>
#include <string>
#include <vector>

namespace facecast::rig {

/// Small head rotation, radians, applied about the neck (yaw about +Y, pitch about +X, roll about
/// +Z, in that order).
struct HeadPose {
  float yaw = 0, pitch = 0, roll = 0;
};

/// Weights and head pose as functions of time.
class Motion {
 public:
  virtual ~Motion() = default;
  /// Seconds from the start to when the face is back at rest.
  virtual double duration() const = 0;
  /// The rig's shape names, in the order sample() writes them.
  virtual const std::vector<std::string>& shape_names() const = 0;
  /// Weights at time `t` seconds, one per shape; `head` (optional) receives the head pose.
  /// Thread-safe (const).
  virtual void sample(double t, std::span<float> weights, HeadPose* head = nullptr) const = 0;

 protected:
  Motion() = default;
  Motion(const Motion&) = default;
  Motion& operator=(const Motion&) = default;
};

}  // namespace facecast::rig
