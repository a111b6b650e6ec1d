#pragma once
// The rig builder's geometric toolbox, private to rigbuild: closest points on a mesh (on a
// triangle: rig::closest_on_triangle), a point carried by a triangle, k-d trees over points, a
// mesh's parts, the target mesh a build computes once. The least-squares fit of point sets
// (procrustes) is public: facecast/rigbuild/geometry.hpp.
#include <Eigen/Core>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <nanoflann.hpp>
#include <string>
#include <utility>
#include <vector>

#include "facecast/rig/rig.hpp"
#include "facecast/rigbuild/geometry.hpp"
#include "mesh_graph.hpp"

namespace facecast::rigbuild {

using rig::centroids;
using rig::closest_on_triangle;
using rig::diagonal;
using rig::face_normals;

/// Whether row k of `p` holds a point: a NaN row marks one that is not there (a dropped landmark).
inline bool has_point(const Points& p, int k) {
  return std::isfinite(p(k, 0));
}

/// Where `point` goes when it moves with the triangle with corners t from `rest` to `now` as it
/// sat on it at rest: its closest point on the triangle follows the triangle, its offset from
/// there turns with the triangle's frame (first edge, in-plane, normal).
Eigen::RowVector3d carried(const Points& rest, const Points& now, const Eigen::RowVector3d& point,
                           const std::array<int, 3>& t);

/// Per vertex: on the silhouette seen from `towards`: a vertex of a triangle facing that way and
/// of one facing away. Only the triangles `keep` selects count (all when it is empty).
std::vector<char> silhouette(const rig::Positions& p, const Triangles& tris,
                             const Eigen::Vector3d& towards, const std::vector<char>& keep = {});

/// Rows of a #N by 3 matrix as a nanoflann point cloud.
struct PointRows {
  const Points& p;
  std::size_t kdtree_get_point_count() const { return static_cast<std::size_t>(p.rows()); }
  double kdtree_get_pt(std::size_t i, std::size_t dim) const {
    return p(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(dim));
  }
  template <class B>
  bool kdtree_get_bbox(B&) const {
    return false;
  }
};
using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, PointRows>,
                                                   PointRows, 3, std::uint32_t>;

/// Owns the points and the tree built over them.
class PointIndex {
 public:
  explicit PointIndex(Points points)
      : points_(std::move(points)),
        rows_{points_},
        tree_(3, rows_, nanoflann::KDTreeSingleIndexAdaptorParams(16)) {
    tree_.buildIndex();
  }
  PointIndex(const PointIndex&) = delete;
  PointIndex& operator=(const PointIndex&) = delete;
  const Points& points() const { return points_; }
  /// The k nearest points (indices, squared distances), nearest first.
  void nearest(const double* q, std::size_t k, std::vector<std::uint32_t>& idx,
               std::vector<double>& d2) const {
    k = std::min<std::size_t>(k, static_cast<std::size_t>(points_.rows()));
    idx.resize(k);
    d2.resize(k);
    const std::size_t found = tree_.knnSearch(q, k, idx.data(), d2.data());
    idx.resize(found);
    d2.resize(found);
  }
  /// All points within `radius` (squared distances), sorted if asked.
  void within(const double* q, double radius, std::vector<std::pair<std::uint32_t, double>>& hits,
              bool sorted) const {
    hits.clear();
    tree_.radiusSearch(q, radius * radius, hits, nanoflann::SearchParams(32, 0.0f, sorted));
  }

 private:
  Points points_;
  PointRows rows_;
  KdTree tree_;
};

/// Closest points on a mesh, or on some of its triangles: a k-d tree over the triangles'
/// centroids, then the exact closest point on each of the nearest few.
class SurfaceQuery {
 public:
  /// Over every triangle of (p, f), or only over `triangles` when given. Keeps references to p
  /// and f.
  SurfaceQuery(const Points& p, const Triangles& f, std::vector<int> triangles = {});

  struct Hit {
    int triangle = -1;  // -1: none found
    Eigen::Vector3d bary = Eigen::Vector3d::Zero();
    Eigen::Vector3d point = Eigen::Vector3d::Zero();
    double dist = std::numeric_limits<double>::infinity();
    bool on_boundary = false;  // on an edge that only one of the triangles has
  };

  /// The closest point among the triangles with the k nearest centroids that `accept(triangle)`
  /// allows and whose normal is within 90 degrees of `normal` (a zero normal accepts every
  /// direction). When none qualifies, the search widens (4k, 16k, ...) before it gives up.
  template <typename Accept>
  Hit closest(const Eigen::Vector3d& q, const Eigen::Vector3d& normal, std::size_t k,
              const Accept& accept) const {
    thread_local std::vector<std::uint32_t> idx;
    thread_local std::vector<double> d2;
    Hit best;
    const std::size_t all = static_cast<std::size_t>(centroids_.points().rows());
    for (; best.triangle < 0; k *= 4) {
      centroids_.nearest(q.data(), std::min(k, all), idx, d2);
      for (const std::uint32_t i : idx) {
        const int t = triangles_.empty() ? static_cast<int>(i) : triangles_[i];
        if (!accept(t)) continue;
        if (normal.squaredNorm() > 0 && normals_.row(i).dot(normal.transpose()) <= 0.0) continue;
        consider(q, t, best);
      }
      if (k >= all) break;
    }
    if (best.triangle >= 0) best.on_boundary = on_boundary(best);
    return best;
  }
  Hit closest(const Eigen::Vector3d& q, const Eigen::Vector3d& normal, std::size_t k) const {
    return closest(q, normal, k, [](int) { return true; });
  }

 private:
  void consider(const Eigen::Vector3d& q, int triangle, Hit& best) const;
  bool on_boundary(const Hit& hit) const;
  const Points& p_;
  const Triangles& f_;
  std::vector<int> triangles_;  // the triangle of each centroid; empty: all, in order
  PointIndex centroids_;
  Points normals_;                             // per centroid, its triangle's unit normal
  std::vector<std::pair<int, int>> boundary_;  // edges (low, high) of one triangle, sorted
};

/// A mesh's connected components and their vertices; the skin is the largest
/// (rig::Components::largest), the others are parts: teeth, eyeballs, lashes, a tongue.
struct MeshParts {
  MeshParts(int vertex_count, const Triangles& faces);
  rig::Components components;             // per vertex its component, -1 in no triangle
  std::vector<std::vector<int>> members;  // per component its vertices, ascending
  int skin = 0;                           // rig::Components::largest
  int of(int vertex) const { return components.label[static_cast<std::size_t>(vertex)]; }
};

/// The target neutral with what the stages read of its mesh, computed once per build: its parts
/// and its edge graph. Keeps references to the positions and faces.
struct TargetMesh {
  TargetMesh(const Points& positions, const Triangles& triangles)
      : rest(positions),
        faces(triangles),
        parts(static_cast<int>(positions.rows()), triangles),
        graph(positions, triangles) {}
  const Points& rest;      // #V by 3
  const Triangles& faces;  // #F by 3
  MeshParts parts;
  MeshGraph graph;
};

/// Throws naming `what` when `components` are not of a mesh with `vertex_count` vertices (a
/// caller's precomputed rig::connected_components).
void check_components(const rig::Components& components, int vertex_count, const std::string& what);

/// The median of `v` (the mean of the middle two for an even count); `v` must not be empty.
double median(std::vector<double> v);

/// The distance from `p` to the segment from `a` to `b`.
double segment_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                        const Eigen::Vector3d& b);

}  // namespace facecast::rigbuild
