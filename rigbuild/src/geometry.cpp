#include "geometry.hpp"

#include <Eigen/Geometry>

namespace facecast::rigbuild {

Eigen::Vector3d closest_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                    const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return {1, 0, 0};
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return {0, 1, 0};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    return {1 - v, v, 0};
  }
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return {0, 0, 1};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    return {1 - w, 0, w};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {0, 1 - w, w};
  }
  const double denom = 1.0 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  return {1 - v - w, v, w};
}

namespace {

// An orthonormal frame of the triangle with corners t at positions p (columns: the first edge,
// in the plane, the normal).
Eigen::Matrix3d triangle_frame(const Points& p, const std::array<int, 3>& t) {
  const Eigen::Vector3d p0 = p.row(t[0]).transpose();
  const Eigen::Vector3d e1 = (p.row(t[1]).transpose() - p0).normalized();
  const Eigen::Vector3d n = e1.cross(p.row(t[2]).transpose() - p0).normalized();
  Eigen::Matrix3d m;
  m << e1, n.cross(e1), n;
  return m;
}

}  // namespace

Eigen::RowVector3d carried(const Points& rest, const Points& now, const Eigen::RowVector3d& point,
                           const std::array<int, 3>& t) {
  const Eigen::Vector3d w =
      closest_on_triangle(point.transpose(), rest.row(t[0]).transpose(), rest.row(t[1]).transpose(),
                          rest.row(t[2]).transpose());
  Eigen::RowVector3d on_rest = Eigen::RowVector3d::Zero(), on_now = on_rest;
  for (std::size_t j = 0; j < 3; ++j) {
    on_rest += w[static_cast<Eigen::Index>(j)] * rest.row(t[j]);
    on_now += w[static_cast<Eigen::Index>(j)] * now.row(t[j]);
  }
  const Eigen::Matrix3d turn = triangle_frame(now, t) * triangle_frame(rest, t).transpose();
  return on_now + (point - on_rest) * turn.transpose();
}

}  // namespace facecast::rigbuild
