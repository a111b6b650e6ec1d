#pragma once
// Spring bones in motion: hair and clothes that trail the body. Each spring joint's tail is a
// point mass on a rod (VRMC_springBone's model, stepped as UniVRM and three-vrm step it): it keeps
// part of its last step's motion (1 - drag), is pulled toward where the joint's parent carries it
// (stiffness) and along gravity, keeps its rod's length and stays out of its spring's colliders;
// the joint turns to point at it. The simulation steps at a fixed rate, so a stream's motion is
// the same whatever its frame rate, and is deterministic for a given sequence of poses.
#include <Eigen/Geometry>
#include <vector>

#include "facecast/rig/body.hpp"
#include "facecast/rig/motion.hpp"
#include "facecast/rig/rig.hpp"

namespace facecast::rig {

class SpringSim {
 public:
  /// No springs: advance() returns nothing.
  SpringSim() = default;
  /// Over the spring bones of `s`, with the body turned through `joints` (find_body_joints), at
  /// `body_options().spring_rate` steps per second. A skeleton whose parents form a cycle has no
  /// springs here.
  SpringSim(const Skeleton& s, BodyJoints joints);
  explicit SpringSim(const Skeleton& s) : SpringSim(s, find_body_joints(s)) {}

  bool empty() const { return turns_.empty(); }

  /// The spring joints' turns (as body_turns gives them: about each joint's rest origin) at
  /// `time`, in seconds: the first call places the springs at rest in `pose`; later calls step
  /// from the last call's time with the body moving from its pose to `pose`, at most two seconds
  /// of steps (a longer gap is skipped). A time not after the last call's changes nothing.
  const JointTurns& advance(const BodyPose& pose, double time);

 private:
  struct Tail {
    Eigen::Vector3f prev{0, 0, 0}, cur{0, 0, 0};
  };
  void compose(const JointTurns& body);
  void refresh_below(int joint);
  void step(const JointTurns& body, bool first);

  Skeleton s_;
  BodyJoints joints_;
  double step_ = 1.0 / 60;
  std::vector<int> order_;                  // joints, parents first
  std::vector<std::vector<int>> children_;  // per joint
  std::vector<Eigen::Affine3f> local_, motion_;
  std::vector<Tail> tails_;  // per spring joint, springs in order
  JointTurns turns_;         // per spring joint
  JointTurns last_body_;
  double t0_ = 0, last_time_ = 0;
  long steps_ = 0;
  bool started_ = false;
};

}  // namespace facecast::rig
