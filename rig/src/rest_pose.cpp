// The rest pose (see rest_pose.hpp): the upper arms found by VRM humanoid bone or by name
// (configs/rig/humanoid.json), turned down about their joints, the rig re-skinned on the CPU.
#include "facecast/rig/rest_pose.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>

#include "facecast/core/config.hpp"
#include "facecast/core/config_reader.hpp"
#include "facecast/core/error.hpp"

namespace facecast::rig {
namespace {

constexpr float kPi = 3.14159265f;

struct HumanoidTable {
  std::vector<std::string> prefixes, left, right;
  float arm_angle_deg = 10, min_turn_deg = 15;
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
        .reject_unknown();
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

// The turn that brings the upper arm `arm` down, or none (identity, angle 0) when it has no child
// joint or hangs down already.
std::pair<Eigen::Quaternionf, float> arm_turn(const Skeleton& s, int arm) {
  const auto origin = [&](int j) { return s.rest_origin[static_cast<std::size_t>(j)]; };
  int farthest = -1;
  float best = 0;
  for (std::size_t j = 0; j < s.parent.size(); ++j)
    if (s.parent[j] == arm) {
      const float d = (origin(static_cast<int>(j)) - origin(arm)).norm();
      if (d > best) best = d, farthest = static_cast<int>(j);
    }
  if (farthest < 0 || best <= 0) return {Eigen::Quaternionf::Identity(), 0.0f};
  const Eigen::Vector3f d = (origin(farthest) - origin(arm)).normalized();
  const float a = table().arm_angle_deg * kPi / 180.0f;
  const Eigen::Vector3f down(d.x() >= 0 ? std::sin(a) : -std::sin(a), -std::cos(a), 0.0f);
  const float angle = std::acos(std::clamp(d.dot(down), -1.0f, 1.0f)) * 180.0f / kPi;
  if (angle < table().min_turn_deg) return {Eigen::Quaternionf::Identity(), 0.0f};
  return {Eigen::Quaternionf::FromTwoVectors(d, down), angle};
}

}  // namespace

RestPoseReport apply_rest_pose(Rig& rig) {
  RestPoseReport report;
  Skeleton& s = rig.skeleton;
  const std::size_t nj = s.joint_names.size();
  if (nj == 0 || s.parent.size() != nj || s.rest_origin.size() != nj ||
      rig.joints.rows() != rig.vertex_count())
    return report;
  const int left = s.left_upper_arm >= 0 ? s.left_upper_arm : find_by_name(s, table().left);
  const int right = s.right_upper_arm >= 0 ? s.right_upper_arm : find_by_name(s, table().right);

  // Each joint's local turn about its own origin, then the composed motion D_j = D_parent * L_j.
  std::vector<Eigen::Affine3f> local(nj, Eigen::Affine3f::Identity());
  for (const int arm : {left, right}) {
    if (arm < 0 || static_cast<std::size_t>(arm) >= nj) continue;
    const auto [turn, angle] = arm_turn(s, arm);
    if (angle == 0.0f) continue;
    const Eigen::Vector3f o = s.rest_origin[static_cast<std::size_t>(arm)];
    local[static_cast<std::size_t>(arm)] =
        Eigen::Translation3f(o) * turn * Eigen::Translation3f(-o);
    report.turned.emplace_back(s.joint_names[static_cast<std::size_t>(arm)], angle);
  }
  if (report.turned.empty()) return report;
  std::vector<Eigen::Affine3f> motion(nj);
  std::vector<char> moved(nj, 0), done(nj, 0);
  for (std::size_t j = 0; j < nj; ++j) {
    // The chain up to a joint already composed (or a root), then down it.
    std::vector<std::size_t> chain{j};
    while (!done[chain.back()] && s.parent[chain.back()] >= 0 && chain.size() <= nj)
      chain.push_back(static_cast<std::size_t>(s.parent[chain.back()]));
    if (chain.size() > nj) throw Error("rest pose: the skeleton's parents form a cycle");
    for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
      if (done[*it]) continue;
      const int p = s.parent[*it];
      const bool from_parent = p >= 0 && moved[static_cast<std::size_t>(p)];
      motion[*it] = from_parent ? motion[static_cast<std::size_t>(p)] * local[*it] : local[*it];
      moved[*it] = from_parent || !local[*it].matrix().isIdentity();
      done[*it] = 1;
    }
  }

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
  return report;
}

Pose parse_pose(const std::string& name, const std::string& what) {
  if (name == "bind") return Pose::kBind;
  if (name == "rest") return Pose::kRest;
  throw Error(what + ": unknown pose '" + name + "' (bind or rest)", ErrorCode::kInvalidInput);
}

}  // namespace facecast::rig
