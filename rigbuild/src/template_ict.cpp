// The ICT FaceKit as the shipped template (template.hpp, docs/algorithms.md#shipped-template):
// parts kept, ARKit names, baked visemes, landmarks, materials.
#include <algorithm>
#include <array>
#include <map>

#include "facecast/avatar/avatar.hpp"
#include "facecast/core/config.hpp"
#include "facecast/core/error.hpp"
#include "facecast/rig/rig_io.hpp"
#include "facecast/rigbuild/landmarks.hpp"
#include "facecast/rigbuild/template.hpp"

namespace facecast::rigbuild {
namespace {

// The FaceKit's vertex ranges (FaceXModel's SOURCE.md): lacrimal fluid 24591-24998, eye blend
// 24999-25046 and eye occlusion 25047-25350 are transparent layers over the eyes that a renderer
// without their shaders draws as grey films; they move with the lids only. Everything else (face,
// head and neck, mouth socket, eye sockets, gums and tongue, teeth, eyeballs, lashes) is kept.
constexpr int kDropFirst = 24591, kDropEnd = 25351;

// ARKit's 52 names are the built-in avatar's shapes (tongueOut: the FaceKit has none).
bool is_arkit(const std::string& name) {
  const auto& arkit = avatar::avatar_shape_names();
  return std::find(arkit.begin(), arkit.end(), name) != arkit.end();
}

// The 15 Oculus visemes in their usual order.
constexpr std::array<const char*, 15> kOculus = {"sil", "PP", "FF", "TH", "DD", "kk", "CH", "SS",
                                                 "nn",  "RR", "aa", "E",  "I",  "O",  "U"};

// Materials by the FaceKit's .mtl names: linear base colour, roughness, double-sided.
struct Look {
  const char* name;
  Eigen::Vector4f color;
  float roughness;
  bool double_sided;
};
const std::array<Look, 9> kLooks = {{
    {"M_Face", {0.62f, 0.38f, 0.29f, 1.0f}, 0.55f, false},
    {"M_BackHead", {0.62f, 0.38f, 0.29f, 1.0f}, 0.6f, false},
    {"M_GumsTongue", {0.50f, 0.14f, 0.14f, 1.0f}, 0.35f, false},
    {"M_Teeth", {0.80f, 0.76f, 0.66f, 1.0f}, 0.3f, false},
    {"M_ScleraLeft", {0.80f, 0.78f, 0.75f, 1.0f}, 0.15f, false},
    {"M_ScleraRight", {0.80f, 0.78f, 0.75f, 1.0f}, 0.15f, false},
    {"M_IrisLeft", {0.10f, 0.06f, 0.035f, 1.0f}, 0.15f, false},
    {"M_IrisRight", {0.10f, 0.06f, 0.035f, 1.0f}, 0.15f, false},
    {"M_EyeLashes", {0.02f, 0.015f, 0.01f, 1.0f}, 0.8f, true},
}};

// The rig without the vertices outside `keep` (and the triangles on them); shapes, landmarks and
// materials that nothing uses any more follow.
rig::Rig keep_vertices(const rig::Rig& in, const std::vector<bool>& keep) {
  std::vector<int> to(static_cast<std::size_t>(in.vertex_count()), -1);
  int n = 0;
  for (int v = 0; v < in.vertex_count(); ++v)
    if (keep[static_cast<std::size_t>(v)]) to[static_cast<std::size_t>(v)] = n++;
  rig::Rig out;
  out.positions.resize(n, 3);
  out.normals.resize(n, 3);
  if (in.uvs.rows()) out.uvs.resize(n, 2);
  for (int v = 0; v < in.vertex_count(); ++v) {
    const int w = to[static_cast<std::size_t>(v)];
    if (w < 0) continue;
    out.positions.row(w) = in.positions.row(v);
    out.normals.row(w) = in.normals.row(v);
    if (in.uvs.rows()) out.uvs.row(w) = in.uvs.row(v);
  }
  std::vector<int> material_to(in.materials.size(), -1);
  std::vector<std::array<int, 3>> tris;
  for (int f = 0; f < in.triangle_count(); ++f) {
    std::array<int, 3> t{};
    for (int k = 0; k < 3; ++k) t[k] = to[static_cast<std::size_t>(in.triangles(f, k))];
    if (t[0] < 0 || t[1] < 0 || t[2] < 0) continue;
    tris.push_back(t);
    int& m = material_to[static_cast<std::size_t>(in.triangle_material[f])];
    if (m < 0) {
      m = static_cast<int>(out.materials.size());
      out.materials.push_back(in.materials[static_cast<std::size_t>(in.triangle_material[f])]);
    }
    out.triangle_material.push_back(m);
  }
  out.triangles.resize(static_cast<Eigen::Index>(tris.size()), 3);
  for (std::size_t f = 0; f < tris.size(); ++f)
    for (int k = 0; k < 3; ++k) out.triangles(static_cast<Eigen::Index>(f), k) = tris[f][k];
  for (const auto& s : in.shapes) {
    rig::Blendshape b;
    b.name = s.name;
    std::vector<Eigen::Index> rows;
    for (std::size_t i = 0; i < s.vertices.size(); ++i)
      if (to[static_cast<std::size_t>(s.vertices[i])] >= 0) {
        b.vertices.push_back(to[static_cast<std::size_t>(s.vertices[i])]);
        rows.push_back(static_cast<Eigen::Index>(i));
      }
    b.deltas = s.deltas(rows, Eigen::all);
    out.shapes.push_back(std::move(b));
  }
  for (const auto& l : in.landmarks)
    if (to[static_cast<std::size_t>(l.vertex)] >= 0)
      out.landmarks.push_back({l.name, to[static_cast<std::size_t>(l.vertex)]});
  return out;
}

// The FaceKit's name as ARKit's (eyeBlink_L -> eyeBlinkLeft) when ARKit has it; else itself.
std::string arkit_name(const std::string& ict) {
  std::string name = ict;
  if (ict.ends_with("_L")) name = ict.substr(0, ict.size() - 2) + "Left";
  if (ict.ends_with("_R")) name = ict.substr(0, ict.size() - 2) + "Right";
  return is_arkit(name) ? name : ict;
}

// Shapes in ARKit's order, then the FaceKit's extras, then the visemes: sum_s w_s * delta_s over
// each Oculus row of configs/anim/visemes_arkit.json (names the rig lacks, tongueOut, skipped).
std::vector<rig::Blendshape> arkit_shapes(const rig::Rig& rig) {
  const int nv = rig.vertex_count();
  std::map<std::string, rig::Positions> dense;
  std::vector<std::string> extras;
  for (const auto& s : rig.shapes) {
    const std::string name = arkit_name(s.name);
    dense[name] = s.dense(nv);
    if (!is_arkit(name)) extras.push_back(name);
  }
  for (const char* both : {"browInnerUp", "cheekPuff"}) {
    const std::string b = both;
    if (dense.contains(b + "_L") && dense.contains(b + "_R"))
      dense[b] = dense[b + "_L"] + dense[b + "_R"];
  }
  std::vector<rig::Blendshape> out;
  for (const auto& a : avatar::avatar_shape_names())
    if (dense.contains(a)) out.push_back(rig::Blendshape::from_dense(a, dense[a]));
  for (const auto& e : extras) out.push_back(rig::Blendshape::from_dense(e, dense[e]));
  const auto path = config_path("anim/visemes_arkit.json");
  const nlohmann::json table = load_json(path);
  if (!table.contains("visemes") || !table["visemes"].contains("oculus"))
    throw Error(path.string() + ": visemes.oculus is missing");
  for (const char* viseme : kOculus) {
    const std::string at = path.string() + ": visemes.oculus." + viseme;
    if (!table["visemes"]["oculus"].contains(viseme)) throw Error(at + " is missing");
    const nlohmann::json& row = table["visemes"]["oculus"][viseme];
    rig::Positions d = rig::Positions::Zero(nv, 3);
    for (const auto& [name, w] : row.items()) {
      if (!w.is_number()) throw Error(at + "." + name + ": not a number");
      if (const auto it = dense.find(name); it != dense.end()) d += w.get<float>() * it->second;
    }
    out.push_back(rig::Blendshape::from_dense(std::string("viseme_") + viseme, d));
  }
  return out;
}

}  // namespace

rig::Rig ict_template_rig(const std::filesystem::path& dir) {
  const auto neutral = dir / "generic_neutral_mesh.obj";
  rig::Rig ict = rig::read_obj_shapes(neutral, dir, {"identity*"});
  if (ict.vertex_count() < kDropEnd)
    throw Error(neutral.string() + ": " + std::to_string(ict.vertex_count()) +
                " vertices, not the ICT FaceKit's 26719");
  const auto indices_path = dir / "vertex_indices.json";
  const nlohmann::json indices = load_json(indices_path);
  if (!indices.contains("idx_to_landmark_verts") ||
      indices["idx_to_landmark_verts"].size() != kLandmarkCount)
    throw Error(indices_path.string() + ": idx_to_landmark_verts: expected 68 vertex indices");
  for (int k = 0; k < kLandmarkCount; ++k) {
    const int v = indices["idx_to_landmark_verts"][static_cast<std::size_t>(k)].get<int>();
    if (v < 0 || v >= kDropFirst)
      throw Error(indices_path.string() + ": idx_to_landmark_verts[" + std::to_string(k) +
                  "]: not a face vertex");
    ict.landmarks.push_back({landmark_name(k), v});
  }
  std::vector<bool> keep(static_cast<std::size_t>(ict.vertex_count()), true);
  std::fill(keep.begin() + kDropFirst, keep.begin() + kDropEnd, false);
  rig::Rig rig = keep_vertices(ict, keep);
  rig.shapes = arkit_shapes(rig);
  for (auto& m : rig.materials) {
    for (const auto& look : kLooks) {
      if (m.name != look.name) continue;
      m.base_color = look.color;
      m.roughness = look.roughness;
      m.double_sided = look.double_sided;
    }
  }
  rig.normals = rig::vertex_normals(rig.positions, rig.triangles);
  rig.validate(dir.string());
  return rig;
}

std::vector<rig::Positions> ict_identity_modes(const std::filesystem::path& dir) {
  const rig::Positions neutral = rig::read_obj_positions(dir / "generic_neutral_mesh.obj");
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    if (e.path().stem().string().starts_with("identity") && e.path().extension() == ".obj")
      files.push_back(e.path());
  std::sort(files.begin(), files.end());
  std::vector<rig::Positions> modes;
  const Eigen::Index kept = neutral.rows() - (kDropEnd - kDropFirst);
  for (const auto& f : files) {
    const rig::Positions p = rig::read_obj_positions(f);
    if (p.rows() != neutral.rows())
      throw Error(f.string() + ": " + std::to_string(p.rows()) + " vertices, the neutral has " +
                  std::to_string(neutral.rows()));
    rig::Positions d(kept, 3);
    d.topRows(kDropFirst) = p.topRows(kDropFirst) - neutral.topRows(kDropFirst);
    d.bottomRows(kept - kDropFirst) =
        p.bottomRows(kept - kDropFirst) - neutral.bottomRows(kept - kDropFirst);
    modes.push_back(std::move(d));
  }
  return modes;
}

}  // namespace facecast::rigbuild
