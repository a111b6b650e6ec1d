#include "facecast/rigbuild/quality.hpp"

#include <algorithm>
#include <chrono>

#include "facecast/anim/intersections.hpp"
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

std::vector<ShapeError> truth_errors(const anim::Rig& built, const anim::Positions& truth_neutral,
                                     const anim::Rig& truth_deltas, int first, int last) {
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
    const anim::Positions got = built.positions + s.dense(nv);
    const anim::Positions want =
        truth_neutral + truth_deltas.shapes[static_cast<std::size_t>(ti)].dense(nv);
    err.clear();
    for (int v = first; v < last; ++v) err.push_back((got.row(v) - want.row(v)).norm());
    out.push_back(stats(s.name, err, diag));
  }
  return out;
}

std::vector<ShapeError> truth_errors(const anim::Rig& built,
                                     const std::vector<anim::Positions>& truth) {
  const int nv = built.vertex_count();
  const double diag =
      (built.positions.colwise().maxCoeff() - built.positions.colwise().minCoeff()).norm();
  std::vector<ShapeError> out;
  std::vector<double> err;
  for (std::size_t k = 0; k < built.shapes.size() && k < truth.size(); ++k) {
    if (truth[k].rows() != nv)
      throw Error("truth shape '" + built.shapes[k].name + "': vertex count differs");
    const anim::Positions got = built.positions + built.shapes[k].dense(nv);
    err.clear();
    for (int v = 0; v < nv; ++v) err.push_back((got.row(v) - truth[k].row(v)).norm());
    out.push_back(stats(built.shapes[k].name, err, diag));
  }
  return out;
}

namespace {

// Intersecting pairs of `rig`'s shape `k` (or the neutral for k < 0) that involve a moved triangle.
anim::IntersectionReport shape_pairs(const anim::Rig& rig, int k,
                                     const std::function<bool(int, int)>& ignore,
                                     std::size_t max_listed) {
  anim::IntersectionOptions opt;
  opt.ignore = ignore;
  opt.max_listed = max_listed;
  if (k < 0) return anim::find_intersections(rig.positions, rig.triangles, opt);
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
  return anim::find_intersections(rig.positions + shape.dense(rig.vertex_count()), rig.triangles,
                                  opt);
}

std::function<bool(int, int)> group_filter(
    const anim::Rig& rig, const std::vector<std::pair<std::string, std::string>>& groups) {
  std::vector<std::pair<std::string, std::string>> present;
  for (const auto& [a, b] : groups)
    if (std::count(rig.groups.begin(), rig.groups.end(), a) &&
        std::count(rig.groups.begin(), rig.groups.end(), b))
      present.emplace_back(a, b);
  return present.empty() ? std::function<bool(int, int)>{}
                         : anim::ignore_between_groups(rig, present);
}

}  // namespace

IntersectionSummary shape_intersections(const anim::Rig& built, const anim::Rig* reference,
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

  // Reference triangles -> the vertices within `rings` rings of them.
  std::vector<std::vector<int>> adjacency;
  if (reference) {
    adjacency.resize(static_cast<std::size_t>(reference->vertex_count()));
    for (int t = 0; t < reference->triangle_count(); ++t)
      for (int c = 0; c < 3; ++c)
        adjacency[static_cast<std::size_t>(reference->triangles(t, c))].push_back(
            reference->triangles(t, (c + 1) % 3));
  }
  const auto verts_of = [&](const std::vector<int>& tris) {
    std::vector<int> v;
    for (const int t : tris)
      for (int c = 0; c < 3; ++c) v.push_back(reference->triangles(t, c));
    for (int r = 0; r < check.rings; ++r) {
      const std::size_t n = v.size();
      for (std::size_t i = 0; i < n; ++i)
        for (const int u : adjacency[static_cast<std::size_t>(v[i])]) v.push_back(u);
      std::sort(v.begin(), v.end());
      v.erase(std::unique(v.begin(), v.end()), v.end());
    }
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
    return v;
  };
  const auto touches = [&](int ref_triangle, const std::vector<int>& verts) {
    for (int c = 0; c < 3; ++c)
      if (std::binary_search(verts.begin(), verts.end(), reference->triangles(ref_triangle, c)))
        return true;
    return false;
  };

  const auto n = static_cast<int>(built.shapes.size());
  out.shapes.resize(static_cast<std::size_t>(n));
  parallel_for(n, [&](int k) {
    auto& r = out.shapes[static_cast<std::size_t>(k)];
    r.shape = built.shapes[static_cast<std::size_t>(k)].name;
    const auto got = shape_pairs(built, k, built_ignore, static_cast<std::size_t>(-1));
    r.total = got.count;
    std::vector<std::pair<int, int>> ref_pairs;
    if (reference) {
      if (const int rk = reference->find_shape(r.shape); rk >= 0)
        ref_pairs = shape_pairs(*reference, rk, ref_ignore, static_cast<std::size_t>(-1)).pairs;
    }
    for (const auto& [a, b] : got.pairs) {
      if (std::binary_search(neutral_pairs.pairs.begin(), neutral_pairs.pairs.end(),
                             std::pair{a, b})) {
        ++r.in_neutral;
        continue;
      }
      bool known = false;
      if (!ref_pairs.empty()) {
        const auto va = verts_of(map.sources[static_cast<std::size_t>(a)]);
        const auto vb = verts_of(map.sources[static_cast<std::size_t>(b)]);
        for (const auto& [x, y] : ref_pairs)
          if ((touches(x, va) && touches(y, vb)) || (touches(x, vb) && touches(y, va))) {
            known = true;
            break;
          }
      }
      if (known) {
        ++r.in_reference;
      } else {
        ++r.fresh;
        if (r.fresh_pairs.size() < 20) r.fresh_pairs.emplace_back(a, b);
      }
    }
  });
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace facecast::rigbuild
