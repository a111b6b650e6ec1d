#pragma once
// The body on a skeleton: which joints a BodyPose turns (the head and neck, the chest that
// breathes, the spine that leans, the shoulders that rise) and the joint motions that result.
// The renderer skins with these every frame; the rest pose and pose files turn joints through the
// same composition once.
#include <Eigen/Geometry>
#include <utility>
#include <vector>

#include "facecast/rig/motion.hpp"
#include "facecast/rig/rig.hpp"

namespace facecast::rig {

/// Turns per unit of the body's channels, and the spring bones' step rate; defaults mirrored in
/// configs/rig/body.json.
struct BodyOptions {
  float neck_share = 0.4f;           // of the head's turn the neck takes (the head the rest)
  float breath_chest_deg = 1.2f;     // the chest pitched back at breath 1 (the neck keeps the head)
  float breath_shoulder_deg = 1.0f;  // the shoulders raised at breath 1
  float shrug_deg = 6.0f;            // the shoulders raised at shrug 1 (the arms keep hanging)
  float lean_counter = 0.7f;         // of the spine's lean the chest turns back: the head stays up
  float spring_rate = 60;            // spring bone steps per second (spring_sim.hpp)
};

/// BodyOptions from configs/rig/body.json; throws Error naming the field when invalid.
const BodyOptions& body_options();

/// The joints a BodyPose turns, -1 where the skeleton has none. The VRM humanoid names them where
/// the file has one; otherwise they are found from the head down: the chest carries the neck, the
/// spine runs from the hips (the first joint below the chest that another limb branches from) up
/// to the chest, a shoulder carries an upper arm (rest_pose.hpp finds those). A chest that would
/// be the skeleton's root is none: then only the head and neck turn.
struct BodyJoints {
  int head = -1, neck = -1, chest = -1;
  std::vector<int> spine;                               // lowest first; empty: the chest leans
  int shoulder[2] = {-1, -1}, upper_arm[2] = {-1, -1};  // left, right (of the figure)

  /// Every joint above, once.
  std::vector<int> all() const;
};
BodyJoints find_body_joints(const Skeleton& s);

using JointTurns = std::vector<std::pair<int, Eigen::Quaternionf>>;

/// The turn of each joint that `pose` asks for, in the file's axes about the joint's origin: the
/// head's rotation shared by neck and head, the breath and shrug raising the shoulders (the upper
/// arms turned back so the arms keep hanging), the breath pitching the chest back, the lean
/// spread over the spine with the chest turning part of it back.
JointTurns body_turns(const BodyJoints& joints, const Skeleton& s, const BodyPose& pose,
                      const BodyOptions& options = body_options());

/// Each joint's motion for local turns: D_j = D_parent * T(o_j) R_j T(-o_j) (o_j its rest
/// origin); `moved[j]` (optional) says whether D_j differs from the identity. Throws Error when
/// the parents form a cycle.
std::vector<Eigen::Affine3f> compose_turns(const Skeleton& s, const JointTurns& turns,
                                           std::vector<char>* moved = nullptr);

}  // namespace facecast::rig
