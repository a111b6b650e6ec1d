// Triangle-mesh self-intersection: BVH over triangle boxes + Moller's triangle-triangle test.
#include "facecast/rig/intersections.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>

#include "facecast/core/error.hpp"

namespace facecast::rig {
namespace {

using V3 = Eigen::Vector3d;
using V2 = Eigen::Vector2d;

// ---- Moller's test ------------------------------------------------------------------------

// Interval of the line of intersection covered by a triangle: `a` is the vertex alone on its
// side of the other plane, b and c the other two.
void interval(double va, double vb, double vc, double da, double db, double dc, double& lo,
              double& hi) {
  const double t1 = va + (vb - va) * da / (da - db);
  const double t2 = va + (vc - va) * da / (da - dc);
  lo = std::min(t1, t2);
  hi = std::max(t1, t2);
}

// Returns false for the coplanar case (all distances zero).
bool compute_interval(const std::array<double, 3>& v, const std::array<double, 3>& d, double& lo,
                      double& hi) {
  if (d[0] * d[1] > 0) {
    interval(v[2], v[0], v[1], d[2], d[0], d[1], lo, hi);
  } else if (d[0] * d[2] > 0) {
    interval(v[1], v[0], v[2], d[1], d[0], d[2], lo, hi);
  } else if (d[1] * d[2] > 0 || d[0] != 0) {
    interval(v[0], v[1], v[2], d[0], d[1], d[2], lo, hi);
  } else if (d[1] != 0) {
    interval(v[1], v[0], v[2], d[1], d[0], d[2], lo, hi);
  } else if (d[2] != 0) {
    interval(v[2], v[0], v[1], d[2], d[0], d[1], lo, hi);
  } else {
    return false;
  }
  return true;
}

double orient2d(const V2& a, const V2& b, const V2& c) {
  return (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
}

bool segments_cross(const V2& a, const V2& b, const V2& c, const V2& d) {
  const double o1 = orient2d(a, b, c), o2 = orient2d(a, b, d);
  const double o3 = orient2d(c, d, a), o4 = orient2d(c, d, b);
  if (((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) && ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0)))
    return true;
  const auto on = [](const V2& p, const V2& q, const V2& r, double o) {  // r on segment pq
    return o == 0 && std::min(p.x(), q.x()) <= r.x() && r.x() <= std::max(p.x(), q.x()) &&
           std::min(p.y(), q.y()) <= r.y() && r.y() <= std::max(p.y(), q.y());
  };
  return on(a, b, c, o1) || on(a, b, d, o2) || on(c, d, a, o3) || on(c, d, b, o4);
}

bool inside(const V2& p, const std::array<V2, 3>& t) {
  const double a = orient2d(t[0], t[1], p), b = orient2d(t[1], t[2], p),
               c = orient2d(t[2], t[0], p);
  return (a >= 0 && b >= 0 && c >= 0) || (a <= 0 && b <= 0 && c <= 0);
}

bool coplanar_overlap(const V3& n, const std::array<V3, 3>& p, const std::array<V3, 3>& q) {
  int drop = 0;  // project away the normal's largest component
  n.cwiseAbs().maxCoeff(&drop);
  const int i0 = drop == 0 ? 1 : 0, i1 = drop == 2 ? 1 : 2;
  std::array<V2, 3> a, b;
  for (int k = 0; k < 3; ++k) {
    a[k] = V2(p[k][i0], p[k][i1]);
    b[k] = V2(q[k][i0], q[k][i1]);
  }
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (segments_cross(a[i], a[(i + 1) % 3], b[j], b[(j + 1) % 3])) return true;
  return inside(a[0], b) || inside(b[0], a);
}

std::array<double, 3> plane_distances(const V3& n, double nn, const V3& o,
                                      const std::array<V3, 3>& pts, double eps) {
  std::array<double, 3> d;
  for (int k = 0; k < 3; ++k) {
    d[k] = n.dot(pts[k] - o) / nn;
    if (std::abs(d[k]) <= eps) d[k] = 0;
  }
  return d;
}

bool same_side(const std::array<double, 3>& d) {
  return (d[0] > 0 && d[1] > 0 && d[2] > 0) || (d[0] < 0 && d[1] < 0 && d[2] < 0);
}

// ---- BVH ----------------------------------------------------------------------------------

struct Box {
  Eigen::Vector3f lo{1e30f, 1e30f, 1e30f}, hi{-1e30f, -1e30f, -1e30f};
  void grow(const Box& b) {
    lo = lo.cwiseMin(b.lo);
    hi = hi.cwiseMax(b.hi);
  }
  bool overlaps(const Box& b) const {
    return (lo.array() <= b.hi.array()).all() && (b.lo.array() <= hi.array()).all();
  }
};

struct Node {
  Box box;
  int left = -1, right = -1;  // children; -1 for a leaf
  int first = 0, count = 0;   // leaf range in `order`
};

class Bvh {
 public:
  /// Over the boxes listed in `subset` (all of them when it is empty).
  explicit Bvh(const std::vector<Box>& boxes, std::vector<int> subset = {})
      : boxes_(boxes), order_(std::move(subset)) {
    if (order_.empty()) {
      order_.resize(boxes.size());
      std::iota(order_.begin(), order_.end(), 0);
    }
    centres_.resize(boxes.size());
    for (const int i : order_)
      centres_[static_cast<std::size_t>(i)] =
          0.5f * (boxes[static_cast<std::size_t>(i)].lo + boxes[static_cast<std::size_t>(i)].hi);
    nodes_.reserve(2 * order_.size() / kLeaf + 2);
    if (!order_.empty()) build(0, static_cast<int>(order_.size()));
  }

  template <typename Visit>
  void query(const Box& b, Visit&& visit) const {
    if (nodes_.empty()) return;
    int stack[128];
    int top = 0;
    stack[top++] = 0;
    while (top) {
      const Node& n = nodes_[static_cast<std::size_t>(stack[--top])];
      if (!n.box.overlaps(b)) continue;
      if (n.left < 0) {
        for (int i = n.first; i < n.first + n.count; ++i) {
          const int t = order_[static_cast<std::size_t>(i)];
          if (boxes_[static_cast<std::size_t>(t)].overlaps(b)) visit(t);
        }
      } else {
        stack[top++] = n.left;
        stack[top++] = n.right;
      }
    }
  }

 private:
  static constexpr int kLeaf = 4;

  int build(int first, int count) {
    const int index = static_cast<int>(nodes_.size());
    nodes_.emplace_back();
    Box box, centre_box;
    for (int i = first; i < first + count; ++i) {
      const int t = order_[static_cast<std::size_t>(i)];
      box.grow(boxes_[static_cast<std::size_t>(t)]);
      centre_box.grow(
          {centres_[static_cast<std::size_t>(t)], centres_[static_cast<std::size_t>(t)]});
    }
    nodes_[static_cast<std::size_t>(index)].box = box;
    if (count <= kLeaf) {
      nodes_[static_cast<std::size_t>(index)].first = first;
      nodes_[static_cast<std::size_t>(index)].count = count;
      return index;
    }
    int axis = 0;
    (centre_box.hi - centre_box.lo).maxCoeff(&axis);
    const int mid = first + count / 2;
    std::nth_element(order_.begin() + first, order_.begin() + mid, order_.begin() + first + count,
                     [&](int a, int b) {
                       const float ca = centres_[static_cast<std::size_t>(a)][axis];
                       const float cb = centres_[static_cast<std::size_t>(b)][axis];
                       return ca < cb || (ca == cb && a < b);
                     });
    const int left = build(first, mid - first);
    const int right = build(mid, first + count - mid);
    nodes_[static_cast<std::size_t>(index)].left = left;
    nodes_[static_cast<std::size_t>(index)].right = right;
    return index;
  }

  const std::vector<Box>& boxes_;
  std::vector<int> order_;
  std::vector<Eigen::Vector3f> centres_;
  std::vector<Node> nodes_;
};

}  // namespace

bool triangles_intersect(const V3& p0, const V3& p1, const V3& p2, const V3& q0, const V3& q1,
                         const V3& q2, double epsilon) {
  const std::array<V3, 3> p{p0, p1, p2}, q{q0, q1, q2};
  const V3 n2 = (q1 - q0).cross(q2 - q0);
  const double nn2 = n2.norm();
  const V3 n1 = (p1 - p0).cross(p2 - p0);
  const double nn1 = n1.norm();
  if (nn1 == 0 || nn2 == 0) return false;  // degenerate
  const auto dp = plane_distances(n2, nn2, q0, p, epsilon);
  if (same_side(dp)) return false;
  const auto dq = plane_distances(n1, nn1, p0, q, epsilon);
  if (same_side(dq)) return false;
  const V3 dir = n1.cross(n2);
  int axis = 0;
  dir.cwiseAbs().maxCoeff(&axis);
  const std::array<double, 3> vp{p0[axis], p1[axis], p2[axis]};
  const std::array<double, 3> vq{q0[axis], q1[axis], q2[axis]};
  double a0, a1, b0, b1;
  if (!compute_interval(vp, dp, a0, a1) || !compute_interval(vq, dq, b0, b1)) {
    return coplanar_overlap(n1, p, q);
  }
  return !(a1 < b0 || b1 < a0);
}

IntersectionReport find_intersections(const Positions& positions, const Triangles& triangles,
                                      const IntersectionOptions& options) {
  const int nf = static_cast<int>(triangles.rows());
  const int nv = static_cast<int>(positions.rows());
  std::vector<Box> boxes(static_cast<std::size_t>(nf));
  const float pad = static_cast<float>(options.epsilon);
  for (int f = 0; f < nf; ++f) {
    Box b;
    for (int c = 0; c < 3; ++c) {
      const int v = triangles(f, c);
      if (v < 0 || v >= nv)
        throw Error("find_intersections: triangle " + std::to_string(f) + " has vertex index " +
                    std::to_string(v) + " out of range");
      const Eigen::Vector3f p = positions.row(v).transpose();
      b.grow({p, p});
    }
    b.lo.array() -= pad;
    b.hi.array() += pad;
    boxes[static_cast<std::size_t>(f)] = b;
  }
  IntersectionReport report;
  std::vector<int> hits;
  const bool subset = !options.active.empty();
  if (subset && options.active.size() != static_cast<std::size_t>(nf))
    throw Error("find_intersections: 'active' has " + std::to_string(options.active.size()) +
                " flags for " + std::to_string(nf) + " triangles");
  // With active triangles, only boxes that meet the active triangles' bounds can take part.
  std::vector<int> near;
  if (subset) {
    Box bounds;
    bool any = false;
    for (int f = 0; f < nf; ++f)
      if (options.active[static_cast<std::size_t>(f)]) {
        bounds.grow(boxes[static_cast<std::size_t>(f)]);
        any = true;
      }
    if (!any) return report;
    for (int f = 0; f < nf; ++f)
      if (boxes[static_cast<std::size_t>(f)].overlaps(bounds)) near.push_back(f);
  }
  const Bvh bvh(boxes, std::move(near));
  for (int f = 0; f < nf; ++f) {
    if (subset && !options.active[static_cast<std::size_t>(f)]) continue;
    const Eigen::Vector3i tf = triangles.row(f).transpose();
    const V3 p0 = positions.row(tf[0]).transpose().cast<double>();
    const V3 p1 = positions.row(tf[1]).transpose().cast<double>();
    const V3 p2 = positions.row(tf[2]).transpose().cast<double>();
    hits.clear();
    // Each pair once: from its lower triangle, or from its only active one.
    bvh.query(boxes[static_cast<std::size_t>(f)], [&](int g) {
      if (g > f || (subset && g < f && !options.active[static_cast<std::size_t>(g)]))
        hits.push_back(g);
    });
    std::sort(hits.begin(), hits.end());
    for (int g : hits) {
      const Eigen::Vector3i tg = triangles.row(g).transpose();
      bool shared = false;
      for (int i = 0; i < 3 && !shared; ++i)
        for (int j = 0; j < 3; ++j)
          if (tf[i] == tg[j]) shared = true;
      if (shared) continue;
      if (options.ignore && options.ignore(f, g)) continue;
      if (triangles_intersect(p0, p1, p2, positions.row(tg[0]).transpose().cast<double>(),
                              positions.row(tg[1]).transpose().cast<double>(),
                              positions.row(tg[2]).transpose().cast<double>(), options.epsilon)) {
        ++report.count;
        if (report.pairs.size() < options.max_listed)
          report.pairs.emplace_back(std::min(f, g), std::max(f, g));
      }
    }
  }
  std::sort(report.pairs.begin(), report.pairs.end());
  return report;
}

std::vector<std::pair<int, int>> near_triangle_pairs(const Positions& positions,
                                                     const Triangles& triangles, double margin,
                                                     const std::vector<char>& from,
                                                     const std::function<bool(int, int)>& wanted) {
  const int nf = static_cast<int>(triangles.rows());
  std::vector<Box> boxes(static_cast<std::size_t>(nf));
  const float pad = static_cast<float>(0.5 * margin);
  for (int f = 0; f < nf; ++f) {
    Box& b = boxes[static_cast<std::size_t>(f)];
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector3f p = positions.row(triangles(f, c)).transpose();
      b.grow({p, p});
    }
    b.lo.array() -= pad;
    b.hi.array() += pad;
  }
  const Bvh bvh(boxes);
  std::vector<std::pair<int, int>> out;
  const auto queried = [&](int f) { return from.empty() || from[static_cast<std::size_t>(f)]; };
  for (int f = 0; f < nf; ++f) {
    if (!queried(f)) continue;
    bvh.query(boxes[static_cast<std::size_t>(f)], [&](int g) {
      if (g == f || (g < f && queried(g))) return;  // each pair once
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          if (triangles(f, i) == triangles(g, j)) return;
      const int a = std::min(f, g), b = std::max(f, g);
      if (!wanted || wanted(a, b)) out.emplace_back(a, b);
    });
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::function<bool(int, int)> ignore_between_groups(
    const Rig& rig, const std::vector<std::pair<std::string, std::string>>& group_pairs) {
  const auto index_of = [&rig](const std::string& name) {
    const auto it = std::find(rig.groups.begin(), rig.groups.end(), name);
    if (it == rig.groups.end())
      throw Error("ignore_between_groups: rig has no group " + name, ErrorCode::kNotFound);
    return static_cast<int>(it - rig.groups.begin());
  };
  std::vector<std::pair<int, int>> ids;
  for (const auto& [a, b] : group_pairs) ids.emplace_back(index_of(a), index_of(b));
  std::vector<int> group = rig.triangle_group;
  return [group = std::move(group), ids = std::move(ids)](int a, int b) {
    if (a < 0 || b < 0 || static_cast<std::size_t>(std::max(a, b)) >= group.size()) return false;
    const int ga = group[static_cast<std::size_t>(a)], gb = group[static_cast<std::size_t>(b)];
    for (const auto& [x, y] : ids)
      if ((ga == x && gb == y) || (ga == y && gb == x)) return true;
    return false;
  };
}

}  // namespace facecast::rig
