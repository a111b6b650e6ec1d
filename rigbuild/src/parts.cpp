// The template's parts and rigid parts. See docs/algorithms.md#rigid-parts.
#include <Eigen/Geometry>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <string>

#include "stages.hpp"

namespace facecast::rigbuild {

namespace {

// Per triangle, its component's most common material; empty with one material.
std::vector<int> by_material(const rig::Rig& tmpl, const rig::Components& comps) {
  if (tmpl.materials.size() < 2) return {};
  std::vector<std::map<int, int>> count(static_cast<std::size_t>(comps.count));
  for (int t = 0; t < tmpl.triangle_count(); ++t) {
    ++count[static_cast<std::size_t>(comps.label[tmpl.triangles(t, 0)])][tmpl.triangle_material[t]];
  }
  std::vector<int> part_of(static_cast<std::size_t>(comps.count));
  for (int c = 0; c < comps.count; ++c) {
    const auto& m = count[static_cast<std::size_t>(c)];
    part_of[static_cast<std::size_t>(c)] =
        std::max_element(m.begin(), m.end(), [](auto& a, auto& b) {
          return a.second < b.second;
        })->first;
  }
  std::vector<int> parts(static_cast<std::size_t>(tmpl.triangle_count()));
  for (int t = 0; t < tmpl.triangle_count(); ++t) {
    parts[static_cast<std::size_t>(t)] =
        part_of[static_cast<std::size_t>(comps.label[tmpl.triangles(t, 0)])];
  }
  return parts;
}

Points rows(const Points& p, const std::vector<int>& vertices) {
  Points out(static_cast<Eigen::Index>(vertices.size()), 3);
  for (std::size_t i = 0; i < vertices.size(); ++i)
    out.row(static_cast<Eigen::Index>(i)) = p.row(vertices[i]);
  return out;
}

}  // namespace

TemplateParts::TemplateParts(const rig::Rig& tmpl)
    : mesh(tmpl.vertex_count(), tmpl.triangles), of_triangle(by_material(tmpl, mesh.components)) {}

RigidParts rigid_parts(const rig::Rig& tmpl, const TemplateParts& template_parts,
                       const TemplateShapes& source, double tolerance) {
  const MeshParts& comps = template_parts.mesh;
  const std::vector<int>& parts = template_parts.of_triangle;
  const int count = comps.components.count;
  std::vector<int> material(static_cast<std::size_t>(count), -1);
  for (int t = 0; t < tmpl.triangle_count(); ++t)
    material[static_cast<std::size_t>(comps.of(tmpl.triangles(t, 0)))] =
        parts.empty() ? comps.of(tmpl.triangles(t, 0)) : parts[static_cast<std::size_t>(t)];
  const auto fit = [&](const std::vector<int>& vertices) {
    const Points from = rows(source.rest, vertices);
    std::vector<Similarity> motion;
    for (const Points& shape : source.shapes)
      motion.push_back(procrustes(from, rows(shape, vertices), false));
    return motion;
  };
  // Every shape moves `vertices` by `motion` within the tolerance (relative to their size).
  const auto moves_by = [&](const std::vector<int>& vertices,
                            const std::vector<Similarity>& motion) {
    const Points from = rows(source.rest, vertices);
    const double size = std::max(diagonal(from), 1e-12);
    for (std::size_t k = 0; k < source.size(); ++k) {
      const Points moved = motion[k].apply(from);
      if (std::sqrt((moved - rows(source.shapes[k], vertices)).rowwise().squaredNorm().mean()) >
          tolerance * size)
        return false;
    }
    return true;
  };
  RigidParts out;
  out.of_vertex.assign(static_cast<std::size_t>(tmpl.vertex_count()), -1);
  std::vector<std::vector<int>> part_members;
  std::vector<int> part_material;
  for (int c = 0; c < count; ++c) {
    const auto& mem = comps.members[static_cast<std::size_t>(c)];
    if (mem.size() < 3) continue;
    std::vector<Similarity> own = fit(mem);
    if (!moves_by(mem, own)) continue;
    std::size_t p = 0;
    while (p < part_members.size() && !(part_material[p] == material[static_cast<std::size_t>(c)] &&
                                        moves_by(mem, out.motion[p])))
      ++p;
    if (p == part_members.size()) {
      part_members.emplace_back();
      part_material.push_back(material[static_cast<std::size_t>(c)]);
      out.motion.push_back(std::move(own));
    }
    part_members[p].insert(part_members[p].end(), mem.begin(), mem.end());
    for (int v : mem) out.of_vertex[static_cast<std::size_t>(v)] = static_cast<int>(p);
  }
  for (std::size_t p = 0; p < part_members.size(); ++p) out.motion[p] = fit(part_members[p]);
  return out;
}

Sphere fit_sphere(const Points& p) {
  // |p|^2 = 2 c.p + (r^2 - |c|^2): linear in (c, r^2 - |c|^2).
  const auto n = p.rows();
  Eigen::MatrixXd a(n, 4);
  a.leftCols(3) = 2 * p;
  a.col(3).setOnes();
  const Eigen::VectorXd b = p.rowwise().squaredNorm();
  const Eigen::Vector4d x = a.colPivHouseholderQr().solve(b);
  Sphere s;
  s.centre = x.head<3>().transpose();
  s.radius = std::sqrt(std::max(x(3) + s.centre.squaredNorm(), 0.0));
  s.rms = std::sqrt(((p.rowwise() - s.centre).rowwise().norm().array() - s.radius).square().mean());
  return s;
}

std::optional<Sphere> ball(const Points& p) {
  if (p.rows() < 8) return std::nullopt;
  const Sphere s = fit_sphere(p);
  const Eigen::RowVector3d extent = p.colwise().maxCoeff() - p.colwise().minCoeff();
  if (!(s.radius > 0) || s.rms > kSphereResidual * s.radius || extent.minCoeff() < s.radius)
    return std::nullopt;
  return s;
}

namespace {

double angle(const Eigen::Matrix3d& r) {
  return std::acos(std::clamp((r.trace() - 1) / 2, -1.0, 1.0));
}

// Per shape, the eyeball's turn about `centre` (template frame: +x the subject's left, +y up, +z
// forward) that an eyeLook shape of its side asks for; identity for every other shape.
std::vector<Similarity> gaze(const rig::Rig& tmpl, const Eigen::RowVector3d& centre, bool left,
                             const EyeLookOptions& look) {
  const double deg = std::acos(-1.0) / 180, side = left ? 1 : -1;
  const std::string suffix = left ? "Left" : "Right";
  const std::pair<const char*, Eigen::AngleAxisd> turns[] = {
      {"eyeLookIn", Eigen::AngleAxisd(-side * look.in_out * deg, Eigen::Vector3d::UnitY())},
      {"eyeLookOut", Eigen::AngleAxisd(side * look.in_out * deg, Eigen::Vector3d::UnitY())},
      {"eyeLookUp", Eigen::AngleAxisd(-look.up * deg, Eigen::Vector3d::UnitX())},
      {"eyeLookDown", Eigen::AngleAxisd(look.down * deg, Eigen::Vector3d::UnitX())}};
  std::vector<Similarity> out(tmpl.shapes.size());
  for (std::size_t k = 0; k < out.size(); ++k)
    for (const auto& [name, turn] : turns)
      if (tmpl.shapes[k].name == std::string(name) + suffix) {
        out[k].R = turn.toRotationMatrix();
        out[k].t = centre.transpose() - out[k].R * centre.transpose();
      }
  return out;
}

}  // namespace

std::vector<TemplateEye> template_eyes(const rig::Rig& tmpl, const TemplateShapes& source,
                                       const RigidParts& rigid, const EyeLookOptions& look) {
  std::vector<TemplateEye> turned, still;
  const double tiny = 1e-6 * diagonal(source.rest);
  for (std::size_t part = 0; part < rigid.motion.size(); ++part) {
    bool looks = false, moves = false;
    for (std::size_t k = 0; k < source.size(); ++k) {
      const Similarity& m = rigid.motion[part][k];
      looks |= tmpl.shapes[k].name.starts_with("eyeLook") && angle(m.R) > kEyeTurn;
      moves |= angle(m.R) > kEyeTurn || m.t.norm() > tiny;
    }
    std::vector<int> members;
    for (std::size_t v = 0; v < rigid.of_vertex.size(); ++v)
      if (rigid.of_vertex[v] == static_cast<int>(part)) members.push_back(static_cast<int>(v));
    const Points at = rows(source.rest, members);
    if (looks)
      turned.push_back({static_cast<int>(part), fit_sphere(at), rigid.motion[part]});
    else if (const auto s = ball(at); s && !moves)
      still.push_back({static_cast<int>(part), *s, {}});
  }
  if (!turned.empty() || still.empty()) return turned;
  // No shape turns the template's eyeballs: its still balls turn by the configured gaze.
  double mid = 0;
  for (const auto& e : still) mid += e.sphere.centre.x() / static_cast<double>(still.size());
  if (still.size() == 1) mid = 0;
  for (auto& e : still) e.motion = gaze(tmpl, e.sphere.centre, e.sphere.centre.x() > mid, look);
  return still;
}

}  // namespace facecast::rigbuild
