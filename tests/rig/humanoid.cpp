// A humanoid made in code (see humanoid.hpp).
#include "humanoid.hpp"

#include <algorithm>
#include <cmath>
#include <tuple>

namespace facecast::test {

using namespace facecast::rig;

namespace {

// Appends a box from lo to hi, each vertex skinned by `skin(position)` -> (joint a, joint b, t):
// weight 1 - t on a, t on b.
template <class Skin>
void add_box(Rig& rig, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, Skin skin) {
  const auto base = static_cast<int>(rig.positions.rows());
  rig.positions.conservativeResize(base + 8, 3);
  rig.joints.conservativeResize(base + 8, 4);
  rig.joint_weights.conservativeResize(base + 8, 4);
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3f p((i & 1 ? hi : lo).x(), (i & 2 ? hi : lo).y(), (i & 4 ? hi : lo).z());
    rig.positions.row(base + i) = p.transpose();
    const auto [a, b, t] = skin(p);
    rig.joints.row(base + i) << a, b, 0, 0;
    rig.joint_weights.row(base + i) << 1 - t, t, 0, 0;
  }
  const auto tri = static_cast<int>(rig.triangles.rows());
  rig.triangles.conservativeResize(tri + 12, 3);
  const int t[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                        {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  for (int f = 0; f < 12; ++f)
    for (int c = 0; c < 3; ++c) rig.triangles(tri + f, c) = base + t[f][c];
}

}  // namespace

Rig humanoid(float droop, const char* left, const char* right) {
  Rig rig;
  rig.positions.resize(0, 3);
  rig.triangles.resize(0, 3);
  rig.joints.resize(0, 4);
  rig.joint_weights.resize(0, 4);
  Skeleton& s = rig.skeleton;
  s.joint_names = {"mixamorig:Hips",
                   left,
                   "mixamorig:LeftForeArm",
                   "mixamorig:LeftHand",
                   right,
                   "mixamorig:RightForeArm",
                   "mixamorig:RightHand",
                   "mixamorig:Neck",
                   "mixamorig:Head",
                   "mixamorig:Spine",
                   "mixamorig:Spine2",
                   "mixamorig:LeftShoulder",
                   "mixamorig:RightShoulder",
                   "mixamorig:LeftUpLeg",
                   "mixamorig:LeftLeg",
                   "mixamorig:RightUpLeg",
                   "mixamorig:RightLeg"};
  s.parent = {-1, 11, 1, 2, 12, 4, 5, 10, 7, 0, 9, 10, 10, 0, 13, 0, 15};
  const float c = std::cos(droop * kDeg), sn = std::sin(droop * kDeg);
  const auto along = [&](float side, float d) {
    return Eigen::Vector3f(side * (0.2f + d * c), 1.45f - d * sn, 0.0f);
  };
  s.rest_origin = {{0, 1, 0},          along(1, 0),      along(1, 0.3f),   along(1, 0.55f),
                   along(-1, 0),       along(-1, 0.3f),  along(-1, 0.55f), {0, 1.5f, 0},
                   {0, 1.6f, 0},       {0, 1.15f, 0},    {0, 1.35f, 0},    {0.08f, 1.45f, 0},
                   {-0.08f, 1.45f, 0}, {0.1f, 0.95f, 0}, {0.1f, 0.5f, 0},  {-0.1f, 0.95f, 0},
                   {-0.1f, 0.5f, 0}};
  s.neck = 7;
  s.head = 8;
  // The torso: its top on the chest, its bottom on the hips.
  add_box(rig, {-0.2f, 0.5f, -0.1f}, {0.2f, 1.5f, 0.1f}, [](const Eigen::Vector3f& p) {
    return p.y() > 1.0f ? std::tuple{10, 10, 0.0f} : std::tuple{0, 0, 0.0f};
  });
  add_box(rig, {-0.1f, 1.55f, -0.1f}, {0.1f, 1.75f, 0.1f}, [](const Eigen::Vector3f&) {
    return std::tuple{8, 8, 0.0f};
  });
  for (const float side : {1.0f, -1.0f}) {
    const int arm = side > 0 ? 1 : 4;
    // The arm as a box in T-pose, bent down by the droop about the shoulder.
    const Eigen::Vector3f shoulder = along(side, 0);
    const auto first = static_cast<int>(rig.positions.rows());
    add_box(rig, {0.0f, -0.04f, -0.04f}, {0.6f, 0.04f, 0.04f}, [&](const Eigen::Vector3f& p) {
      return p.x() < 0.3f ? std::tuple{arm, arm, 0.0f} : std::tuple{arm + 1, arm + 1, 0.0f};
    });
    for (int v = first; v < first + 8; ++v) {
      const Eigen::Vector3f p = rig.positions.row(v).transpose();
      rig.positions.row(v) = (shoulder + Eigen::Vector3f(side * (p.x() * c + p.y() * sn),
                                                         p.y() * c - p.x() * sn, p.z()))
                                 .transpose();
    }
  }
  rig.normals = vertex_normals(rig.positions, rig.triangles);
  rig.materials = {Material::solid("skin")};
  rig.triangle_material.assign(static_cast<std::size_t>(rig.triangles.rows()), 0);
  Positions jaw = Positions::Zero(rig.positions.rows(), 3);
  for (int v = 8; v < 16; ++v) jaw(v, 1) = -0.02f;
  rig.shapes.push_back(Blendshape::from_dense("jawOpen", jaw));
  rig.validate("humanoid");
  return rig;
}

void add_ponytail(Rig& rig, bool front) {
  Skeleton& s = rig.skeleton;
  const int first = static_cast<int>(s.joint_names.size());
  const float z = front ? -1.0f : 1.0f;  // behind the head, or in front of the face
  s.joint_names.insert(s.joint_names.end(), {"Hair1", "Hair2", "Hair3"});
  s.parent.insert(s.parent.end(), {s.head, first, first + 1});
  s.rest_origin.insert(s.rest_origin.end(),
                       {{0, 1.7f, -0.12f * z}, {0, 1.5f, -0.14f * z}, {0, 1.3f, -0.16f * z}});
  add_box(rig, {-0.03f, 1.3f, std::min(-0.17f * z, -0.11f * z)},
          {0.03f, 1.7f, std::max(-0.17f * z, -0.11f * z)}, [&](const Eigen::Vector3f& p) {
            return p.y() > 1.6f ? std::tuple{first, first, 0.0f}
                                : std::tuple{first + 1, first + 1, 0.0f};
          });
  rig.normals = vertex_normals(rig.positions, rig.triangles);
  rig.triangle_material.resize(static_cast<std::size_t>(rig.triangles.rows()), 0);
  SpringBones& sb = s.springs;
  sb = {};
  sb.colliders.push_back({s.head, {0, 1.65f, 0}, {0, 1.65f, 0}, 0.1f, false});
  SpringBones::Spring spring;
  for (int k = 0; k < 2; ++k) {
    SpringJoint j;
    j.joint = first + k;
    j.tail = s.rest_origin[static_cast<std::size_t>(first + k + 1)];
    j.drag = 0.4f;
    spring.joints.push_back(j);
  }
  spring.colliders = {0};
  sb.springs.push_back(spring);
  rig.validate("humanoid with a ponytail");
}

}  // namespace facecast::test
