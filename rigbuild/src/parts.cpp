// The template's parts and rigid parts. See docs/algorithms.md#rigid-parts.
#include <algorithm>
#include <map>

#include "stages.hpp"

namespace facecast::rigbuild {

std::vector<int> template_parts(const anim::Rig& tmpl) {
  if (tmpl.materials.size() < 2) return {};
  const anim::Components comps = anim::connected_components(tmpl.vertex_count(), tmpl.triangles);
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

namespace {

Points rows(const Points& p, const std::vector<int>& vertices) {
  Points out(static_cast<Eigen::Index>(vertices.size()), 3);
  for (std::size_t i = 0; i < vertices.size(); ++i)
    out.row(static_cast<Eigen::Index>(i)) = p.row(vertices[i]);
  return out;
}

}  // namespace

RigidParts rigid_parts(const anim::Rig& tmpl, const TemplateShapes& source, double tolerance) {
  const MeshParts comps(tmpl.vertex_count(), tmpl.triangles);
  const std::vector<int> parts = template_parts(tmpl);
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

}  // namespace facecast::rigbuild
