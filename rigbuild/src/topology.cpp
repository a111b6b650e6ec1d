// Same-topology correspondences: the identity, and the same triangles in another order.
#include <algorithm>
#include <tuple>

#include "facecast/rigbuild/correspondence.hpp"

namespace facecast::rigbuild {

Correspondence identity_correspondence(int vertex_count, const Triangles& faces) {
  Correspondence c;
  c.template_vertices = c.target_vertices = vertex_count;
  c.template_triangles = c.target_triangles = static_cast<int>(faces.rows());
  c.map = TriangleMap::identity(static_cast<int>(faces.rows()));
  c.vertex_map.resize(static_cast<std::size_t>(vertex_count));
  for (int v = 0; v < vertex_count; ++v) c.vertex_map[static_cast<std::size_t>(v)].v = {v, v, v};
  return c;
}

std::optional<std::vector<int>> match_triangle_order(const Triangles& tmpl,
                                                     const Triangles& target) {
  if (tmpl.rows() != target.rows()) return std::nullopt;
  // A triangle's key: its corners rotated so the smallest comes first (keeps the orientation).
  using Key = std::array<int, 3>;
  const auto key = [](const Triangles& f, Eigen::Index t) {
    Key k{f(t, 0), f(t, 1), f(t, 2)};
    std::rotate(k.begin(), std::min_element(k.begin(), k.end()), k.end());
    return k;
  };
  const auto n = static_cast<std::size_t>(tmpl.rows());
  std::vector<std::pair<Key, int>> sorted(n);
  for (std::size_t t = 0; t < n; ++t)
    sorted[t] = {key(tmpl, static_cast<Eigen::Index>(t)), static_cast<int>(t)};
  std::sort(sorted.begin(), sorted.end());
  // Equal template triangles go to equal target triangles in order: taken[i] counts the template
  // triangles of the run starting at i already given out.
  std::vector<int> out(n), taken(n, 0);
  for (std::size_t t = 0; t < n; ++t) {
    const Key k = key(target, static_cast<Eigen::Index>(t));
    const auto first = std::lower_bound(sorted.begin(), sorted.end(), std::pair{k, -1});
    const auto run = static_cast<std::size_t>(first - sorted.begin());
    const std::size_t i = run + static_cast<std::size_t>(run < n ? taken[run]++ : 0);
    if (i >= n || sorted[i].first != k) return std::nullopt;
    out[t] = sorted[i].second;
  }
  return out;
}

std::optional<Correspondence> same_topology_correspondence(int template_vertices,
                                                           const Triangles& template_faces,
                                                           int target_vertices,
                                                           const Triangles& target_faces) {
  if (template_vertices != target_vertices) return std::nullopt;
  if (template_faces == target_faces) return identity_correspondence(target_vertices, target_faces);
  const auto order = match_triangle_order(template_faces, target_faces);
  if (!order) return std::nullopt;
  Correspondence c = identity_correspondence(target_vertices, target_faces);
  for (std::size_t t = 0; t < order->size(); ++t) c.map.sources[t] = {(*order)[t]};
  return c;
}

bool reorder_triangles_like(const rig::Rig& tmpl, rig::Rig& target) {
  if (tmpl.vertex_count() != target.vertex_count()) return false;
  if (tmpl.triangles == target.triangles) return true;
  const auto order = match_triangle_order(tmpl.triangles, target.triangles);
  if (!order) return false;
  // Template slot s gets the target triangle that matches it (the same corners as the
  // template's), with that triangle's material and group.
  std::vector<int> mats(order->size(), 0),
      groups(target.triangle_group.empty() ? 0 : order->size());
  for (std::size_t t = 0; t < order->size(); ++t) {
    const auto s = static_cast<std::size_t>((*order)[t]);
    if (!target.triangle_material.empty()) mats[s] = target.triangle_material[t];
    if (!groups.empty()) groups[s] = target.triangle_group[t];
  }
  target.triangles = tmpl.triangles;
  if (!target.triangle_material.empty()) target.triangle_material = std::move(mats);
  if (!groups.empty()) target.triangle_group = std::move(groups);
  return true;
}

}  // namespace facecast::rigbuild
