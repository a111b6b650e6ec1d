#pragma once
// How an avatar stands. The rest pose: an avatar saved in T- or A-pose (arms straight out, as Ready
// Player Me, Mixamo, VRoid and MakeHuman export them) stands with its arms down. A pose file turns
// the bones it names. Both are linear blend skinning on the rig's own skeleton: each turned joint
// turns about its origin, carrying the joints under it; vertices, normals, shape deltas and joint
// origins follow their skin weights. The face (no weight on a turned joint) is untouched, so the
// rig builder's face view and every shape stay as they are.
#include <Eigen/Geometry>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "facecast/rig/rig.hpp"

namespace facecast::rig {

/// One bone of a pose: its turn about its joint, in the rig's axes (the figure faces +Z, as in
/// the VRM 1.0 frame pose files are written in; a VRM 0.x figure is turned to face +Z when read).
struct BoneTurn {
  std::string bone;
  Eigen::Quaternionf rotation = Eigen::Quaternionf::Identity();
};

/// How an avatar is drawn: as its file holds it (bind), standing at rest (rest, the default), or
/// with the bones of a pose file turned (file).
struct Pose {
  enum class Kind { kBind, kRest, kFile };
  Kind kind = Kind::kRest;
  std::vector<BoneTurn> bones;  // kFile
  std::string source;           // kFile: the file, for messages
};

/// What a pose turned: the joints' names and their turns in degrees.
struct PoseReport {
  std::vector<std::pair<std::string, float>> turned;
};

/// The joint of a VRM humanoid bone ("head", "leftUpperArm" ...): the file's humanoid, else the
/// head and neck the skeleton found by name and the upper arms by configs/rig/humanoid.json; -1.
int humanoid_joint(const Skeleton& s, std::string_view bone);

/// Finds the upper arms (the VRM humanoid's leftUpperArm/rightUpperArm, else the name table in
/// configs/rig/humanoid.json) and turns each down (see the config). A rig without a skeleton or
/// arms is left as it is.
PoseReport apply_rest_pose(Rig& rig);

/// Turns the bones of a pose file. A bone is a VRM humanoid bone name ("leftUpperArm", found by
/// the file's humanoid or, for the upper arms, by configs/rig/humanoid.json's names) or a joint's
/// own name. A bone the rig does not have is an Error naming it and the file; a rig without a
/// skeleton is left as it is.
PoseReport apply_pose_file(Rig& rig, const Pose& pose);

/// bind: nothing; rest: apply_rest_pose; file: apply_pose_file.
PoseReport apply_pose(Rig& rig, const Pose& pose);

/// Reads a pose file (JSON, at most 1 MiB): an object of bones, each {"rotation": [x, y, z, w]}
/// (a quaternion, as three-vrm's VRMPose holds it) or {"euler_deg": [x, y, z]} (degrees, about x
/// then y then z), in the VRM 1.0 frame (the figure faces +z, y up); "position" is allowed and
/// ignored (the figure stays where it stands). Errors name the file and the field.
Pose read_pose_file(const std::filesystem::path& path);

/// Parses "bind", "rest" or the path of a pose file (an Error naming `what` otherwise).
Pose parse_pose(const std::string& value, const std::string& what);

}  // namespace facecast::rig
