// OBJ reading and writing.
//
// Our own parser rather than OpenMesh's OBJ reader: OpenMesh builds a half-edge mesh, so it drops
// or duplicates vertices of faces that would make the mesh non-manifold (ICT FaceKit's eye and
// mouth parts touch), splits vertices at UV seams on request, and forgets groups. Expressions are
// matched to the neutral by vertex index, so vertex order and count must be exactly those of the
// file.
#include <fnmatch.h>
#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <unordered_map>

#include "decode_budget.hpp"
#include "facecast/core/config.hpp"
#include "facecast/core/config_reader.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/core/threads.hpp"
#include "facecast/rig/avatar_view.hpp"
#include "facecast/rig/rest_pose.hpp"
#include "facecast/rig/rig_io.hpp"

namespace facecast::rig {
namespace {

struct LineReader {
  std::string_view text;
  std::size_t pos = 0;
  int line = 0;
  std::string_view name = {};  // for the error on a long line
  std::size_t max_line = 0;    // 0: any length
  bool next(std::string_view& out) {
    if (pos >= text.size()) return false;
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    if (max_line && end - pos > max_line)
      throw Error(std::string(name) + ":" + std::to_string(line + 1) + ": line of " +
                      std::to_string(end - pos) + " bytes is over the limit of " +
                      std::to_string(max_line) + " (max_obj_line)",
                  ErrorCode::kLimit);
    out = text.substr(pos, end - pos);
    if (!out.empty() && out.back() == '\r') out.remove_suffix(1);
    pos = end + 1;
    ++line;
    return true;
  }
};

bool is_space(char c) {
  return c == ' ' || c == '\t';
}

std::string_view next_token(std::string_view& s) {
  std::size_t i = 0;
  while (i < s.size() && is_space(s[i])) ++i;
  std::size_t j = i;
  while (j < s.size() && !is_space(s[j])) ++j;
  std::string_view tok = s.substr(i, j - i);
  s.remove_prefix(j);
  return tok;
}

std::string where(std::string_view name, int line) {
  return std::string(name) + ":" + std::to_string(line) + ": ";
}

template <int N>
Eigen::Matrix<float, 1, N> parse_floats(std::string_view rest, std::string_view name, int line,
                                        const char* what) {
  Eigen::Matrix<float, 1, N> out;
  for (int i = 0; i < N; ++i) {
    std::string_view tok = next_token(rest);
    if (tok.empty()) {
      throw Error(where(name, line) + "expected " + std::to_string(N) + " numbers in '" + what +
                  "' record");
    }
    if (tok.front() == '+') tok.remove_prefix(1);
    float v = 0;
    auto [p, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), v);
    if (ec != std::errc() || p != tok.data() + tok.size()) {
      if (tok == "nan" || tok == "NaN" || tok == "inf" || tok == "-inf" || tok == "-nan") {
        throw Error(where(name, line) + "non-finite coordinate '" + std::string(tok) + "'");
      }
      throw Error(where(name, line) + "bad number '" + std::string(tok) + "'");
    }
    if (!std::isfinite(v)) {
      throw Error(where(name, line) + "non-finite coordinate '" + std::string(tok) + "'");
    }
    out[i] = v;
  }
  return out;
}

int parse_index(std::string_view tok, int current_count, std::string_view name, int line) {
  int v = 0;
  auto [p, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), v);
  if (ec != std::errc() || p != tok.data() + tok.size() || v == 0) {
    throw Error(where(name, line) + "bad face index '" + std::string(tok) + "'");
  }
  return v > 0 ? v - 1 : current_count + v;  // negative indices count back from the last record
}

struct Corner {
  int v = -1, t = -1, n = -1;
};

int intern(std::vector<std::string>& names, std::unordered_map<std::string, int>& index,
           std::string_view name) {
  auto [it, inserted] = index.try_emplace(std::string(name), static_cast<int>(names.size()));
  if (inserted) names.emplace_back(name);
  return it->second;
}

std::string trim(std::string_view s) {
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
  return std::string(s);
}

// The image a map_Kd line names (its last token: options may come first), relative to the .mtl.
// PNG, JPEG and WebP are read; a missing or other image only loses the texture, as a missing
// material library loses the colours in every OBJ viewer.
int read_texture(Rig& rig, const std::filesystem::path& mtl, std::string_view rest,
                 const DecodeLimits& limits) {
  std::string file = trim(rest);
  if (const auto space = file.find_last_of(" \t"); space != std::string::npos)
    file = file.substr(space + 1);
  std::string bytes;
  try {
    bytes = read_file(mtl.parent_path() / file);
  } catch (const Error&) {
    return -1;
  }
  const bool png = bytes.rfind("\x89PNG", 0) == 0, jpeg = bytes.rfind("\xff\xd8\xff", 0) == 0;
  const bool webp =
      bytes.size() >= 12 && bytes.rfind("RIFF", 0) == 0 && bytes.substr(8, 4) == "WEBP";
  if (!png && !jpeg && !webp) return -1;
  try {  // over the image limits: an error, before any decoder; unreadable: as any bad texture
    (void)check_image(bytes, (mtl.parent_path() / file).string(), limits);
  } catch (const Error& e) {
    if (e.code() == ErrorCode::kLimit) throw;
  }
  rig.textures.push_back({file,
                          png    ? "image/png"
                          : jpeg ? "image/jpeg"
                                 : "image/webp",
                          std::move(bytes)});
  return static_cast<int>(rig.textures.size()) - 1;
}

// Reads an .mtl file into the rig's materials (names not in the file keep grey): Kd colour, d
// (or Tr = 1 - d) opacity, blended when below 1; map_Kd as the base-colour texture. (Ns/Ks are not
// read: without a physically based model in the file, Facecast's default roughness looks better.)
void apply_mtl(Rig& rig, const std::filesystem::path& mtl, const DecodeLimits& limits) {
  std::string text;
  try {
    text = read_file(mtl);
  } catch (const Error&) {
    return;  // a missing material library only loses colours, as in every OBJ viewer
  }
  LineReader lr{text, 0, 0, mtl.native(), limits.max_obj_line};
  std::string_view line;
  Material* current = nullptr;
  const auto opacity = [&](float d) {
    current->base_color[3] = std::clamp(d, 0.0f, 1.0f);
    current->alpha_mode = d < 1.0f ? AlphaMode::kBlend : AlphaMode::kOpaque;
  };
  while (lr.next(line)) {
    std::string_view rest = line;
    std::string_view key = next_token(rest);
    if (key == "newmtl") {
      const std::string n = trim(rest);
      current = nullptr;
      for (auto& m : rig.materials)
        if (m.name == n) current = &m;
    } else if (!current) {
      continue;
    } else if (key == "Kd") {
      current->base_color.head<3>() =
          parse_floats<3>(rest, mtl.string(), lr.line, "Kd").transpose();
    } else if (key == "d") {
      opacity(parse_floats<1>(rest, mtl.string(), lr.line, "d")[0]);
    } else if (key == "Tr") {
      opacity(1.0f - parse_floats<1>(rest, mtl.string(), lr.line, "Tr")[0]);
    } else if (key == "map_Kd") {
      current->base_color_texture.texture = read_texture(rig, mtl, rest, limits);
    }
  }
}

// configs/rig/materials.json: looks for material names whose library cannot say them (the ICT
// FaceKit's transparent eye shells, its irises).
void apply_presets(Rig& rig) {
  static const std::vector<std::pair<std::string, Material>> presets = [] {
    std::vector<std::pair<std::string, Material>> out;
    ConfigReader c = ConfigReader::open(config_path("rig/materials.json"));
    ConfigReader& list = c.section("materials");
    for (const std::string& name : list.keys()) {
      Material m;
      std::array<float, 3> srgb{1, 1, 1};
      float alpha = 1;
      list.section(name)
          .read("base_color_srgb", srgb)
          .read("alpha", alpha)
          .read("roughness", m.roughness)
          .read_choice("alpha_mode", m.alpha_mode,
                       {{"opaque", AlphaMode::kOpaque}, {"blend", AlphaMode::kBlend}})
          .reject_unknown();
      for (int k = 0; k < 3; ++k) m.base_color[k] = srgb_to_linear(srgb[k]);
      m.base_color[3] = alpha;
      out.emplace_back(name, m);
    }
    c.reject_unknown();
    return out;
  }();
  for (auto& m : rig.materials)
    for (const auto& [name, preset] : presets)
      if (m.name == name && m.base_color_texture.texture < 0) {
        m.base_color = preset.base_color;
        m.roughness = preset.roughness;
        m.alpha_mode = preset.alpha_mode;
      }
}

struct ParsedObj {
  Rig rig;
  std::vector<std::string> mtllibs;
};

// What each record costs once parsed (its row in the lists here and in the rig), charged to the
// file's decoded budget before it is stored: a small file of long faces cannot ask for much more.
constexpr std::size_t kVertexBytes = 12 + 12 + 12 + 8 + 8, kTexBytes = 8 + 8, kNormalBytes = 12,
                      kTriangleBytes = 12 + 24 + 4 + 4 + 4 + 12, kNameBytes = 256;

ParsedObj parse(std::string_view text, std::string_view name, const DecodeLimits& limits) {
  detail::DecodeBudget budget(limits, text.size());
  ParsedObj out;
  Rig& rig = out.rig;
  std::vector<Eigen::RowVector3f> pos;
  std::vector<Eigen::RowVector2f> tex;
  std::vector<Eigen::RowVector3f> nrm;
  std::vector<Eigen::Vector3i> tris;
  std::vector<std::array<int, 6>> tri_tn;  // texcoord and normal index per corner
  std::vector<int> tri_line;
  std::vector<std::string> mat_names, group_names;
  std::unordered_map<std::string, int> mat_index, group_index;
  int cur_mat = -1, cur_group = -1;
  std::vector<Corner> corners;

  LineReader lr{text, 0, 0, name, limits.max_obj_line};
  std::string_view line;
  const auto charge = [&](std::size_t bytes, const char* what) {
    budget.charge(bytes, std::string(name) + ":" + std::to_string(lr.line), what);
  };
  while (lr.next(line)) {
    std::string_view rest = line;
    const std::string_view key = next_token(rest);
    if (key.empty() || key.front() == '#') continue;
    if (key == "v") {
      charge(kVertexBytes, "vertex");
      pos.push_back(parse_floats<3>(rest, name, lr.line, "v"));
    } else if (key == "vt") {
      charge(kTexBytes, "texture coordinate");
      tex.push_back(parse_floats<2>(rest, name, lr.line, "vt"));
    } else if (key == "vn") {
      charge(kNormalBytes, "normal");
      nrm.push_back(parse_floats<3>(rest, name, lr.line, "vn"));
    } else if (key == "f") {
      corners.clear();
      for (std::string_view tok = next_token(rest); !tok.empty(); tok = next_token(rest)) {
        if (corners.size() >= limits.max_obj_face)
          throw Error(where(name, lr.line) + "face of more than " +
                          std::to_string(limits.max_obj_face) + " corners (max_obj_face)",
                      ErrorCode::kLimit);
        Corner c;
        const std::size_t s1 = tok.find('/');
        c.v = parse_index(tok.substr(0, s1), static_cast<int>(pos.size()), name, lr.line);
        if (s1 != std::string_view::npos) {
          std::string_view r = tok.substr(s1 + 1);
          const std::size_t s2 = r.find('/');
          if (s2 != 0 && !r.empty()) {
            c.t = parse_index(r.substr(0, s2), static_cast<int>(tex.size()), name, lr.line);
          }
          if (s2 != std::string_view::npos && s2 + 1 < r.size()) {
            c.n = parse_index(r.substr(s2 + 1), static_cast<int>(nrm.size()), name, lr.line);
          }
        }
        corners.push_back(c);
      }
      if (corners.size() < 3) {
        throw Error(where(name, lr.line) + "face with fewer than 3 vertices");
      }
      if (cur_mat < 0) cur_mat = intern(mat_names, mat_index, "default");
      charge(detail::product(corners.size() - 2, kTriangleBytes), "face");
      for (std::size_t k = 1; k + 1 < corners.size(); ++k) {  // fan triangulation
        const Corner& a = corners[0];
        const Corner& b = corners[k];
        const Corner& c = corners[k + 1];
        tris.emplace_back(a.v, b.v, c.v);
        tri_tn.push_back({a.t, b.t, c.t, a.n, b.n, c.n});
        tri_line.push_back(lr.line);
        rig.triangle_material.push_back(cur_mat);
        rig.triangle_group.push_back(cur_group);
      }
    } else if (key == "usemtl") {
      charge(kNameBytes + 2 * rest.size(), "material name");
      cur_mat = intern(mat_names, mat_index, trim(rest));
    } else if (key == "g" || key == "o") {
      if (key == "o" && cur_group >= 0) continue;  // groups are finer than objects
      charge(kNameBytes + 2 * rest.size(), "group name");
      const std::string g = trim(rest);
      cur_group = g.empty() ? -1 : intern(group_names, group_index, g);
    } else if (key == "mtllib") {
      out.mtllibs.push_back(trim(rest));
    }
    // s, l, p, and unknown records carry nothing a rig keeps.
  }

  const int nv = static_cast<int>(pos.size());
  if (nv == 0) throw Error(std::string(name) + ": mesh has no vertices");
  if (tris.empty()) throw Error(std::string(name) + ": mesh has no faces");
  rig.positions.resize(nv, 3);
  for (int v = 0; v < nv; ++v) rig.positions.row(v) = pos[v];
  rig.triangles.resize(static_cast<Eigen::Index>(tris.size()), 3);

  std::vector<int> vt_of(static_cast<std::size_t>(nv), -1), vn_of(static_cast<std::size_t>(nv), -1);
  for (std::size_t f = 0; f < tris.size(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const int v = tris[f][c];
      if (v < 0 || v >= nv) {
        throw Error(where(name, tri_line[f]) + "face index " + std::to_string(v + 1) +
                    " out of range (" + std::to_string(nv) + " vertices)");
      }
      const int t = tri_tn[f][c], n = tri_tn[f][3 + c];
      if (t >= static_cast<int>(tex.size()) || t < -1 || n >= static_cast<int>(nrm.size()) ||
          n < -1) {
        throw Error(where(name, tri_line[f]) + "texture or normal index out of range");
      }
      if (vt_of[v] < 0) vt_of[v] = t;
      if (vn_of[v] < 0) vn_of[v] = n;
    }
    rig.triangles.row(static_cast<Eigen::Index>(f)) = tris[f].transpose();
  }

  if (!tex.empty()) {  // OBJ's v is 0 at the image's bottom, a rig's (glTF's) at its top
    rig.uvs = UVs::Zero(nv, 2);
    for (int v = 0; v < nv; ++v) {
      if (vt_of[v] >= 0) rig.uvs.row(v) << tex[vt_of[v]][0], 1.0f - tex[vt_of[v]][1];
    }
  }
  vertex_normals(rig.positions, rig.triangles, rig.normals);
  for (int v = 0; v < nv; ++v) {
    if (vn_of[v] >= 0 && nrm[vn_of[v]].norm() > 1e-12f)
      rig.normals.row(v) = nrm[vn_of[v]].normalized();
  }
  // OBJ cannot say which side a face shows; open sheets (eye shells, an inner mouth) are common.
  for (auto& m : mat_names) {
    rig.materials.push_back(Material::solid(m));
    rig.materials.back().double_sided = true;
  }
  rig.groups = std::move(group_names);
  if (rig.groups.empty()) rig.triangle_group.clear();
  return out;
}

}  // namespace

Rig parse_obj(std::string_view text, std::string_view name, const DecodeLimits& limits) {
  Rig rig = parse(text, name, limits).rig;
  rig.validate(name);
  return rig;
}

Rig read_obj(const std::filesystem::path& path, const DecodeLimits& limits) {
  const std::string text = read_file(path);
  ParsedObj p = parse(text, path.string(), limits);
  for (const auto& lib : p.mtllibs) apply_mtl(p.rig, path.parent_path() / lib, limits);
  apply_presets(p.rig);
  p.rig.validate(path.string());
  return std::move(p.rig);
}

Positions read_obj_positions(const std::filesystem::path& path) {
  const std::string text = read_file(path);
  const std::string name = path.string();
  std::vector<Eigen::RowVector3f> pos;
  pos.reserve(text.size() / 40);
  LineReader lr{text};
  std::string_view line;
  while (lr.next(line)) {
    if (line.size() < 2 || line[0] != 'v' || !is_space(line[1])) continue;
    pos.push_back(parse_floats<3>(line.substr(2), name, lr.line, "v"));
  }
  Positions out(static_cast<Eigen::Index>(pos.size()), 3);
  for (std::size_t v = 0; v < pos.size(); ++v) out.row(static_cast<Eigen::Index>(v)) = pos[v];
  return out;
}

Rig read_obj_shapes(const std::filesystem::path& neutral, const std::filesystem::path& shapes_dir,
                    const std::vector<std::string>& exclude_patterns) {
  Rig rig = read_obj(neutral);
  if (!std::filesystem::is_directory(shapes_dir)) {
    throw Error(shapes_dir.string() + ": not a folder", ErrorCode::kNotFound);
  }
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(shapes_dir)) {
    if (!e.is_regular_file() || e.path().extension() != ".obj") continue;
    if (std::filesystem::equivalent(e.path(), neutral)) continue;
    const std::string stem = e.path().stem().string();
    const bool excluded =
        std::any_of(exclude_patterns.begin(), exclude_patterns.end(),
                    [&](const std::string& p) { return fnmatch(p.c_str(), stem.c_str(), 0) == 0; });
    if (!excluded) files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());

  // Shape files are independent: parse them on the cores (within the caller's thread budget).
  std::vector<Blendshape> shapes(files.size());
  parallel_for(files.size(), [&](std::size_t i) {
    Positions p = read_obj_positions(files[i]);
    if (p.rows() != rig.positions.rows()) {
      throw Error(files[i].string() + ": " + std::to_string(p.rows()) +
                  " vertices, but the neutral has " + std::to_string(rig.positions.rows()));
    }
    p -= rig.positions;
    shapes[i] = Blendshape::from_dense(files[i].stem().string(), p);
  });
  rig.shapes = std::move(shapes);
  return rig;
}

namespace {
void append_float(std::string& out, float f) {
  char buf[32];
  auto [p, ec] = std::to_chars(buf, buf + sizeof buf, f);
  out.append(buf, p);
}
}  // namespace

void write_obj(const std::filesystem::path& path, const Rig& rig, const Positions& positions) {
  if (positions.rows() != rig.positions.rows()) {
    throw Error(path.string() + ": position count differs from the rig's vertex count");
  }
  std::string s;
  s.reserve(static_cast<std::size_t>(positions.rows()) * 80 +
            static_cast<std::size_t>(rig.triangles.rows()) * 40);
  s += "# written by facecast\n";
  const bool uv = rig.uvs.rows() == positions.rows();
  const Positions normals = vertex_normals(positions, rig.triangles);
  auto vec = [&](const char* key, auto row) {
    s += key;
    for (Eigen::Index c = 0; c < row.size(); ++c) {
      s += ' ';
      append_float(s, row[c]);
    }
    s += '\n';
  };
  for (Eigen::Index v = 0; v < positions.rows(); ++v) vec("v", positions.row(v));
  if (uv) {
    for (Eigen::Index v = 0; v < positions.rows(); ++v)
      vec("vt", Eigen::RowVector2f(rig.uvs(v, 0), 1.0f - rig.uvs(v, 1)));
  }
  for (Eigen::Index v = 0; v < positions.rows(); ++v) vec("vn", normals.row(v));
  // Faces keep their order; "usemtl"/"g" are written when they change.
  int mat = -1, grp = -1;
  for (Eigen::Index f = 0; f < rig.triangles.rows(); ++f) {
    if (!rig.triangle_group.empty() && rig.triangle_group[f] != grp) {
      grp = rig.triangle_group[f];
      if (grp >= 0) s += "g " + rig.groups[grp] + "\n";
    }
    if (rig.triangle_material[f] != mat) {
      mat = rig.triangle_material[f];
      s += "usemtl " + rig.materials[mat].name + "\n";
    }
    s += 'f';
    for (int c = 0; c < 3; ++c) {
      const std::string i = std::to_string(rig.triangles(f, c) + 1);
      s += ' ';
      s += i;
      s += uv ? "/" + i + "/" : "//";
      s += i;
    }
    s += '\n';
  }
  write_file_atomic(path, s);
}

void write_obj(const std::filesystem::path& path, const Rig& rig) {
  write_obj(path, rig, rig.positions);
}

void write_obj_folder(const std::filesystem::path& dir, const Rig& rig) {
  write_obj(dir / "neutral.obj", rig);
  Positions p;
  for (const auto& s : rig.shapes) {
    p = rig.positions;
    for (std::size_t k = 0; k < s.vertices.size(); ++k) {
      p.row(s.vertices[k]) += s.deltas.row(static_cast<Eigen::Index>(k));
    }
    write_obj(dir / (s.name + ".obj"), rig, p);
  }
}

Rig load_rig(const std::filesystem::path& path) {
  const std::string ext = path.extension().string();
  if (ext == ".glb" || ext == ".gltf" || ext == ".vrm") return read_glb(path);
  if (ext == ".obj") return read_obj(path);
  throw Error(path.string() + ": unknown rig format (expected .glb, .gltf, .vrm or .obj)",
              ErrorCode::kUnsupported);
}

Rig load_scene(const std::filesystem::path& path, const Pose& pose) {
  const std::string ext = path.extension().string();
  Rig rig = ext == ".glb" || ext == ".gltf" || ext == ".vrm"
                ? make_view(AvatarDocument::read(path), {.all_meshes = true}).rig
                : load_rig(path);
  (void)apply_pose(rig, pose);
  return rig;
}

}  // namespace facecast::rig
