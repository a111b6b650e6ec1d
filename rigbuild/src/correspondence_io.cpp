// Marker pairs from JSON and the binary correspondence cache.
#include <cstring>

#include "facecast/core/config.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/rigbuild/correspondence.hpp"

namespace facecast::rigbuild {
namespace {

// Throws when the pair's vertices (given with `base`) are out of range.
void check_pair(const MarkerPair& m, const std::string& where, int base, int template_vertices,
                int target_vertices) {
  const auto check = [&](int vertex, int count, const char* side) {
    if (vertex >= 0 && vertex < count) return;
    throw Error(where + " (" + m.name + "): " + side + " vertex " + std::to_string(vertex + base) +
                " out of range (" + std::to_string(count) + " vertices)");
  };
  check(m.template_vertex, template_vertices, "template");
  check(m.target_vertex, target_vertices, "target");
}

std::string pair_where(const std::string& where, std::size_t i) {
  return where + ": pairs[" + std::to_string(i) + "]";
}

}  // namespace

void check_markers(const std::vector<MarkerPair>& markers, int template_vertices,
                   int target_vertices, const std::string& where) {
  for (std::size_t i = 0; i < markers.size(); ++i)
    check_pair(markers[i], pair_where(where, i), 0, template_vertices, target_vertices);
  if (markers.size() < 3) throw Error(where + ": at least 3 marker pairs are needed");
}

std::vector<MarkerPair> parse_markers(const nlohmann::json& j, int template_vertices,
                                      int target_vertices, const std::string& where) {
  if (!j.is_object() || !j.contains("pairs") || !j["pairs"].is_array()) {
    throw Error(where + ": expected an object with a \"pairs\" array");
  }
  const nlohmann::json base_field = j.value("index_base", nlohmann::json(0));
  if (!base_field.is_number() || (base_field.get<double>() != 0 && base_field.get<double>() != 1))
    throw Error(where + ": index_base must be 0 or 1");
  const int base = base_field.get<int>();
  std::vector<MarkerPair> out;
  for (std::size_t i = 0; i < j["pairs"].size(); ++i) {
    const auto& p = j["pairs"][i];
    const std::string at = pair_where(where, i);
    if (!p.is_object() || !p.contains("template") || !p.contains("target") ||
        !p["template"].is_number_integer() || !p["target"].is_number_integer()) {
      throw Error(at + ": needs integer \"template\" and \"target\" vertex indices");
    }
    if (p.contains("name") && !p["name"].is_string()) throw Error(at + ": name must be a string");
    MarkerPair m;
    m.name = p.value("name", "pair" + std::to_string(i));
    m.template_vertex = p["template"].get<int>() - base;
    m.target_vertex = p["target"].get<int>() - base;
    check_pair(m, at, base, template_vertices, target_vertices);
    out.push_back(std::move(m));
  }
  if (out.size() < 3) throw Error(where + ": at least 3 marker pairs are needed");
  return out;
}

std::vector<MarkerPair> read_markers(const std::filesystem::path& path, int template_vertices,
                                     int target_vertices) {
  return parse_markers(load_json(path), template_vertices, target_vertices, path.string());
}

namespace {
constexpr char kMagic[8] = {'F', 'C', 'C', 'O', 'R', 'R', '1', '\n'};

template <typename T>
void put(std::string& s, const T& v) {
  s.append(reinterpret_cast<const char*>(&v), sizeof v);
}
template <typename T>
T get(std::string_view& s, const std::string& what) {
  if (s.size() < sizeof(T)) throw Error(what + ": truncated correspondence file");
  T v;
  std::memcpy(&v, s.data(), sizeof v);
  s.remove_prefix(sizeof v);
  return v;
}
}  // namespace

void save_correspondence(const std::filesystem::path& path, const Correspondence& c) {
  std::string s(kMagic, sizeof kMagic);
  for (int n : {c.template_vertices, c.template_triangles, c.target_vertices, c.target_triangles})
    put(s, n);
  put(s, c.alignment.scale);
  for (int i = 0; i < 9; ++i) put(s, c.alignment.R.data()[i]);
  for (int i = 0; i < 3; ++i) put(s, c.alignment.t[i]);
  for (const auto& src : c.map.sources) {
    put(s, static_cast<std::int32_t>(src.size()));
    for (int t : src) put(s, static_cast<std::int32_t>(t));
  }
  for (const auto& sp : c.vertex_map) {
    for (int k = 0; k < 3; ++k) put(s, static_cast<std::int32_t>(sp.v[k]));
    for (int k = 0; k < 3; ++k) put(s, sp.w[k]);
  }
  write_file_atomic(path, s);
}

Correspondence load_correspondence(const std::filesystem::path& path, int template_vertices,
                                   int template_triangles, int target_vertices,
                                   int target_triangles) {
  const std::string bytes = read_file(path);
  const std::string what = path.string();
  std::string_view s(bytes);
  if (s.size() < sizeof kMagic || std::memcmp(s.data(), kMagic, sizeof kMagic) != 0) {
    throw Error(what + ": not a facecast correspondence file");
  }
  s.remove_prefix(sizeof kMagic);
  Correspondence c;
  c.template_vertices = get<int>(s, what);
  c.template_triangles = get<int>(s, what);
  c.target_vertices = get<int>(s, what);
  c.target_triangles = get<int>(s, what);
  if (c.template_vertices != template_vertices || c.template_triangles != template_triangles ||
      c.target_vertices != target_vertices || c.target_triangles != target_triangles) {
    throw Error(what + ": correspondence was made for other meshes (" +
                std::to_string(c.template_vertices) + "/" + std::to_string(c.target_vertices) +
                " vertices); delete it to recompute");
  }
  c.alignment.scale = get<double>(s, what);
  for (int i = 0; i < 9; ++i) c.alignment.R.data()[i] = get<double>(s, what);
  for (int i = 0; i < 3; ++i) c.alignment.t[i] = get<double>(s, what);
  c.map.sources.resize(static_cast<std::size_t>(target_triangles));
  for (auto& src : c.map.sources) {
    const auto n = get<std::int32_t>(s, what);
    if (n < 0 || n > template_triangles) throw Error(what + ": corrupt triangle map");
    for (int k = 0; k < n; ++k) {
      const auto t = get<std::int32_t>(s, what);
      if (t < 0 || t >= template_triangles) throw Error(what + ": corrupt triangle map");
      src.push_back(t);
    }
  }
  c.vertex_map.resize(static_cast<std::size_t>(target_vertices));
  for (auto& sp : c.vertex_map) {
    for (int k = 0; k < 3; ++k) {
      sp.v[k] = get<std::int32_t>(s, what);
      if (sp.v[k] < 0 || sp.v[k] >= template_vertices) throw Error(what + ": corrupt vertex map");
    }
    for (int k = 0; k < 3; ++k) sp.w[k] = get<double>(s, what);
  }
  return c;
}

}  // namespace facecast::rigbuild
