// Landmark options, the known templates' landmarks, marker files and the landmark picture.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>

#include "facecast/core/config.hpp"
#include "facecast/core/config_reader.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/rigbuild/landmarks.hpp"

namespace facecast::rigbuild {

std::string landmark_name(int k) {
  return (k < 10 ? "dlib_0" : "dlib_") + std::to_string(k);
}

LandmarkOptions load_landmark_options() {
  ConfigReader c = ConfigReader::open(config_path("rigbuild/landmarks.json"));
  LandmarkOptions o;
  c.read("predictor", o.predictor)
      .read("image_size", o.image_size)
      .read("frame_margin", o.frame_margin)
      .read("face_fill", o.face_fill)
      .read("yaws", o.yaws)
      .read("contour_yaw", o.contour_yaw)
      .read("search_pixels", o.search_pixels)
      .read("outlier", o.outlier)
      .read("symmetry", o.symmetry)
      .read("eye_bias_limit", o.eye_bias_limit)
      .read("lid_margins", o.lid_margins);
  if (o.image_size < 64 || o.image_size > 4096) c.fail("image_size", "must be in 64..4096");
  if (o.frame_margin < 1.0f) c.fail("frame_margin", "must be at least 1");
  if (!(o.face_fill > 0.05 && o.face_fill <= 1)) c.fail("face_fill", "must be in (0.05, 1]");
  if (o.yaws.empty()) c.fail("yaws", "must list at least one view");
  for (double y : o.yaws)
    if (!(std::abs(y) < 80)) c.fail("yaws", "views must be turned less than 80 degrees");
  if (o.outlier <= 0) c.fail("outlier", "must be positive");
  if (o.symmetry <= 0) c.fail("symmetry", "must be positive");
  if (o.eye_bias_limit <= 0) c.fail("eye_bias_limit", "must be positive");
  c.reject_unknown();
  return o;
}

namespace {

// The entry of template_landmarks.json made for `rig` (its vertex and triangle counts), or null.
const nlohmann::json* template_entry(const nlohmann::json& j, const rig::Rig& rig) {
  if (!j.contains("templates")) return nullptr;
  for (const auto& t : j["templates"])
    if (t.value("vertices", -1) == rig.vertex_count() &&
        t.value("triangles", -1) == rig.triangle_count())
      return &t;
  return nullptr;
}

}  // namespace

std::optional<std::array<int, kLandmarkCount>> known_landmarks(const rig::Rig& rig) {
  std::array<int, kLandmarkCount> out;
  out.fill(-1);
  int stored = 0;
  for (const auto& l : rig.landmarks) {
    int k = -1;
    if (std::sscanf(l.name.c_str(), "dlib_%d", &k) == 1 && k >= 0 && k < kLandmarkCount &&
        l.vertex >= 0 && l.vertex < rig.vertex_count()) {
      stored += out[static_cast<std::size_t>(k)] < 0;
      out[static_cast<std::size_t>(k)] = l.vertex;
    }
  }
  if (stored == kLandmarkCount) return out;
  const auto path = config_path("rigbuild/template_landmarks.json");
  const nlohmann::json j = load_json(path);
  const nlohmann::json* t = template_entry(j, rig);
  if (!t) return std::nullopt;
  const auto& ids = t->at("landmarks");
  if (!ids.is_array() || ids.size() != kLandmarkCount)
    throw Error(path.string() + ": templates." + t->value("name", std::string("?")) +
                ".landmarks: expected 68 vertex indices");
  for (int k = 0; k < kLandmarkCount; ++k) {
    const int v = ids[static_cast<std::size_t>(k)].get<int>();
    if (v < -1 || v >= rig.vertex_count())
      throw Error(path.string() + ": templates." + t->value("name", std::string("?")) +
                  ".landmarks[" + std::to_string(k) + "]: vertex out of range");
    out[static_cast<std::size_t>(k)] = v;
  }
  return out;
}

std::optional<std::array<int, 4>> known_lid_middles(const rig::Rig& rig) {
  const auto path = config_path("rigbuild/template_landmarks.json");
  const nlohmann::json j = load_json(path);
  const nlohmann::json* t = template_entry(j, rig);
  if (!t || !t->contains("lid_middles")) return std::nullopt;
  const auto& list = t->at("lid_middles");
  std::array<int, 4> out{};
  if (!list.is_array() || list.size() != out.size())
    throw Error(path.string() + ": templates." + t->value("name", std::string("?")) +
                ".lid_middles: expected 4 vertex numbers");
  for (std::size_t i = 0; i < out.size(); ++i) {
    if (!list[i].is_number_integer() || list[i].get<int>() < 0 ||
        list[i].get<int>() >= rig.vertex_count())
      throw Error(path.string() + ": templates." + t->value("name", std::string("?")) +
                  ".lid_middles[" + std::to_string(i) + "]: not a vertex of the template");
    out[i] = list[i].get<int>();
  }
  return out;
}

std::optional<Points> known_landmark_bias(const rig::Rig& rig) {
  const auto path = config_path("rigbuild/template_landmarks.json");
  const nlohmann::json j = load_json(path);
  const nlohmann::json* t = template_entry(j, rig);
  if (!t || !t->contains("bias")) return std::nullopt;
  const auto& rows = t->at("bias");
  const std::string where =
      path.string() + ": templates." + t->value("name", std::string("?")) + ".bias";
  if (!rows.is_array() || rows.size() != kLandmarkCount)
    throw Error(where + ": expected 68 rows [x, y, z]");
  Points bias(kLandmarkCount, 3);
  for (int k = 0; k < kLandmarkCount; ++k) {
    const auto& row = rows[static_cast<std::size_t>(k)];
    if (!row.is_array() || row.size() != 3 || !row[0].is_number() || !row[1].is_number() ||
        !row[2].is_number())
      throw Error(where + "[" + std::to_string(k) + "]: expected [x, y, z]");
    for (int i = 0; i < 3; ++i) bias(k, i) = row[static_cast<std::size_t>(i)].get<double>();
  }
  return bias;
}

void write_markers_json(const std::filesystem::path& path, const std::vector<MarkerPair>& markers) {
  nlohmann::json pairs = nlohmann::json::array();
  for (const auto& m : markers) {
    nlohmann::json p = {
        {"name", m.name}, {"template", m.template_vertex}, {"target", m.target_vertex}};
    int k = -1;
    if (std::sscanf(m.name.c_str(), "dlib_%d", &k) == 1) p["dlib68"] = k;
    pairs.push_back(std::move(p));
  }
  const nlohmann::json j = {{"index_base", 0}, {"pairs", pairs}};
  write_file_atomic(path, j.dump(1) + "\n");
}

render::Image landmark_picture(const HeadLandmarks& landmarks) {
  render::Image out;
  for (const auto& v : landmarks.views) {
    out.width += v.image.width;
    out.height = std::max(out.height, v.image.height);
  }
  out.pixels.assign(static_cast<std::size_t>(out.width) * out.height * 3, 0);
  int x0 = 0;
  for (const auto& v : landmarks.views) {
    for (int y = 0; y < v.image.height; ++y)
      std::copy_n(&v.image.pixels[static_cast<std::size_t>(y) * v.image.width * 3],
                  static_cast<std::size_t>(v.image.width) * 3,
                  &out.pixels[(static_cast<std::size_t>(y) * out.width + x0) * 3]);
    if (v.found) {
      for (int k = 0; k < kLandmarkCount; ++k) {
        const auto& p = v.pixels[static_cast<std::size_t>(k)];
        const bool used = v.lifted[static_cast<std::size_t>(k)] &&
                          landmarks.vertex[static_cast<std::size_t>(k)] >= 0;
        for (int dy = -2; dy <= 2; ++dy) {
          for (int dx = -2; dx <= 2; ++dx) {
            const int x = static_cast<int>(std::lround(p.x())) + dx;
            const int y = static_cast<int>(std::lround(p.y())) + dy;
            if (x < 0 || y < 0 || x >= v.image.width || y >= v.image.height) continue;
            std::uint8_t* px = &out.pixels[(static_cast<std::size_t>(y) * out.width + x0 + x) * 3];
            px[0] = used ? 40 : 240;
            px[1] = used ? 230 : 40;
            px[2] = 40;
          }
        }
      }
    }
    x0 += v.image.width;
  }
  return out;
}

}  // namespace facecast::rigbuild
