// Poses (see rest_pose.hpp): the rest pose's upper arms found by VRM humanoid bone or by name
// (configs/rig/humanoid.json) and turned down about their joints, or a pose file's bones; the rig
// re-skinned on the CPU.
#include "facecast/rig/rest_pose.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>

#include "facecast/core/config.hpp"
#include "facecast/core/config_reader.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/core/json_limits.hpp"
#include "facecast/rig/body.hpp"

namespace facecast::rig {
namespace {

constexpr float kPi = 3.14159265f;

struct HumanoidTable {
  std::vector<std::string> prefixes, left, right;
  float arm_angle_deg = 10, min_turn_deg = 15;
  std::vector<float> finger_curl_deg{15, 25, 15};  // per finger joint from the hand out
};

const HumanoidTable& table() {
  static const HumanoidTable t = [] {
    HumanoidTable h;
    ConfigReader c = ConfigReader::open(config_path("rig/humanoid.json"));
    c.read("prefixes", h.prefixes)
        .read("left_upper_arm", h.left)
        .read("right_upper_arm", h.right)
        .read("arm_angle_deg", h.arm_angle_deg)
        .read("min_turn_deg", h.min_turn_deg)
        .read("finger_curl_deg", h.finger_curl_deg)
        .reject_unknown();
    for (const float deg : h.finger_curl_deg)
      if (!(std::abs(deg) <= 90)) c.fail("finger_curl_deg", "angles must be within 90 degrees");
    return h;
  }();
  return t;
}

// "mixamorig:LeftArm" -> "leftarm", "J_Bip_L_UpperArm" -> "lupperarm", "upperarm01.L" ->
// "upperarm01l": after the namespace, letters and digits in lower case, one prefix dropped.
std::string normalized(const std::string& name, const std::vector<std::string>& prefixes) {
  const auto colon = name.rfind(':');
  std::string n;
  for (const char c : colon == std::string::npos ? name : name.substr(colon + 1))
    if (std::isalnum(static_cast<unsigned char>(c)))
      n += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  for (const auto& p : prefixes)
    if (n.size() > p.size() && n.starts_with(p)) return n.substr(p.size());
  return n;
}

int find_by_name(const Skeleton& s, const std::vector<std::string>& candidates) {
  const HumanoidTable& t = table();
  std::vector<std::string> names;
  for (const auto& n : s.joint_names) names.push_back(normalized(n, t.prefixes));
  for (const auto& c : candidates)
    for (std::size_t j = 0; j < names.size(); ++j)
      if (names[j] == c) return static_cast<int>(j);
  return -1;
}

// The child of `j` whose origin is farthest from j's, or -1.
int farthest_child(const Skeleton& s, int j) {
  int farthest = -1;
  float best = 0;
  for (std::size_t c = 0; c < s.parent.size(); ++c)
    if (s.parent[c] == j) {
      const float d = (s.rest_origin[c] - s.rest_origin[static_cast<std::size_t>(j)]).norm();
      if (d > best) best = d, farthest = static_cast<int>(c);
    }
  return farthest;
}

// The turn that brings the upper arm `arm` down, or none (identity, angle 0) when it has no child
// joint or hangs down already.
std::pair<Eigen::Quaternionf, float> arm_turn(const Skeleton& s, int arm) {
  const auto origin = [&](int j) { return s.rest_origin[static_cast<std::size_t>(j)]; };
  const int farthest = farthest_child(s, arm);
  if (farthest < 0) return {Eigen::Quaternionf::Identity(), 0.0f};
  const Eigen::Vector3f d = (origin(farthest) - origin(arm)).normalized();
  const float a = table().arm_angle_deg * kPi / 180.0f;
  const Eigen::Vector3f down(d.x() >= 0 ? std::sin(a) : -std::sin(a), -std::cos(a), 0.0f);
  const float angle = std::acos(std::clamp(d.dot(down), -1.0f, 1.0f)) * 180.0f / kPi;
  if (angle < table().min_turn_deg) return {Eigen::Quaternionf::Identity(), 0.0f};
  return {Eigen::Quaternionf::FromTwoVectors(d, down), angle};
}

// Relaxed hands: the fingers of the hand below upper arm `arm` (`side` +1: the figure's left, at
// +X) curled toward the palm by finger_curl_deg per joint; the thumb (the finger that points least
// along the hand) left straight. The hand is the arm's farthest child's farthest child; a finger
// is a chain of two or more joints from it. The palm faces where the normal of the plane of the
// hand and its fingers' bases points down and inward; a hand whose palm faces forward or back
// (no such side) stays as it is.
void curl_fingers(const Skeleton& s, int arm, float side, JointTurns& turns, PoseReport& report) {
  const auto origin = [&](int j) { return s.rest_origin[static_cast<std::size_t>(j)]; };
  const int forearm = farthest_child(s, arm);
  const int hand = forearm >= 0 ? farthest_child(s, forearm) : -1;
  if (hand < 0) return;
  const Eigen::Vector3f along = (origin(hand) - origin(forearm)).normalized();
  std::vector<std::vector<int>> fingers;
  for (std::size_t c = 0; c < s.parent.size(); ++c) {
    if (s.parent[c] != hand) continue;
    std::vector<int> chain{static_cast<int>(c)};
    for (int next = farthest_child(s, chain.back()); next >= 0 && chain.size() <= s.parent.size();
         next = farthest_child(s, chain.back()))
      chain.push_back(next);
    if (chain.size() >= 2) fingers.push_back(std::move(chain));
  }
  if (fingers.size() < 3) return;
  const auto direction = [&](const std::vector<int>& f) {
    return Eigen::Vector3f((origin(f.back()) - origin(f.front())).normalized());
  };
  const auto thumb =
      std::min_element(fingers.begin(), fingers.end(), [&](const auto& a, const auto& b) {
        return direction(a).dot(along) < direction(b).dot(along);
      });
  fingers.erase(thumb);
  // Across the hand: between the two finger bases farthest apart.
  Eigen::Vector3f across = Eigen::Vector3f::Zero();
  for (const auto& a : fingers)
    for (const auto& b : fingers)
      if ((origin(a.front()) - origin(b.front())).norm() > across.norm())
        across = origin(a.front()) - origin(b.front());
  Eigen::Vector3f palm = along.cross(across);
  if (palm.norm() < 1e-9f) return;
  palm.normalize();
  const float facing = palm.dot(Eigen::Vector3f(-side, -1, 0).normalized());
  if (std::abs(facing) < 0.3f) return;
  if (facing < 0) palm = -palm;
  const auto& curl = table().finger_curl_deg;
  for (const auto& f : fingers)
    for (std::size_t k = 0; k + 1 < f.size() && k < curl.size(); ++k) {
      const Eigen::Vector3f d = (origin(f[k + 1]) - origin(f[k])).normalized();
      const Eigen::Vector3f axis = d.cross(palm);
      if (axis.norm() < 1e-6f || curl[k] == 0) continue;
      turns.emplace_back(f[k], Eigen::AngleAxisf(curl[k] * kPi / 180.0f, axis.normalized()));
      report.turned.emplace_back(s.joint_names[static_cast<std::size_t>(f[k])], curl[k]);
    }
}

bool has_skeleton(const Rig& rig) {
  const Skeleton& s = rig.skeleton;
  const std::size_t nj = s.joint_names.size();
  return nj > 0 && s.parent.size() == nj && s.rest_origin.size() == nj &&
         rig.joints.rows() == rig.vertex_count();
}

// Turns joints (each about its own origin, in the file's axes, carrying the joints under it) and
// re-skins the rig.
void turn_joints(Rig& rig, const JointTurns& turns) {
  Skeleton& s = rig.skeleton;
  const std::size_t nj = s.joint_names.size();
  std::vector<char> moved;
  const std::vector<Eigen::Affine3f> motion = compose_turns(s, turns, &moved);

  // Vertices, normals and shape deltas by their blended joint motion; joint origins by their
  // parent's.
  const int nv = rig.vertex_count();
  std::vector<Eigen::Matrix3f> linear(static_cast<std::size_t>(nv));
  std::vector<char> vertex_moved(static_cast<std::size_t>(nv), 0);
  for (int v = 0; v < nv; ++v) {
    float total = 0;
    bool any = false;
    for (int k = 0; k < 4; ++k) {
      const int j = rig.joints(v, k);
      const float w = rig.joint_weights(v, k);
      if (w <= 0 || j < 0 || static_cast<std::size_t>(j) >= nj) continue;
      total += w;
      any |= moved[static_cast<std::size_t>(j)] != 0;
    }
    if (!any || total <= 1e-6f) continue;
    Eigen::Matrix4f m = Eigen::Matrix4f::Zero();
    for (int k = 0; k < 4; ++k) {
      const int j = rig.joints(v, k);
      const float w = rig.joint_weights(v, k);
      if (w <= 0 || j < 0 || static_cast<std::size_t>(j) >= nj) continue;
      const auto uj = static_cast<std::size_t>(j);
      m += (w / total) * (moved[uj] ? motion[uj].matrix() : Eigen::Matrix4f::Identity());
    }
    const Eigen::Vector3f p = rig.positions.row(v).transpose();
    rig.positions.row(v) = (m.topLeftCorner<3, 3>() * p + m.topRightCorner<3, 1>()).transpose();
    linear[static_cast<std::size_t>(v)] = m.topLeftCorner<3, 3>();
    vertex_moved[static_cast<std::size_t>(v)] = 1;
    if (rig.normals.rows() == nv)
      rig.normals.row(v) =
          (m.topLeftCorner<3, 3>() * rig.normals.row(v).transpose()).normalized().transpose();
  }
  for (auto& shape : rig.shapes)
    for (std::size_t i = 0; i < shape.vertices.size(); ++i) {
      const auto v = static_cast<std::size_t>(shape.vertices[i]);
      const auto row = static_cast<Eigen::Index>(i);
      if (vertex_moved[v])
        shape.deltas.row(row) = (linear[v] * shape.deltas.row(row).transpose()).transpose();
    }
  for (std::size_t j = 0; j < nj; ++j) {
    const int p = s.parent[j];
    if (p >= 0 && moved[static_cast<std::size_t>(p)])
      s.rest_origin[j] = motion[static_cast<std::size_t>(p)] * s.rest_origin[j];
  }
  // Spring tails hang from their joint, colliders from theirs.
  const auto carried = [&](int j) { return j >= 0 && moved[static_cast<std::size_t>(j)]; };
  for (auto& spring : s.springs.springs)
    for (auto& sj : spring.joints)
      if (carried(sj.joint)) sj.tail = motion[static_cast<std::size_t>(sj.joint)] * sj.tail;
  for (auto& c : s.springs.colliders)
    if (carried(c.joint)) {
      c.offset = motion[static_cast<std::size_t>(c.joint)] * c.offset;
      c.tail = motion[static_cast<std::size_t>(c.joint)] * c.tail;
    }
}

float degrees(const Eigen::Quaternionf& q) {
  return 2.0f * std::acos(std::clamp(std::abs(q.w()), 0.0f, 1.0f)) * 180.0f / kPi;
}

}  // namespace

// The joint of a humanoid bone: the VRM humanoid's, else the head and neck the skeleton found by
// name, the upper arms by the name table.
int humanoid_joint(const Skeleton& s, std::string_view bone) {
  if (const int j = s.humanoid_bone(bone); j >= 0) return j;
  if (bone == "head") return s.head;
  if (bone == "neck") return s.neck;
  if (bone == "leftUpperArm") return find_by_name(s, table().left);
  if (bone == "rightUpperArm") return find_by_name(s, table().right);
  return -1;
}

PoseReport apply_rest_pose(Rig& rig) {
  PoseReport report;
  if (!has_skeleton(rig)) return report;
  const Skeleton& s = rig.skeleton;
  JointTurns turns;
  for (const char* bone : {"leftUpperArm", "rightUpperArm"}) {
    const int arm = humanoid_joint(s, bone);
    if (arm < 0) continue;
    curl_fingers(s, arm, bone[0] == 'l' ? 1.0f : -1.0f, turns, report);
    const auto [turn, angle] = arm_turn(s, arm);
    if (angle == 0.0f) continue;
    turns.emplace_back(arm, turn);
    report.turned.emplace_back(s.joint_names[static_cast<std::size_t>(arm)], angle);
  }
  if (!turns.empty()) turn_joints(rig, turns);
  return report;
}

PoseReport apply_pose_file(Rig& rig, const Pose& pose) {
  PoseReport report;
  if (!has_skeleton(rig)) return report;
  const Skeleton& s = rig.skeleton;
  JointTurns turns;
  for (const BoneTurn& b : pose.bones) {
    int joint = humanoid_joint(s, b.bone);
    for (std::size_t j = 0; joint < 0 && j < s.joint_names.size(); ++j)
      if (s.joint_names[j] == b.bone) joint = static_cast<int>(j);
    if (joint < 0)
      throw Error(pose.source + ": " + b.bone + ": the avatar has no such bone (a VRM humanoid " +
                  "bone name or one of its joints' names)");
    // The file is in the VRM 1.0 frame, the rig's own (a VRM 0.x figure was turned to face +Z).
    const Eigen::Quaternionf q = b.rotation;
    turns.emplace_back(joint, q);
    report.turned.emplace_back(s.joint_names[static_cast<std::size_t>(joint)], degrees(q));
  }
  if (!turns.empty()) turn_joints(rig, turns);
  return report;
}

PoseReport apply_pose(Rig& rig, const Pose& pose) {
  switch (pose.kind) {
    case Pose::Kind::kRest:
      return apply_rest_pose(rig);
    case Pose::Kind::kFile:
      return apply_pose_file(rig, pose);
    case Pose::Kind::kBind:
      break;
  }
  return {};
}

Pose read_pose_file(const std::filesystem::path& path) {
  constexpr std::uintmax_t kMaxBytes = 1 << 20;
  constexpr int kMaxDepth = 8;
  const std::string where = path.string();
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) throw Error(where + ": cannot read the pose file: " + ec.message());
  if (size > kMaxBytes) throw Error(where + ": a pose file is at most 1 MiB", ErrorCode::kLimit);
  const std::string text = read_file(path);
  check_json_depth(text, kMaxDepth, where);
  nlohmann::json json;
  try {
    json = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception&) {
    throw Error(where + ": invalid JSON");
  }
  ConfigReader c(std::move(json), where);
  Pose pose{Pose::Kind::kFile, {}, where};
  for (const std::string& bone : c.keys()) {
    ConfigReader& b = c.section(bone);
    std::vector<double> rotation, euler, position;
    b.read("rotation", rotation).read("euler_deg", euler).read("position", position);
    b.reject_unknown();
    const auto finite = [](const std::vector<double>& v) {
      return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
    };
    Eigen::Quaternionf q = Eigen::Quaternionf::Identity();
    if (!rotation.empty() == !euler.empty())
      b.fail("needs \"rotation\" [x, y, z, w] or \"euler_deg\" [x, y, z], one of them");
    if (!rotation.empty()) {
      if (rotation.size() != 4 || !finite(rotation)) b.fail("rotation", "expected [x, y, z, w]");
      q = Eigen::Quaternionf(static_cast<float>(rotation[3]), static_cast<float>(rotation[0]),
                             static_cast<float>(rotation[1]), static_cast<float>(rotation[2]));
      if (!(q.norm() > 1e-6f)) b.fail("rotation", "is not a rotation (zero length)");
      q.normalize();
    } else {
      if (euler.size() != 3 || !finite(euler)) b.fail("euler_deg", "expected [x, y, z]");
      const auto axis = [&](int i, const Eigen::Vector3f& a) {
        return Eigen::AngleAxisf(
            static_cast<float>(euler[static_cast<std::size_t>(i)]) * kPi / 180.0f, a);
      };
      q = axis(2, Eigen::Vector3f::UnitZ()) * axis(1, Eigen::Vector3f::UnitY()) *
          axis(0, Eigen::Vector3f::UnitX());
    }
    pose.bones.push_back({bone, q});
  }
  c.reject_unknown();
  return pose;
}

Pose parse_pose(const std::string& value, const std::string& what) {
  if (value == "bind") return {Pose::Kind::kBind, {}, {}};
  if (value == "rest") return {Pose::Kind::kRest, {}, {}};
  if (value.ends_with(".json")) return read_pose_file(value);
  throw Error(what + ": unknown pose '" + value + "' (bind, rest or a pose file, FILE.json)",
              ErrorCode::kInvalidInput);
}

}  // namespace facecast::rig
