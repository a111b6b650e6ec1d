// The default avatar: parameters, variants and assembly of the Rig.
#include <algorithm>
#include <random>

#include "facecast/core/error.hpp"
#include "model.hpp"

namespace facecast::avatar {

namespace {
constexpr float kMin = 0.75f, kMax = 1.3f;
}

void AvatarParams::validate() const {
  const std::pair<const char*, float> fields[] = {{"face_width", face_width},
                                                  {"jaw_length", jaw_length},
                                                  {"lip_thickness", lip_thickness},
                                                  {"eye_size", eye_size},
                                                  {"nose_length", nose_length}};
  for (const auto& [name, value] : fields) {
    if (!(value >= kMin && value <= kMax)) {
      throw Error(std::string("avatar parameter ") + name + " = " + std::to_string(value) +
                  " is outside [0.75, 1.3]");
    }
  }
}

AvatarParams avatar_variant(std::uint64_t seed) {
  AvatarParams p;
  if (seed == 0) return p;
  // A fixed generator and a hand-rolled uniform mapping: identical on every platform.
  std::mt19937_64 rng(seed);
  const auto draw = [&rng](float lo, float hi) {
    const double u = static_cast<double>(rng() >> 11) * (1.0 / 9007199254740992.0);
    return static_cast<float>(lo + (hi - lo) * u);
  };
  p.face_width = draw(0.85f, 1.2f);
  p.jaw_length = draw(0.85f, 1.2f);
  p.lip_thickness = draw(0.8f, 1.3f);
  p.eye_size = draw(0.8f, 1.15f);
  p.nose_length = draw(0.8f, 1.25f);
  return p;
}

const std::vector<std::string>& avatar_shape_names() {
  static const std::vector<std::string> names{
      "eyeBlinkLeft",      "eyeLookDownLeft",    "eyeLookInLeft",
      "eyeLookOutLeft",    "eyeLookUpLeft",      "eyeSquintLeft",
      "eyeWideLeft",       "eyeBlinkRight",      "eyeLookDownRight",
      "eyeLookInRight",    "eyeLookOutRight",    "eyeLookUpRight",
      "eyeSquintRight",    "eyeWideRight",       "jawForward",
      "jawLeft",           "jawRight",           "jawOpen",
      "mouthClose",        "mouthFunnel",        "mouthPucker",
      "mouthLeft",         "mouthRight",         "mouthSmileLeft",
      "mouthSmileRight",   "mouthFrownLeft",     "mouthFrownRight",
      "mouthDimpleLeft",   "mouthDimpleRight",   "mouthStretchLeft",
      "mouthStretchRight", "mouthRollLower",     "mouthRollUpper",
      "mouthShrugLower",   "mouthShrugUpper",    "mouthPressLeft",
      "mouthPressRight",   "mouthLowerDownLeft", "mouthLowerDownRight",
      "mouthUpperUpLeft",  "mouthUpperUpRight",  "browDownLeft",
      "browDownRight",     "browInnerUp",        "browOuterUpLeft",
      "browOuterUpRight",  "cheekPuff",          "cheekSquintLeft",
      "cheekSquintRight",  "noseSneerLeft",      "noseSneerRight",
      "tongueOut"};
  return names;
}

rig::Rig make_avatar(const AvatarParams& params) {
  params.validate();
  detail::Model m = detail::build_geometry(params);
  std::vector<rig::Blendshape> shapes = detail::build_shapes(m);

  rig::Rig rig;
  rig.positions = m.pos;
  rig.triangles = m.tris;
  rig.normals = rig::vertex_normals(rig.positions, rig.triangles);
  rig.triangle_material = m.material;
  rig.materials = m.materials;
  rig.triangle_group = m.group;
  rig.groups = m.group_names;
  rig.landmarks = m.landmarks;
  rig.uvs = m.uvs;
  rig.textures = m.textures;
  rig.meshes = m.meshes;
  for (const auto& name : avatar_shape_names()) {
    auto it = std::find_if(shapes.begin(), shapes.end(),
                           [&](const rig::Blendshape& s) { return s.name == name; });
    if (it == shapes.end())
      throw Error("avatar: shape " + name + " was not generated", ErrorCode::kInternal);
    rig.shapes.push_back(std::move(*it));
  }
  rig.validate("default avatar");
  return rig;
}

const rig::Rig& default_avatar() {
  static const rig::Rig rig = make_avatar({});
  return rig;
}

}  // namespace facecast::avatar
