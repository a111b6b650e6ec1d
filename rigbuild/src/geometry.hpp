#pragma once
// Small geometric helpers private to rigbuild: closest point on a triangle, a point carried by a
// triangle, k-d trees over points.
#include <Eigen/Core>
#include <array>
#include <nanoflann.hpp>

#include "facecast/rigbuild/transfer.hpp"

namespace facecast::rigbuild {

/// Closest point to p on triangle (a, b, c) (Ericson, Real-Time Collision Detection 5.1.5);
/// returns barycentric weights of a, b, c.
Eigen::Vector3d closest_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                    const Eigen::Vector3d& b, const Eigen::Vector3d& c);

/// Where `point` goes when it moves with the triangle with corners t from `rest` to `now` as it
/// sat on it at rest: its closest point on the triangle follows the triangle, its offset from
/// there turns with the triangle's frame (first edge, in-plane, normal).
Eigen::RowVector3d carried(const Points& rest, const Points& now, const Eigen::RowVector3d& point,
                           const std::array<int, 3>& t);

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

}  // namespace facecast::rigbuild
