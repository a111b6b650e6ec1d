// Spring bones as VRM files store them (avatar_view_detail.hpp): VRMC_springBone's springs of
// joints and its sphere and capsule colliders, or VRM 0.x's bone groups (every node under each
// root a joint, a leaf's tail 7 cm on along its bone) and sphere colliders. Positions are taken
// at rest into the rig's axes, where a VRM 0.x figure was turned to face +Z: its gravity turns
// with it, and its collider offsets, written in Unity's axes, have z negated (as three-vrm and
// UniVRM read them).
#include <algorithm>
#include <cmath>
#include <string>

#include "avatar_view_detail.hpp"
#include "facecast/core/error.hpp"

namespace facecast::rig::detail {
namespace {

// What a file may ask to simulate: a frame steps every joint against its spring's colliders.
constexpr std::size_t kMaxJoints = 2048, kMaxColliders = 1024, kMaxCollidersPerSpring = 256,
                      kMaxVisits = 8 * kMaxJoints;

struct Reader {
  const tinygltf::Model& m;
  const NodeGraph& g;
  const std::map<int, int>& joint_of_node;
  std::string what;
  SpringBones out;
  std::size_t joints = 0;  // added so far

  bool is_node(const tinygltf::Value& v) const {
    return v.IsInt() && v.GetNumberAsInt() >= 0 &&
           static_cast<std::size_t>(v.GetNumberAsInt()) < m.nodes.size();
  }
  // The joint a node moves with: itself or the nearest joint above it; -1: none (fixed).
  int carrier(int node) const {
    for (std::size_t guard = 0; node >= 0 && guard <= m.nodes.size(); ++guard) {
      if (const auto it = joint_of_node.find(node); it != joint_of_node.end()) return it->second;
      node = g.parent[static_cast<std::size_t>(node)];
    }
    return -1;
  }
  Eigen::Vector3f at(int node, const Eigen::Vector3f& local) const {
    const Eigen::Matrix4f& w = g.world[static_cast<std::size_t>(node)];
    return w.topLeftCorner<3, 3>() * local + w.topRightCorner<3, 1>();
  }
  float scale(int node) const {
    return g.world[static_cast<std::size_t>(node)].topLeftCorner<3, 3>().colwise().norm().mean();
  }
  // Adds joint `j` of node `node` unless its tail is where it is (a rod of no length).
  void add_joint(SpringBones::Spring& spring, const SpringJoint& j, int node) {
    const Eigen::Vector3f origin = g.world[static_cast<std::size_t>(node)].topRightCorner<3, 1>();
    if (!j.tail.allFinite() || (j.tail - origin).norm() <= 1e-6f) return;
    if (++joints > kMaxJoints)
      throw Error(what + ": more than " + std::to_string(kMaxJoints) + " spring joints");
    spring.joints.push_back(j);
  }
  void add_collider(SpringCollider c) {
    if (out.colliders.size() >= kMaxColliders)
      throw Error(what + ": more than " + std::to_string(kMaxColliders) + " colliders");
    out.colliders.push_back(c);
  }
  // The colliders of the groups `groups` names (indices into `members`), each once.
  std::vector<int> colliders_of(const tinygltf::Value& groups,
                                const std::vector<std::vector<int>>& members) const {
    std::vector<int> list;
    for (std::size_t i = 0; groups.IsArray() && i < groups.ArrayLen(); ++i) {
      const auto& v = groups.Get(static_cast<int>(i));
      if (!v.IsInt() || v.GetNumberAsInt() < 0 ||
          static_cast<std::size_t>(v.GetNumberAsInt()) >= members.size())
        continue;
      for (const int c : members[static_cast<std::size_t>(v.GetNumberAsInt())])
        if (std::find(list.begin(), list.end(), c) == list.end()) list.push_back(c);
    }
    if (list.size() > kMaxCollidersPerSpring)
      throw Error(what + ": a spring with more than " + std::to_string(kMaxCollidersPerSpring) +
                  " colliders");
    return list;
  }
};

Eigen::Vector3f vec3_or(const tinygltf::Value& o, const char* key, Eigen::Vector3f fallback) {
  if (!o.IsObject() || !o.Has(key)) return fallback;
  const auto& v = o.Get(key);
  Eigen::Vector3f r = fallback;
  if (v.IsArray() && v.ArrayLen() == 3) {
    for (int k = 0; k < 3; ++k)
      if (v.Get(k).IsNumber())
        r[k] = static_cast<float>(std::clamp(v.Get(k).GetNumberAsDouble(), -1e4, 1e4));
  } else if (v.IsObject()) {  // VRM 0.x: {"x": .., "y": .., "z": ..}
    r = {number_or(v, "x", fallback.x()), number_or(v, "y", fallback.y()),
         number_or(v, "z", fallback.z())};
  }
  return r.allFinite() ? r : fallback;
}

Eigen::Vector3f direction_or_down(Eigen::Vector3f d) {
  return d.norm() > 1e-6f ? Eigen::Vector3f(d.normalized()) : Eigen::Vector3f(0, -1, 0);
}

// VRM 1.0: extensions.VRMC_springBone.
void read_vrm1(Reader& r, const tinygltf::Value& ext) {
  const auto& colliders = ext.Get("colliders");
  std::vector<int> collider_index;  // file's collider -> ours, -1: unusable
  for (std::size_t i = 0; colliders.IsArray() && i < colliders.ArrayLen(); ++i) {
    const auto& c = colliders.Get(static_cast<int>(i));
    const auto& shape = c.Get("shape");
    const bool capsule = shape.Has("capsule");
    const auto& s = capsule ? shape.Get("capsule") : shape.Get("sphere");
    if (!r.is_node(c.Get("node")) || !s.IsObject()) {
      collider_index.push_back(-1);
      continue;
    }
    const int node = c.Get("node").GetNumberAsInt();
    SpringCollider out;
    out.joint = r.carrier(node);
    out.capsule = capsule;
    out.offset = r.at(node, vec3_or(s, "offset", Eigen::Vector3f::Zero()));
    out.tail = capsule ? r.at(node, vec3_or(s, "tail", Eigen::Vector3f::Zero())) : out.offset;
    out.radius = std::max(0.0f, number_or(s, "radius", 0.0f)) * r.scale(node);
    collider_index.push_back(static_cast<int>(r.out.colliders.size()));
    r.add_collider(out);
  }
  std::vector<std::vector<int>> groups;
  const auto& cg = ext.Get("colliderGroups");
  for (std::size_t i = 0; cg.IsArray() && i < cg.ArrayLen(); ++i) {
    const auto& list = cg.Get(static_cast<int>(i)).Get("colliders");
    std::vector<int> members;
    for (std::size_t k = 0; list.IsArray() && k < list.ArrayLen(); ++k)
      if (const auto& v = list.Get(static_cast<int>(k));
          v.IsInt() && v.GetNumberAsInt() >= 0 &&
          static_cast<std::size_t>(v.GetNumberAsInt()) < collider_index.size() &&
          collider_index[static_cast<std::size_t>(v.GetNumberAsInt())] >= 0)
        members.push_back(collider_index[static_cast<std::size_t>(v.GetNumberAsInt())]);
    groups.push_back(std::move(members));
  }
  const auto& springs = ext.Get("springs");
  for (std::size_t i = 0; springs.IsArray() && i < springs.ArrayLen(); ++i) {
    const auto& s = springs.Get(static_cast<int>(i));
    const auto& joints = s.Get("joints");
    SpringBones::Spring spring;
    // Each joint but the last turns toward the next, with its own settings.
    for (std::size_t k = 0; joints.IsArray() && k + 1 < joints.ArrayLen(); ++k) {
      const auto& j = joints.Get(static_cast<int>(k));
      const auto& next = joints.Get(static_cast<int>(k + 1));
      if (!r.is_node(j.Get("node")) || !r.is_node(next.Get("node"))) continue;
      const auto it = r.joint_of_node.find(j.Get("node").GetNumberAsInt());
      if (it == r.joint_of_node.end()) continue;  // not a joint of the skin: moves nothing
      SpringJoint sj;
      sj.joint = it->second;
      sj.tail = r.at(next.Get("node").GetNumberAsInt(), Eigen::Vector3f::Zero());
      sj.hit_radius = std::max(0.0f, number_or(j, "hitRadius", 0.0f));
      sj.stiffness = std::max(0.0f, number_or(j, "stiffness", 1.0f));
      sj.gravity_power = std::max(0.0f, number_or(j, "gravityPower", 0.0f));
      sj.gravity_dir = direction_or_down(vec3_or(j, "gravityDir", {0, -1, 0}));
      sj.drag = std::clamp(number_or(j, "dragForce", 0.5f), 0.0f, 1.0f);
      r.add_joint(spring, sj, j.Get("node").GetNumberAsInt());
    }
    spring.colliders = r.colliders_of(s.Get("colliderGroups"), groups);
    if (!spring.joints.empty()) r.out.springs.push_back(std::move(spring));
  }
}

// VRM 0.x: extensions.VRM.secondaryAnimation.
void read_vrm0(Reader& r, const tinygltf::Value& ext) {
  std::vector<std::vector<int>> groups;
  const auto& cg = ext.Get("colliderGroups");
  for (std::size_t i = 0; cg.IsArray() && i < cg.ArrayLen(); ++i) {
    const auto& group = cg.Get(static_cast<int>(i));
    std::vector<int> members;
    const auto& list = group.Get("colliders");
    for (std::size_t k = 0; r.is_node(group.Get("node")) && list.IsArray() && k < list.ArrayLen();
         ++k) {
      const int node = group.Get("node").GetNumberAsInt();
      const auto& c = list.Get(static_cast<int>(k));
      Eigen::Vector3f offset = vec3_or(c, "offset", Eigen::Vector3f::Zero());
      offset.z() = -offset.z();
      SpringCollider out;
      out.joint = r.carrier(node);
      out.offset = out.tail = r.at(node, offset);
      out.radius = std::max(0.0f, number_or(c, "radius", 0.0f)) * r.scale(node);
      members.push_back(static_cast<int>(r.out.colliders.size()));
      r.add_collider(out);
    }
    groups.push_back(std::move(members));
  }
  const auto& bone_groups = ext.Get("boneGroups");
  std::size_t visits = 0;  // nodes walked under the roots (a file's nodes may form a cycle)
  for (std::size_t i = 0; bone_groups.IsArray() && i < bone_groups.ArrayLen(); ++i) {
    const auto& b = bone_groups.Get(static_cast<int>(i));
    SpringJoint settings;
    settings.hit_radius = std::max(0.0f, number_or(b, "hitRadius", 0.0f));
    settings.stiffness = std::max(0.0f, number_or(b, "stiffiness", 1.0f));
    settings.gravity_power = std::max(0.0f, number_or(b, "gravityPower", 0.0f));
    // Gravity in the file's world axes; the figure (and so the world) was turned half about +Y.
    const Eigen::Vector3f g = vec3_or(b, "gravityDir", {0, -1, 0});
    settings.gravity_dir = direction_or_down({-g.x(), g.y(), -g.z()});
    settings.drag = std::clamp(number_or(b, "dragForce", 0.4f), 0.0f, 1.0f);
    SpringBones::Spring spring;
    spring.colliders = r.colliders_of(b.Get("colliderGroups"), groups);
    const auto& roots = b.Get("bones");
    for (std::size_t k = 0; roots.IsArray() && k < roots.ArrayLen(); ++k) {
      if (!r.is_node(roots.Get(static_cast<int>(k)))) continue;
      // Every node under the root, depth first; each turns toward its first child, a leaf
      // toward a point 7 cm on along its bone.
      std::vector<int> stack{roots.Get(static_cast<int>(k)).GetNumberAsInt()};
      while (!stack.empty()) {
        const int node = stack.back();
        stack.pop_back();
        if (++visits > kMaxVisits)
          throw Error(r.what + ": more than " + std::to_string(kMaxVisits) + " bone nodes");
        const auto& n = r.m.nodes[static_cast<std::size_t>(node)];
        for (auto c = n.children.rbegin(); c != n.children.rend(); ++c)
          if (*c >= 0 && static_cast<std::size_t>(*c) < r.m.nodes.size()) stack.push_back(*c);
        const auto it = r.joint_of_node.find(node);
        if (it == r.joint_of_node.end()) continue;
        SpringJoint sj = settings;
        sj.joint = it->second;
        if (!n.children.empty() && n.children[0] >= 0 &&
            static_cast<std::size_t>(n.children[0]) < r.m.nodes.size()) {
          sj.tail = r.at(n.children[0], Eigen::Vector3f::Zero());
        } else {
          Eigen::Vector3f t = Eigen::Vector3f::Zero();
          if (n.translation.size() == 3)
            t = {static_cast<float>(n.translation[0]), static_cast<float>(n.translation[1]),
                 static_cast<float>(n.translation[2])};
          else if (n.matrix.size() == 16)
            t = {static_cast<float>(n.matrix[12]), static_cast<float>(n.matrix[13]),
                 static_cast<float>(n.matrix[14])};
          if (t.norm() < 1e-9f || !t.allFinite()) continue;
          sj.tail = r.at(node, 0.07f * t.normalized());
        }
        r.add_joint(spring, sj, node);
      }
    }
    if (!spring.joints.empty()) r.out.springs.push_back(std::move(spring));
  }
}

}  // namespace

SpringBones read_springs(const tinygltf::Model& m, const NodeGraph& g,
                         const std::map<int, int>& joint_of_node) {
  Reader r{m, g, joint_of_node, "", {}};
  if (const auto it = m.extensions.find("VRMC_springBone");
      it != m.extensions.end() && it->second.IsObject()) {
    r.what = "VRMC_springBone";
    read_vrm1(r, it->second);
  } else if (const auto v0 = m.extensions.find("VRM"); v0 != m.extensions.end() &&
                                                       v0->second.IsObject() &&
                                                       v0->second.Has("secondaryAnimation")) {
    r.what = "VRM secondaryAnimation";
    read_vrm0(r, v0->second.Get("secondaryAnimation"));
  }
  return std::move(r.out);
}

}  // namespace facecast::rig::detail
