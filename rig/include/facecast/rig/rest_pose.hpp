#pragma once
// The rest pose: an avatar saved in T- or A-pose (arms straight out, as Ready Player Me, Mixamo,
// VRoid and MakeHuman export them) stands with its arms down. Linear blend skinning on the rig's
// own skeleton: each upper arm turns about its joint, carrying the joints under it; vertices,
// normals, shape deltas and joint origins follow their skin weights. The face (no arm weight) is
// untouched, so the rig builder's face view and every shape stay as they are.
#include <string>
#include <vector>

#include "facecast/rig/rig.hpp"

namespace facecast::rig {

/// How an avatar is drawn: as its file holds it (bind) or standing at rest (rest, the default).
enum class Pose { kBind, kRest };

/// What the rest pose turned: the upper arms' joint names and their turns in degrees.
struct RestPoseReport {
  std::vector<std::pair<std::string, float>> turned;
};

/// Finds the upper arms (Skeleton::left_upper_arm/right_upper_arm, else the name table in
/// configs/rig/humanoid.json) and turns each down (see the config). A rig without a skeleton or
/// arms is left as it is.
RestPoseReport apply_rest_pose(Rig& rig);

/// Parses "bind" or "rest" (an Error naming `what` otherwise).
Pose parse_pose(const std::string& name, const std::string& what);

}  // namespace facecast::rig
