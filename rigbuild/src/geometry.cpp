#include "geometry.hpp"

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <string>

#include "facecast/core/error.hpp"

namespace facecast::rigbuild {

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

Points Similarity::apply(const Points& p) const {
  return ((scale * p) * R.transpose()).rowwise() + t.transpose();
}

Eigen::RowVector3d Similarity::apply(const Eigen::RowVector3d& p) const {
  return (scale * R * p.transpose() + t).transpose();
}

Similarity procrustes(const Points& from, const Points& to, bool with_scale) {
  const Eigen::RowVector3d cf = from.colwise().mean(), ct = to.colwise().mean();
  const Points a = from.rowwise() - cf;
  Eigen::Matrix3d H = a.transpose() * (to.rowwise() - ct);
  // Umeyama's covariance is H / N; the rotation does not depend on the factor, the scale does.
  if (with_scale) H /= static_cast<double>(from.rows());
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0) D(2, 2) = -1;
  Similarity s;
  s.R = svd.matrixV() * D * svd.matrixU().transpose();
  if (with_scale)
    s.scale = (svd.singularValues().asDiagonal() * D).trace() / a.rowwise().squaredNorm().mean();
  s.t = ct.transpose() - s.scale * s.R * cf.transpose();
  s.rms = std::sqrt((s.apply(from) - to).rowwise().squaredNorm().mean());
  return s;
}

std::vector<char> silhouette(const rig::Positions& p, const Triangles& tris,
                             const Eigen::Vector3d& towards, const std::vector<char>& keep) {
  std::vector<unsigned char> facing(static_cast<std::size_t>(p.rows()), 0);
  for (Eigen::Index f = 0; f < tris.rows(); ++f) {
    if (!keep.empty() && !keep[static_cast<std::size_t>(f)]) continue;
    const Eigen::Vector3d a = p.row(tris(f, 0)).cast<double>(),
                          b = p.row(tris(f, 1)).cast<double>(),
                          c = p.row(tris(f, 2)).cast<double>();
    const unsigned char bit = (b - a).cross(c - a).dot(towards) > 0 ? 1 : 2;
    for (int k = 0; k < 3; ++k) facing[static_cast<std::size_t>(tris(f, k))] |= bit;
  }
  std::vector<char> out(facing.size());
  for (std::size_t v = 0; v < facing.size(); ++v) out[v] = facing[v] == 3;
  return out;
}

namespace {

// The rows of per-triangle values `all` at `triangles` (all of them when empty).
Points rows_at(Points all, const std::vector<int>& triangles) {
  if (triangles.empty()) return all;
  Points out(static_cast<Eigen::Index>(triangles.size()), 3);
  for (std::size_t i = 0; i < triangles.size(); ++i)
    out.row(static_cast<Eigen::Index>(i)) = all.row(triangles[i]);
  return out;
}

}  // namespace

SurfaceQuery::SurfaceQuery(const Points& p, const Triangles& f, std::vector<int> triangles)
    : p_(p),
      f_(f),
      triangles_(std::move(triangles)),
      centroids_(rows_at(centroids(p, f), triangles_)),
      normals_(rows_at(face_normals(p, f), triangles_)) {
  // Boundary edges: those that exactly one of the triangles has.
  std::vector<std::pair<int, int>> edges;
  const auto add = [&](Eigen::Index t) {
    for (int k = 0; k < 3; ++k) edges.push_back(std::minmax(f(t, k), f(t, (k + 1) % 3)));
  };
  if (triangles_.empty())
    for (Eigen::Index t = 0; t < f.rows(); ++t) add(t);
  for (const int t : triangles_) add(t);
  std::sort(edges.begin(), edges.end());
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    if (j - i == 1) boundary_.push_back(edges[i]);
    i = j;
  }
}

void SurfaceQuery::consider(const Eigen::Vector3d& q, int t, Hit& best) const {
  const Eigen::Vector3d a = p_.row(f_(t, 0)), b = p_.row(f_(t, 1)), c = p_.row(f_(t, 2));
  const Eigen::Vector3d w = closest_on_triangle(q, a, b, c);
  const Eigen::Vector3d x = w[0] * a + w[1] * b + w[2] * c;
  const double d = (x - q).norm();
  if (d < best.dist) {
    best.triangle = t;
    best.bary = w;
    best.point = x;
    best.dist = d;
  }
}

bool SurfaceQuery::on_boundary(const Hit& hit) const {
  for (int k = 0; k < 3; ++k) {
    if (hit.bary[k] >= 1e-9) continue;  // on the edge opposite corner k
    const std::pair<int, int> edge =
        std::minmax(f_(hit.triangle, (k + 1) % 3), f_(hit.triangle, (k + 2) % 3));
    if (std::binary_search(boundary_.begin(), boundary_.end(), edge)) return true;
  }
  return false;
}

MeshParts::MeshParts(int vertex_count, const Triangles& faces)
    : components(rig::connected_components(vertex_count, faces)),
      members(static_cast<std::size_t>(components.count)),
      skin(std::max(components.largest, 0)) {
  for (int v = 0; v < vertex_count; ++v)
    if (const int c = of(v); c >= 0) members[static_cast<std::size_t>(c)].push_back(v);
}

void check_components(const rig::Components& components, int vertex_count,
                      const std::string& what) {
  if (components.label.size() != static_cast<std::size_t>(vertex_count))
    throw Error(what + ": " + std::to_string(components.label.size()) + " vertex labels for " +
                std::to_string(vertex_count) + " vertices");
}

double median(std::vector<double> v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  if (v.size() % 2) return *mid;
  return 0.5 * (*mid + *std::max_element(v.begin(), mid));
}

double segment_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                        const Eigen::Vector3d& b) {
  const Eigen::Vector3d d = b - a;
  const double t = std::clamp((p - a).dot(d) / std::max(1e-12, d.squaredNorm()), 0.0, 1.0);
  return (a + t * d - p).norm();
}

}  // namespace facecast::rigbuild
