#include "facecast/rigbuild/quality.hpp"

#include <algorithm>
#include <chrono>
#include <optional>

#include "facecast/rig/intersections.hpp"
#include "parallel.hpp"

#include "facecast/core/error.hpp"

namespace facecast::rigbuild {
namespace {
ShapeError stats(const std::string& name, std::vector<double>& err, double diag) {
  ShapeError e;
  e.shape = name;
  if (err.empty()) return e;
  double sum = 0;
  for (double x : err) sum += x;
  e.mean = sum / static_cast<double>(err.size());
  const std::size_t k =
      std::min(err.size() - 1, static_cast<std::size_t>(0.99 * static_cast<double>(err.size())));
  std::nth_element(err.begin(), err.begin() + static_cast<long>(k), err.end());
  e.p99 = err[k];
  e.max = *std::max_element(err.begin(), err.end());
  e.p99_percent = 100.0 * e.p99 / diag;
  return e;
}
}  // namespace

std::vector<ShapeError> truth_errors(const rig::Rig& built, const rig::Positions& truth_neutral,
                                     const rig::Rig& truth_deltas, int first, int last) {
  const int nv = built.vertex_count();
  if (truth_neutral.rows() != nv) throw Error("truth: vertex count differs from the built rig");
  last = std::min(last, nv);
  const double diag =
      (built.positions.colwise().maxCoeff() - built.positions.colwise().minCoeff()).norm();
  std::vector<ShapeError> out;
  std::vector<double> err;
  for (const auto& s : built.shapes) {
    const int ti = truth_deltas.find_shape(s.name);
    if (ti < 0) continue;
    const rig::Positions got = built.positions + s.dense(nv);
    const rig::Positions want =
        truth_neutral + truth_deltas.shapes[static_cast<std::size_t>(ti)].dense(nv);
    err.clear();
    for (int v = first; v < last; ++v) err.push_back((got.row(v) - want.row(v)).norm());
    out.push_back(stats(s.name, err, diag));
  }
  return out;
}

std::vector<ShapeError> truth_errors(const rig::Rig& built,
                                     const std::vector<rig::Positions>& truth) {
  const int nv = built.vertex_count();
  const double diag =
      (built.positions.colwise().maxCoeff() - built.positions.colwise().minCoeff()).norm();
  std::vector<ShapeError> out;
  std::vector<double> err;
  for (std::size_t k = 0; k < built.shapes.size() && k < truth.size(); ++k) {
    if (truth[k].rows() != nv)
      throw Error("truth shape '" + built.shapes[k].name + "': vertex count differs");
    const rig::Positions got = built.positions + built.shapes[k].dense(nv);
    err.clear();
    for (int v = 0; v < nv; ++v) err.push_back((got.row(v) - truth[k].row(v)).norm());
    out.push_back(stats(built.shapes[k].name, err, diag));
  }
  return out;
}

namespace {

// Intersecting pairs of `rig`'s shape `k` (or the neutral for k < 0) that involve a moved triangle.
rig::IntersectionReport shape_pairs(const rig::Rig& rig, int k,
                                    const std::function<bool(int, int)>& ignore,
                                    std::size_t max_listed) {
  rig::IntersectionOptions opt;
  opt.ignore = ignore;
  opt.max_listed = max_listed;
  if (k < 0) return rig::find_intersections(rig.positions, rig.triangles, opt);
  const auto& shape = rig.shapes[static_cast<std::size_t>(k)];
  std::vector<char> moved(static_cast<std::size_t>(rig.vertex_count()), 0);
  for (const int v : shape.vertices) moved[static_cast<std::size_t>(v)] = 1;
  opt.active.assign(static_cast<std::size_t>(rig.triangle_count()), 0);
  bool any = false;
  for (int t = 0; t < rig.triangle_count(); ++t)
    for (int c = 0; c < 3; ++c)
      if (moved[static_cast<std::size_t>(rig.triangles(t, c))]) {
        opt.active[static_cast<std::size_t>(t)] = 1;
        any = true;
      }
  if (!any) return {};
  return rig::find_intersections(rig.positions + shape.dense(rig.vertex_count()), rig.triangles,
                                 opt);
}

std::function<bool(int, int)> group_filter(
    const rig::Rig& rig, const std::vector<std::pair<std::string, std::string>>& groups) {
  std::vector<std::pair<std::string, std::string>> present;
  for (const auto& [a, b] : groups)
    if (std::count(rig.groups.begin(), rig.groups.end(), a) &&
        std::count(rig.groups.begin(), rig.groups.end(), b))
      present.emplace_back(a, b);
  return present.empty() ? std::function<bool(int, int)>{}
                         : rig::ignore_between_groups(rig, present);
}

}  // namespace

ReferenceCrossings::ReferenceCrossings(const rig::Rig& reference, const TriangleMap& map, int rings)
    : reference_(reference),
      map_(map),
      rings_(rings),
      adjacency_(static_cast<std::size_t>(reference.vertex_count())),
      touching_(map.sources.size()),
      touching_made_(std::make_unique<std::once_flag[]>(map.sources.size())) {
  triangles_at_.resize(adjacency_.size());
  for (int t = 0; t < reference.triangle_count(); ++t)
    for (int c = 0; c < 3; ++c) {
      adjacency_[static_cast<std::size_t>(reference.triangles(t, c))].push_back(
          reference.triangles(t, (c + 1) % 3));
      triangles_at_[static_cast<std::size_t>(reference.triangles(t, c))].push_back(t);
    }
}

const std::vector<int>& ReferenceCrossings::touching(int built) const {
  const auto i = static_cast<std::size_t>(built);
  std::call_once(touching_made_[i], [&] {
    std::vector<int>& tris = touching_[i];
    for (const int v : around(built))
      for (const int t : triangles_at_[static_cast<std::size_t>(v)]) tris.push_back(t);
    std::sort(tris.begin(), tris.end());
    tris.erase(std::unique(tris.begin(), tris.end()), tris.end());
  });
  return touching_[i];
}

bool ReferenceCrossings::crosses_at(const Points& positions, int a, int b) const {
  const auto& f = reference_.triangles;
  const auto corner = [&](int t, int c) -> Eigen::Vector3d {
    return positions.row(f(t, c)).transpose();
  };
  const auto share = [&](int s, int t) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        if (f(s, i) == f(t, j)) return true;
    return false;
  };
  // Sweep and prune along x: boxes of b's triangles sorted by their low end.
  struct Box {
    Eigen::Vector3d lo, hi;
    int t;
  };
  const auto boxes = [&](const std::vector<int>& tris) {
    std::vector<Box> out;
    for (const int t : tris) {
      const Eigen::Vector3d p = corner(t, 0), q = corner(t, 1), r = corner(t, 2);
      out.push_back({p.cwiseMin(q).cwiseMin(r), p.cwiseMax(q).cwiseMax(r), t});
    }
    std::sort(out.begin(), out.end(), [](const Box& x, const Box& y) { return x.lo[0] < y.lo[0]; });
    return out;
  };
  const auto ba = boxes(touching(a)), bb = boxes(touching(b));
  std::size_t first = 0;
  for (const Box& x : ba) {
    while (first < bb.size() && bb[first].hi[0] < x.lo[0]) ++first;
    for (std::size_t j = first; j < bb.size() && bb[j].lo[0] <= x.hi[0]; ++j) {
      const Box& y = bb[j];
      if ((x.lo - y.hi).maxCoeff() > 0 || (y.lo - x.hi).maxCoeff() > 0) continue;
      if (x.t != y.t && !share(x.t, y.t) &&
          rig::triangles_intersect(corner(x.t, 0), corner(x.t, 1), corner(x.t, 2), corner(y.t, 0),
                                   corner(y.t, 1), corner(y.t, 2)))
        return true;
    }
  }
  return false;
}

std::vector<std::pair<int, int>> ReferenceCrossings::pairs(
    const std::string& name, const std::function<bool(int, int)>& ignore) const {
  const int k = reference_.find_shape(name);
  return k < 0 ? std::vector<std::pair<int, int>>{}
               : shape_pairs(reference_, k, ignore, static_cast<std::size_t>(-1)).pairs;
}

// The reference vertices within `rings_` rings of a built triangle's reference triangles, sorted.
std::vector<int> ReferenceCrossings::around(int built_triangle) const {
  std::vector<int> v;
  for (const int t : map_.sources[static_cast<std::size_t>(built_triangle)])
    for (int c = 0; c < 3; ++c) v.push_back(reference_.triangles(t, c));
  for (int r = 0; r < rings_; ++r) {
    const std::size_t n = v.size();
    for (std::size_t i = 0; i < n; ++i)
      for (const int u : adjacency_[static_cast<std::size_t>(v[i])]) v.push_back(u);
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
  }
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
  return v;
}

bool ReferenceCrossings::at(const std::vector<std::pair<int, int>>& pairs, int a, int b) const {
  if (pairs.empty()) return false;
  const auto va = around(a), vb = around(b);
  const auto touches = [&](int ref_triangle, const std::vector<int>& verts) {
    for (int c = 0; c < 3; ++c)
      if (std::binary_search(verts.begin(), verts.end(), reference_.triangles(ref_triangle, c)))
        return true;
    return false;
  };
  for (const auto& [x, y] : pairs)
    if ((touches(x, va) && touches(y, vb)) || (touches(x, vb) && touches(y, va))) return true;
  return false;
}

IntersectionSummary shape_intersections(const rig::Rig& built, const rig::Rig* reference,
                                        const TriangleMap& map, const IntersectionCheck& check) {
  const auto t0 = std::chrono::steady_clock::now();
  if (reference && map.sources.size() != static_cast<std::size_t>(built.triangle_count()))
    throw Error("shape_intersections: the triangle map does not fit the built rig");
  IntersectionSummary out;
  if (!check.region.empty() &&
      check.region.size() != static_cast<std::size_t>(built.triangle_count()))
    throw Error("shape_intersections: the region does not fit the built rig");
  std::function<bool(int, int)> built_ignore = group_filter(built, check.touching_groups);
  if (!check.region.empty())
    built_ignore = [groups = std::move(built_ignore), &region = check.region](int a, int b) {
      return !region[static_cast<std::size_t>(a)] || !region[static_cast<std::size_t>(b)] ||
             (groups && groups(a, b));
    };
  const auto ref_ignore =
      reference ? group_filter(*reference, check.touching_groups) : std::function<bool(int, int)>{};
  const auto neutral_pairs = shape_pairs(built, -1, built_ignore, static_cast<std::size_t>(-1));
  out.neutral = neutral_pairs.count;
  if (reference) out.reference_neutral = shape_pairs(*reference, -1, ref_ignore, 0).count;

  std::optional<ReferenceCrossings> sites;
  if (reference) sites.emplace(*reference, map, check.rings);
  // The part of each built triangle, by name, for the breakdown of new pairs.
  const bool by_group = !built.groups.empty() && !built.triangle_group.empty();
  const bool by_material = !by_group && built.materials.size() > 1;
  const auto part = [&](int t) -> const std::string& {
    return by_group ? built.groups[static_cast<std::size_t>(
                          built.triangle_group[static_cast<std::size_t>(t)])]
                    : built
                          .materials[static_cast<std::size_t>(
                              built.triangle_material[static_cast<std::size_t>(t)])]
                          .name;
  };

  const auto n = static_cast<int>(built.shapes.size());
  out.shapes.resize(static_cast<std::size_t>(n));
  parallel_for(n, [&](int k) {
    auto& r = out.shapes[static_cast<std::size_t>(k)];
    r.shape = built.shapes[static_cast<std::size_t>(k)].name;
    const auto got = shape_pairs(built, k, built_ignore, static_cast<std::size_t>(-1));
    r.total = got.count;
    const auto ref_pairs = sites ? sites->pairs(r.shape, ref_ignore) : decltype(got.pairs){};
    for (const auto& [a, b] : got.pairs) {
      if (std::binary_search(neutral_pairs.pairs.begin(), neutral_pairs.pairs.end(),
                             std::pair{a, b})) {
        ++r.in_neutral;
        continue;
      }
      const bool known = sites && sites->at(ref_pairs, a, b);
      if (known) {
        ++r.in_reference;
      } else {
        ++r.fresh;
        if (r.fresh_pairs.size() < 20) r.fresh_pairs.emplace_back(a, b);
        if (by_group || by_material) {
          const auto& x = part(a);
          const auto& y = part(b);
          ++r.fresh_by_parts[x < y ? x + "|" + y : y + "|" + x];
        }
      }
    }
  });
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace facecast::rigbuild
