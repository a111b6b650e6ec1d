#pragma once
// Private: the default avatar's geometry with the per-vertex information its blendshapes need.
#include <Eigen/Geometry>
#include <algorithm>
#include <cstdint>
#include <numbers>
#include <string>
#include <vector>

#include "facecast/avatar/avatar.hpp"

namespace facecast::avatar::detail {

using V3 = Eigen::Vector3f;
constexpr float kPi = std::numbers::pi_v<float>;
constexpr float deg(float d) {
  return d * kPi / 180.0f;
}

enum class Part : std::uint8_t {
  kSkin,
  kTeethUpper,
  kTeethLower,
  kTongue,
  kEyeball,
  kLidUpper,
  kLidLower,
};

struct VertexInfo {
  Part part = Part::kSkin;
  int side = 0;        // eyes and lids: 0 = left (+x), 1 = right (-x)
  bool inner = false;  // skin inside the lip line (inner lips and mouth cavity)
  float nu = 0;        // skin: angle around the mouth (0 = left corner, pi/2 = upper lip centre)
  float mu = 0;        // skin outside: elliptic ring coordinate (0 on the lip line)
  float s = 0;         // skin inside: 0 at the lip line .. 1 at the back of the cavity
  float lip_u = 0;     // skin outside: mu / vermilion extent (< 1 on the red of the lips)
  float bulge = 0;     // skin outside: how far the lips were pushed out along Frames::lip_dir
  float a = 0, e = 0;  // lids: lateral angle and elevation (radians) in the eye frame
  float along = 0;     // tongue: 0 at the root .. 1 at the tip
  Eigen::Vector2f cross{0, 0};      // tongue: cross-section offset (x, y) from its centre line
  float eye_mask = 1;               // skin: 0 in the eye sockets, 1 away from them
  float jaw = 0;                    // skin: jaw rotation weight
  float inner_att = 1;              // skin: mouth-field attenuation into the cavity (1 outside)
  Eigen::Vector3f anchor{0, 0, 0};  // skin: where mouth fields are evaluated (inner: the lip line)
};

/// Frames and sizes shared by geometry and shapes (world coordinates, centimetres).
struct Frames {
  Eigen::Vector3f mouth{0, 0, 0};  // centre of the lip line
  float mouth_half_width = 0;
  float lip_bulge_upper = 0, lip_bulge_lower = 0;
  float lip_depth = 0;               // front-to-back length of the inner lips
  Eigen::Vector3f lip_dir{0, 0, 1};  // direction of the lip bulge
  Eigen::Vector3f jaw_hinge{0, 0, 0};
  Eigen::Vector3f eye_center[2];
  float eye_radius = 0;
  float lid_lower_in = 0, lid_lower_out = 0, lid_upper_in = 0, lid_upper_out = 0;
  float socket_radius = 0;
  float upper_margin = 0, lower_margin = 0, corner_angle = 0;  // radians
  Eigen::Vector3f brow[2];                                     // centre of each brow
  Eigen::Vector3f cheek[2];
  Eigen::Vector3f nose_tip{0, 0, 0};
  // Tongue centre line (neutral) in world coordinates, root to tip, and its tongue-out form
  // relative to the jaw (before the jaw rotation of tongueOut).
  std::vector<Eigen::Vector3f> tongue_line, tongue_out_line;
};

struct Model {
  AvatarParams params;
  Frames f;
  rig::Positions pos;
  std::vector<VertexInfo> info;
  rig::Triangles tris;
  std::vector<int> material;
  std::vector<int> group;
  std::vector<std::string> group_names;
  std::vector<rig::Material> materials;
  std::vector<rig::Landmark> landmarks;
  rig::UVs uvs;                        // skin, lids and eyeballs (textures.cpp); 0 elsewhere
  std::vector<rig::Texture> textures;  // the skin's and the irises'
  std::vector<rig::MeshRange>
      meshes;  // Head (skin, lids, lashes), Teeth, Tongue, EyeLeft, EyeRight
};

Model build_geometry(const AvatarParams& params);
std::vector<rig::Blendshape> build_shapes(const Model& model);

// Small shared helpers.
inline float smoothstep(float e0, float e1, float x) {
  const float t = std::clamp((x - e0) / (e1 - e0), 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);
}
inline Eigen::Vector3f rotate_about(const Eigen::Vector3f& p, const Eigen::Vector3f& pivot,
                                    const Eigen::Vector3f& axis, float angle) {
  return pivot + Eigen::AngleAxisf(angle, axis) * (p - pivot);
}
/// Point on a polyline at arc-length fraction t in [0, 1].
Eigen::Vector3f polyline_at(const std::vector<Eigen::Vector3f>& line, float t);
/// Elevation (radians, in the eye frame) of a lid's margin at the lateral angle `a` in the neutral:
/// upper_margin / -lower_margin at the centre, the lids overlapping by 4 degrees at the corners
/// (a = +-corner_angle).
float margin_elevation(const Frames& f, bool upper, float a);

}  // namespace facecast::avatar::detail
