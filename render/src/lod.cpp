// The renderer's level of detail (RenderOptions::lod_pixels). llvmpipe shades whole 4x4 pixel
// blocks per triangle, so a face of 50k triangles that cover 2-4 pixels each costs it several
// times the shading of its pixels. Each material's triangles are simplified by meshoptimizer's
// edge collapses within the error of the neutral (borders locked: mesh boundaries, UV seams, lip
// and eyelid edges keep every vertex). The neutral's error does not see the shapes (a flat patch
// that a shape folds, a collapse across the mouth's corner that tears when the jaw opens), so:
// - vertices that a shape bends by more than kBendShare errors are kept, and
// - every removed vertex is checked where it stands on the simplified surface (the nearest
//   simplified triangle in the neutral), in the neutral and in every shape at weight 1: farther
//   than kShapeSlack errors, or with a normal that differs by more than kNormalTolerance (a fold's
//   shading), it is kept and the range simplified again, until none is.
// A kept vertex is locked alone, its neighbours still collapse onto it: meshoptimizer 0.18 locks a
// position that more vertices share than a seam's pair, so each kept vertex gets an unused copy.
// (Keeping its triangles instead left 35 % more triangles at the same tolerances: every kept
// vertex's ring became a locked border for the simplifier.)
// A deformation-sensitive decimation (after Mohr and Gleicher 2003), checked after the collapses
// rather than built into their cost (meshoptimizer 0.18 takes positions only).
#include <meshoptimizer.h>

#include <algorithm>
#include <array>
#include <limits>
#include <set>
#include <span>
#include <utility>

#include "facecast/rig/rig.hpp"
#include "gpu_rig.hpp"

namespace facecast::render::detail {
namespace {

constexpr double kBendShare = 2.0;        // bending that keeps a vertex, in errors
constexpr double kShapeSlack = 4.0;       // a removed vertex's distance in a shape, in errors
constexpr double kNormalTolerance = 0.5;  // |n - n'| of unit normals (about 29 degrees)
constexpr int kMaxRounds = 12;            // then the range is drawn in full
constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

// Per vertex, the triangles (offsets of their first index) that use it.
class Incidence {
 public:
  Incidence(std::span<const std::uint32_t> indices, std::size_t vertex_count)
      : start_(vertex_count + 1, 0), triangles_(indices.size()) {
    for (std::uint32_t v : indices) ++start_[v + 1];
    for (std::size_t v = 0; v < vertex_count; ++v) start_[v + 1] += start_[v];
    std::vector<std::uint32_t> next(start_.begin(), start_.end() - 1);
    for (std::size_t i = 0; i < indices.size(); ++i)
      triangles_[next[indices[i]]++] = static_cast<std::uint32_t>(i - i % 3);
  }
  std::span<const std::uint32_t> of(std::uint32_t v) const {
    return {triangles_.data() + start_[v], start_[v + 1] - start_[v]};
  }

 private:
  std::vector<std::uint32_t> start_, triangles_;
};

using Vector6d = Eigen::Matrix<double, 6, 1>;  // position, normal

// Per vertex, the shapes that move it and how (the morphs turned around).
struct ShapeDeltas {
  std::vector<std::uint32_t> start;
  std::vector<std::pair<std::uint32_t, Vector6d>> entries;  // shape, position and normal delta

  ShapeDeltas(const PackedRig& p, std::size_t vertex_count) : start(vertex_count + 1, 0) {
    for (const PackedMorph& m : p.morphs)
      for (std::uint32_t v : m.vertices) ++start[v + 1];
    for (std::size_t v = 0; v < vertex_count; ++v) start[v + 1] += start[v];
    entries.resize(start.back());
    std::vector<std::uint32_t> next(start.begin(), start.end() - 1);
    for (std::size_t s = 0; s < p.morphs.size(); ++s) {
      const PackedMorph& m = p.morphs[s];
      for (std::size_t i = 0; i < m.vertices.size(); ++i)
        entries[next[m.vertices[i]]++] = {
            static_cast<std::uint32_t>(s),
            Eigen::Matrix<float, 6, 1>::Map(&m.deltas[i * kBlendedStride]).cast<double>()};
    }
  }
  std::span<const std::pair<std::uint32_t, Vector6d>> of(std::uint32_t v) const {
    return {entries.data() + start[v], start[v + 1] - start[v]};
  }
};

Vector6d neutral(const PackedRig& p, std::uint32_t v) {
  return Eigen::Matrix<float, 6, 1>::Map(&p.neutral[v * kBlendedStride]).cast<double>();
}

// How far a removed vertex is from the simplified surface: the distance from its closest point on
// the triangle standing in for it (sliding along the surface is not counted: the texture moves
// with the triangles either way), and the difference of the unit normals there.
struct Deviation {
  double distance = 0, normal = 0;
};

// The largest deviation of removed vertex v from the triangle with corners c, over the neutral
// and each shape at weight 1. `moved` (four zero deltas per shape) and `touched` are scratch.
Deviation deviation(const PackedRig& p, const ShapeDeltas& deltas, std::uint32_t v,
                    const std::uint32_t* c, std::vector<std::array<Vector6d, 4>>& moved,
                    std::vector<std::uint32_t>& touched) {
  const std::array<std::uint32_t, 4> at{c[0], c[1], c[2], v};
  std::array<Vector6d, 4> rest;
  for (std::size_t k = 0; k < 4; ++k) {
    rest[k] = neutral(p, at[k]);
    for (const auto& [s, d] : deltas.of(at[k])) {
      if (std::find(touched.begin(), touched.end(), s) == touched.end()) touched.push_back(s);
      moved[s][k] = d;
    }
  }
  Deviation worst;
  const auto measure = [&](const std::array<Vector6d, 4>& x) {
    const Eigen::Vector3d w =
        rig::closest_on_triangle(x[3].head<3>(), x[0].head<3>(), x[1].head<3>(), x[2].head<3>());
    const Vector6d on = w[0] * x[0] + w[1] * x[1] + w[2] * x[2];
    worst.distance = std::max(worst.distance, (x[3].head<3>() - on.head<3>()).norm());
    worst.normal =
        std::max(worst.normal, (x[3].tail<3>().normalized() - on.tail<3>().normalized()).norm());
  };
  measure(rest);
  for (std::uint32_t s : touched) {
    std::array<Vector6d, 4> x = rest;
    for (std::size_t k = 0; k < 4; ++k) {
      x[k] += moved[s][k];
      moved[s][k].setZero();
    }
    measure(x);
  }
  touched.clear();
  return worst;
}

// Per vertex, the largest bending any shape gives it: |delta(v) - mean of delta over v's
// neighbours| (the umbrella Laplacian of the shape's displacement). A rigid or smooth move has
// none; where a shape folds the surface (lip corners, lids, the jaw's edge) a coarser mesh cannot
// follow it.
std::vector<double> bending(const PackedRig& p, std::size_t nv) {
  std::vector<double> out(nv, 0.0), count(nv, 0.0);
  std::vector<Eigen::Vector3d> sum(nv, Eigen::Vector3d::Zero()), d = sum;
  const auto edges = [&](auto&& f) {
    for (const PackedRig::Range& r : p.ranges)
      for (std::size_t i = r.first; i < r.first + r.count; i += 3)
        for (std::size_t k = 0; k < 3; ++k) f(p.indices[i + k], p.indices[i + (k + 1) % 3]);
  };
  edges([&](std::uint32_t a, std::uint32_t b) { ++count[a], ++count[b]; });
  for (const PackedMorph& m : p.morphs) {
    for (std::size_t i = 0; i < m.vertices.size(); ++i)
      d[m.vertices[i]] = Eigen::Vector3f::Map(&m.deltas[i * kBlendedStride]).cast<double>();
    edges([&](std::uint32_t a, std::uint32_t b) { sum[a] += d[b], sum[b] += d[a]; });
    for (std::size_t v = 0; v < nv; ++v) {
      if (count[v] > 0) out[v] = std::max(out[v], (d[v] - sum[v] / count[v]).norm());
      sum[v].setZero();
    }
    for (std::uint32_t v : m.vertices) d[v].setZero();
  }
  return out;
}

std::array<std::uint32_t, 3> sorted(const std::uint32_t* t) {
  std::array<std::uint32_t, 3> a{t[0], t[1], t[2]};
  std::sort(a.begin(), a.end());
  return a;
}

// The simplified triangles (`out`) around their vertices, and the nearest of them to a removed
// vertex in the neutral.
class Coarse {
 public:
  Coarse(const std::vector<std::uint32_t>& out, std::size_t nv)
      : out_(out), incidence_(out, nv), seen_(out.size() / 3, 0) {}
  bool uses(std::uint32_t v) const { return !incidence_.of(v).empty(); }
  // Among the triangles around `survivor` and around their corners (each once).
  const std::uint32_t* nearest(const PackedRig& p, std::uint32_t v, std::uint32_t survivor) {
    const Eigen::Vector3d x = neutral(p, v).head<3>();
    double best = std::numeric_limits<double>::infinity();
    const std::uint32_t* corners = nullptr;
    ++stamp_;
    for (std::uint32_t t0 : incidence_.of(survivor))
      for (std::size_t k = 0; k < 3; ++k)
        for (std::uint32_t t : incidence_.of(out_[t0 + k])) {
          if (std::exchange(seen_[t / 3], stamp_) == stamp_) continue;
          const std::uint32_t* c = &out_[t];
          const Eigen::Vector3d a = neutral(p, c[0]).head<3>(), b = neutral(p, c[1]).head<3>(),
                                e = neutral(p, c[2]).head<3>();
          const Eigen::Vector3d w = rig::closest_on_triangle(x, a, b, e);
          const double dist = (x - (w[0] * a + w[1] * b + w[2] * e)).squaredNorm();
          if (dist < best) best = dist, corners = c;
        }
    return corners;
  }

 private:
  const std::vector<std::uint32_t>& out_;
  Incidence incidence_;
  std::vector<std::uint32_t> seen_;  // per triangle: the stamp of the last search that saw it
  std::uint32_t stamp_ = 0;
};

// One material's triangles simplified (into `out`); `keep` (per vertex: keeps its triangles) is
// extended by the check.
void simplify_range(const PackedRig& p, std::span<const std::uint32_t> triangles,
                    const ShapeDeltas& deltas, float max_error, std::vector<char>& keep,
                    std::vector<std::uint32_t>& out) {
  const std::size_t nv = p.neutral.size() / kBlendedStride;
  const Incidence full(triangles, nv);
  std::vector<std::uint32_t> members(triangles.begin(), triangles.end());
  std::sort(members.begin(), members.end());
  members.erase(std::unique(members.begin(), members.end()), members.end());
  // meshoptimizer works on the range's own vertices (its tables are per vertex), then the copies
  // that lock the kept ones.
  std::vector<std::uint32_t> local(nv, kNone);
  std::vector<float> positions;
  for (std::uint32_t v : members) {
    local[v] = static_cast<std::uint32_t>(positions.size() / 3);
    positions.insert(positions.end(), &p.neutral[v * kBlendedStride],
                     &p.neutral[v * kBlendedStride] + 3);
  }
  const std::size_t own = positions.size();
  const float scale = meshopt_simplifyScale(positions.data(), members.size(), 3 * sizeof(float));
  std::vector<std::uint32_t> local_triangles(triangles.size());
  for (std::size_t i = 0; i < triangles.size(); ++i) local_triangles[i] = local[triangles[i]];
  std::vector<std::uint32_t> simplified, survivor(nv), queue, touched;
  // Per vertex, the simplified triangle it last stood on within the tolerances (its corners,
  // sorted): while that triangle is still there the vertex is not checked again.
  std::vector<std::array<std::uint32_t, 3>> passed(nv, {kNone, kNone, kNone});
  std::set<std::array<std::uint32_t, 3>> present;
  std::vector<std::array<Vector6d, 4>> moved(p.morphs.size());
  for (auto& m : moved) m.fill(Vector6d::Zero());
  for (int round = 0; round < kMaxRounds; ++round) {
    positions.resize(own);
    for (std::uint32_t v : members)
      if (keep[v]) {
        const std::array<float, 3> at{positions[3 * local[v]], positions[3 * local[v] + 1],
                                      positions[3 * local[v] + 2]};
        positions.insert(positions.end(), at.begin(), at.end());
      }
    // The error is relative to the vertices' extent; no target count: as far as the error allows.
    simplified.resize(local_triangles.size());
    simplified.resize(meshopt_simplify(simplified.data(), local_triangles.data(),
                                       local_triangles.size(), positions.data(),
                                       positions.size() / 3, 3 * sizeof(float), 0,
                                       max_error / scale, meshopt_SimplifyLockBorder, nullptr));
    out.clear();
    for (std::uint32_t v : simplified) out.push_back(members[v]);
    Coarse coarse(out, nv);
    present.clear();
    for (std::size_t i = 0; i < out.size(); i += 3) present.insert(sorted(&out[i]));
    // Each removed vertex's survivor: the nearest vertex still used (in edges), breadth first.
    std::fill(survivor.begin(), survivor.end(), kNone);
    queue.clear();
    for (std::uint32_t v : members)
      if (coarse.uses(v)) survivor[v] = v, queue.push_back(v);
    for (std::size_t head = 0; head < queue.size(); ++head)
      for (std::uint32_t t : full.of(queue[head]))
        for (std::size_t k = 0; k < 3; ++k)
          if (const std::uint32_t c = triangles[t + k]; survivor[c] == kNone) {
            survivor[c] = survivor[queue[head]];
            queue.push_back(c);
          }
    bool grew = false, locks_failed = false;
    for (std::uint32_t v : members) {
      if (survivor[v] == v) continue;
      if (keep[v]) {  // the lock did not hold (not meshoptimizer 0.18's rule): drawn in full
        locks_failed = true;
        break;
      }
      if (present.count(passed[v])) continue;
      bool bad = survivor[v] == kNone;  // a part collapsed away
      if (!bad) {
        const std::uint32_t* c = coarse.nearest(p, v, survivor[v]);
        const Deviation e = deviation(p, deltas, v, c, moved, touched);
        bad = e.distance > kShapeSlack * max_error || e.normal > kNormalTolerance;
        passed[v] = sorted(c);
      }
      if (bad) keep[v] = 1, grew = true;
    }
    if (locks_failed) break;
    if (!grew) return;
  }
  out.assign(triangles.begin(), triangles.end());
}

}  // namespace

void add_lod(PackedRig& p, float max_error) {
  const std::size_t nv = p.neutral.size() / kBlendedStride;
  if (!(max_error > 0)) return;
  const ShapeDeltas deltas(p, nv);
  std::vector<char> keep(nv, 0);
  const std::vector<double> bent = bending(p, nv);
  for (std::size_t v = 0; v < nv; ++v) keep[v] = bent[v] > kBendShare * max_error;
  p.lod_ranges.clear();
  std::vector<std::uint32_t> simplified;
  for (std::size_t i = 0, n = p.ranges.size(); i < n; ++i) {
    PackedRig::Range lod = p.ranges[i];
    simplify_range(p, {p.indices.data() + lod.first, lod.count}, deltas, max_error, keep,
                   simplified);
    lod.first = p.indices.size();
    lod.count = simplified.size();
    p.indices.insert(p.indices.end(), simplified.begin(), simplified.end());
    p.lod_ranges.push_back(lod);
  }
  p.lod_error = max_error;
}

}  // namespace facecast::render::detail
