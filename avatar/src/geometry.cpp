// The default avatar's neutral geometry: the head on which every part is placed, and the assembly
// of the parts (skin, teeth and tongue, eyeballs and lids; see generator.hpp) into a Model.
// See avatar.hpp for the overview.
#include <algorithm>
#include <cmath>
#include <numeric>

#include "generator.hpp"

namespace facecast::avatar::detail {

float Generator::lower_y(float y) const {  // scales heights below the nose with jaw_length
  constexpr float y_nose = -1.6f;
  return y < y_nose ? y_nose + (y - y_nose) * prm.jaw_length : y;
}

void Generator::setup_head() {
  shape_head();
  place_mouth();
  place_eyes();
}

// The head's signed-distance model: ellipsoids, then the nose and ears placed on their surface.
void Generator::shape_head() {
  const float fw = prm.face_width;
  head.cran_c = V3(0, 1.4f, -0.8f);
  head.cran_r = V3(7.3f * fw, 8.5f, 9.2f);
  head.jaw_c = V3(0, lower_y(-4.0f), 1.6f);
  head.jaw_r = V3(5.5f * fw, 4.6f * prm.jaw_length, 6.5f);
  head.chin_c = V3(0, lower_y(-7.8f), 5.3f);
  head.chin_r = V3(2.7f * fw, 1.7f * prm.jaw_length, 2.3f);
  head.muzzle_c = V3(0, lower_y(-4.5f), 5.9f);
  head.muzzle_r = V3(3.4f * fw, 2.6f * prm.jaw_length, 2.9f);
  for (int s = 0; s < 2; ++s) head.cheek_c[s] = V3((s ? -3.9f : 3.9f) * fw, -1.9f, 4.7f);
  head.cheek_r = V3(2.6f * fw, 2.3f, 2.5f);
  head.brow_c = V3(0, 3.5f, 5.6f);
  head.brow_r = V3(5.4f * fw, 1.3f, 2.4f);
  for (int s = 0; s < 2; ++s) head.orbit_c[s] = V3((s ? -3.3f : 3.3f) * fw, 1.4f, 5.6f);
  head.orbit_r = V3(2.5f * fw, 2.0f, 1.9f);
  head.features = false;

  // Nose, placed on the base surface.
  const float nl = prm.nose_length;
  const V3 root_s = head.raycast(V3(0, 1.5f, 0), V3(0, 0, 1));
  head.root = root_s - V3(0, 0, 0.35f);
  head.root_r = 0.5f;
  const float tip_y = 1.5f - 2.9f * nl;
  const V3 tip_s = head.raycast(V3(0, tip_y, 0), V3(0, 0, 1));
  head.tip = tip_s + V3(0, 0, 1.45f * nl);
  head.tip_r = 0.8f;
  for (int s = 0; s < 2; ++s) head.ala_c[s] = head.tip + V3(s ? -0.85f : 0.85f, -0.25f, -0.95f);
  head.ala_r = 0.6f;
  for (int s = 0; s < 2; ++s) {
    const float sx = s ? -1.0f : 1.0f;
    head.ear_c[s] = V3(sx * 7.25f * fw, -0.3f, -0.9f);
    head.concha_c[s] = V3(sx * (7.25f * fw + 1.05f), -0.1f, -0.7f);
  }
  head.ear_r = V3(1.0f, 2.6f, 1.7f);
  head.concha_r = V3(0.55f, 1.5f, 0.95f);
  head.features = true;
  f.nose_tip = head.tip + V3(0, 0, head.tip_r * 1.08f);

  // Nostrils: the nose's underside below each ala.
  nostril_axis = V3(0, 1.0f, -0.45f).normalized();
  for (int s = 0; s < 2; ++s) {
    const V3 start = head.tip + V3(s ? -0.48f : 0.48f, -0.1f, -0.55f);
    nostril_c[s] = head.raycast(start, -nostril_axis);
  }
}

// The mouth's frame: the lip line's centre on the head, the ray origin behind it; the sizes of the
// lips and the cavity; the jaw hinge.
void Generator::place_mouth() {
  const float mouth_height = lower_y(-4.5f);
  f.mouth = head.raycast(V3(0, mouth_height, 0), V3(0, 0, 1));
  ray_origin = V3(0, -1.2f, -0.6f);
  mouth_axis = (f.mouth - ray_origin).normalized();
  f.lip_dir = (mouth_axis + V3(0, 0, 0.6f)).normalized();
  mouth_x = V3(1, 0, 0);
  mouth_y = mouth_axis.cross(mouth_x).normalized();
  proj_f = (f.mouth - ray_origin).norm();
  mouth_c = 2.2f * prm.face_width;
  f.mouth_half_width = mouth_c;
  f.lip_bulge_upper = 0.42f * prm.lip_thickness;
  f.lip_bulge_lower = 0.5f * prm.lip_thickness;
  vermilion_upper = std::asinh(0.72f / mouth_c);
  vermilion_lower = std::asinh(0.85f / mouth_c);
  f.lip_depth = 0.9f;
  cavity_w = 2.8f * prm.face_width;
  cavity_h = 2.1f * std::min(1.0f, prm.jaw_length);
  cavity_y = -0.5f;
  cavity_d = 6.0f;
  f.jaw_hinge = V3(0, -1.6f, 0.3f);
}

// The eyes' frames (the eyeball's front just in front of the head's surface; lid radii and
// margins), the brows' and cheeks' centres.
void Generator::place_eyes() {
  const float fw = prm.face_width;
  f.eye_radius = 1.45f * prm.eye_size;
  const float R = f.eye_radius;
  for (int s = 0; s < 2; ++s) {
    const float x = (s ? -3.25f : 3.25f) * fw;
    const V3 front = head.raycast(V3(x, 1.5f, 0), V3(0, 0, 1));
    f.eye_center[s] = front + V3(0, 0, 0.2f - R);
    eye_axis[s] = V3(0, 0, 1);
  }
  f.lid_lower_in = R + 0.11f;
  f.lid_lower_out = R + 0.17f;
  f.lid_upper_in = R + 0.22f;
  f.lid_upper_out = R + 0.30f;
  f.socket_radius = R + 0.48f;
  f.upper_margin = deg(25);
  f.lower_margin = deg(20);
  f.corner_angle = deg(44);
  for (int s = 0; s < 2; ++s) {
    const float sx = s ? -1.0f : 1.0f;
    f.brow[s] = V3(f.eye_center[s].x() + sx * 0.25f, f.eye_center[s].y() + R + 1.0f, 0);
    f.brow[s] = head.raycast(V3(f.brow[s].x(), f.brow[s].y(), 0), V3(0, 0, 1));
    f.cheek[s] = head.raycast(V3(sx * 3.4f * fw, lower_y(-2.2f), 0), V3(0, 0, 1));
  }
}

Eigen::Vector3f polyline_at(const std::vector<Eigen::Vector3f>& line, float t) {
  double total = 0;
  for (std::size_t i = 1; i < line.size(); ++i) total += (line[i] - line[i - 1]).norm();
  double want = std::clamp(t, 0.0f, 1.0f) * total;
  for (std::size_t i = 1; i < line.size(); ++i) {
    const double len = (line[i] - line[i - 1]).norm();
    if (want <= len || i + 1 == line.size()) {
      const float u = len > 0 ? static_cast<float>(std::min(want / len, 1.0)) : 0.0f;
      return line[i - 1] + u * (line[i] - line[i - 1]);
    }
    want -= len;
  }
  return line.back();
}

// The vertices reordered so that each of the avatar's meshes (as real avatars split theirs: the
// head with lids and lashes, teeth, tongue, each eye) is one consecutive range; the GLB writes one
// glTF mesh per range and the file keeps the rig's vertex order.
void split_meshes(Model& m) {
  const auto mesh_of = [](const VertexInfo& i) {
    switch (i.part) {
      case Part::kTeethUpper:
      case Part::kTeethLower:
        return 1;
      case Part::kTongue:
        return 2;
      case Part::kEyeball:
        return 3 + i.side;
      default:
        return 0;  // skin and lids
    }
  };
  const auto nv = static_cast<int>(m.pos.rows());
  std::vector<int> order(static_cast<std::size_t>(nv));  // new -> old
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return mesh_of(m.info[static_cast<std::size_t>(a)]) <
           mesh_of(m.info[static_cast<std::size_t>(b)]);
  });
  std::vector<int> index(static_cast<std::size_t>(nv));  // old -> new
  for (int v = 0; v < nv; ++v)
    index[static_cast<std::size_t>(order[static_cast<std::size_t>(v)])] = v;
  const rig::Positions pos = m.pos;
  const rig::UVs uvs = m.uvs;
  const std::vector<VertexInfo> info = m.info;
  for (int v = 0; v < nv; ++v) {
    const int old = order[static_cast<std::size_t>(v)];
    m.pos.row(v) = pos.row(old);
    if (uvs.rows()) m.uvs.row(v) = uvs.row(old);
    m.info[static_cast<std::size_t>(v)] = info[static_cast<std::size_t>(old)];
  }
  for (Eigen::Index t = 0; t < m.tris.rows(); ++t)
    for (int c = 0; c < 3; ++c) m.tris(t, c) = index[static_cast<std::size_t>(m.tris(t, c))];
  for (rig::Landmark& l : m.landmarks) l.vertex = index[static_cast<std::size_t>(l.vertex)];
  const char* names[] = {"Head", "Teeth", "Tongue", "EyeLeft", "EyeRight"};
  for (int v = 0; v < nv; ++v) {
    const int k = mesh_of(m.info[static_cast<std::size_t>(v)]);
    if (m.meshes.empty() || m.meshes.back().name != names[k]) m.meshes.push_back({names[k], v, 0});
    ++m.meshes.back().vertex_count;
  }
}

Model build_geometry(const AvatarParams& params) {
  Generator g(params);
  g.setup_head();
  g.build_skin();
  g.build_teeth(true);
  g.build_teeth(false);
  g.build_tongue();
  for (int s = 0; s < 2; ++s) {
    g.build_eyeball(s);
    g.build_lid(s, false);
    g.build_lid(s, true);
  }

  Model m;
  m.params = params;
  m.f = g.f;
  const auto& b = g.b;
  m.pos.resize(static_cast<Eigen::Index>(b.pos.size()), 3);
  for (std::size_t v = 0; v < b.pos.size(); ++v)
    m.pos.row(static_cast<Eigen::Index>(v)) = b.pos[v].transpose();
  m.info = b.info;
  m.tris.resize(static_cast<Eigen::Index>(b.tris.size()), 3);
  for (std::size_t t = 0; t < b.tris.size(); ++t)
    m.tris.row(static_cast<Eigen::Index>(t)) = b.tris[t].transpose();
  m.material = b.mat;
  m.group = b.group;
  m.group_names = {"skin",           "lip_upper",      "lip_lower",       "teeth_upper",
                   "teeth_lower",    "tongue",         "eyeball_left",    "eyeball_right",
                   "lid_upper_left", "lid_lower_left", "lid_upper_right", "lid_lower_right"};
  const auto srgb = [](float r, float gg, float bb) {
    const auto lin = [](float c) { return rig::srgb_to_linear(c / 255.0f); };
    return Eigen::Vector4f(lin(r), lin(gg), lin(bb), 1.0f);
  };
  for (const auto& [name, colour] : std::initializer_list<std::pair<const char*, Eigen::Vector4f>>{
           {"M_Skin", srgb(236, 188, 158)},
           {"M_Lips", srgb(204, 104, 104)},
           {"M_MouthInterior", srgb(74, 18, 24)},
           {"M_Teeth", srgb(246, 242, 230)},
           {"M_Tongue", srgb(214, 102, 108)},
           {"M_Sclera", srgb(248, 248, 244)},
           {"M_Iris", srgb(66, 128, 150)},
           {"M_Pupil", srgb(8, 8, 10)},
           {"M_Lashes", srgb(44, 30, 26)},
       })
    m.materials.push_back(rig::Material::solid(name, colour));
  // Landmarks found by position.
  int nose = -1, chin = -1;
  for (Eigen::Index v = 0; v < m.pos.rows(); ++v) {
    if (m.info[v].part != Part::kSkin || m.info[v].inner) continue;
    if (nose < 0 || m.pos(v, 2) > m.pos(nose, 2)) nose = static_cast<int>(v);
    if (std::abs(m.pos(v, 0)) < 0.3f && m.pos(v, 2) > 3.0f &&
        (chin < 0 || m.pos(v, 1) < m.pos(chin, 1)))
      chin = static_cast<int>(v);
  }
  m.landmarks = g.landmarks;
  m.landmarks.push_back({"nose_tip", nose});
  m.landmarks.push_back({"chin", chin});
  g.paint_textures(m);
  split_meshes(m);
  return m;
}

}  // namespace facecast::avatar::detail
