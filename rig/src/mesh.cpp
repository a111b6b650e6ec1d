#include "facecast/rig/mesh.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <Eigen/Geometry>

namespace facecast::rig {

Components connected_components(int vertex_count, const Triangles& triangles) {
  std::vector<int> parent(static_cast<std::size_t>(vertex_count));
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  std::vector<char> used(static_cast<std::size_t>(vertex_count), 0);
  for (Eigen::Index f = 0; f < triangles.rows(); ++f) {
    const int a = find(triangles(f, 0));
    used[triangles(f, 0)] = used[triangles(f, 1)] = used[triangles(f, 2)] = 1;
    for (int c = 1; c < 3; ++c) {
      const int b = find(triangles(f, c));
      if (a != b) parent[b] = a;
    }
  }
  Components out;
  out.label.assign(static_cast<std::size_t>(vertex_count), -1);
  std::vector<int> root_label(static_cast<std::size_t>(vertex_count), -1);
  std::vector<int> size;
  for (int v = 0; v < vertex_count; ++v) {
    if (!used[v]) continue;
    int& l = root_label[find(v)];
    if (l < 0) {
      l = out.count++;
      size.push_back(0);
    }
    out.label[v] = l;
    ++size[static_cast<std::size_t>(l)];
  }
  if (out.count > 0)
    out.largest = static_cast<int>(std::max_element(size.begin(), size.end()) - size.begin());
  return out;
}

namespace {

// Area-weighted unit vertex normals in the precision of `Matrix` (#V by 3, row-major).
template <class Matrix>
void area_weighted_normals(const Matrix& positions, const Triangles& triangles, Matrix& normals) {
  using Scalar = typename Matrix::Scalar;
  normals.setZero(positions.rows(), 3);
  for (Eigen::Index f = 0; f < triangles.rows(); ++f) {
    const int a = triangles(f, 0), b = triangles(f, 1), c = triangles(f, 2);
    const Eigen::Matrix<Scalar, 3, 1> n =
        (positions.row(b) - positions.row(a)).cross(positions.row(c) - positions.row(a));
    normals.row(a) += n;  // |n| = 2 * area: area weighting for free
    normals.row(b) += n;
    normals.row(c) += n;
  }
  for (Eigen::Index v = 0; v < normals.rows(); ++v) {
    const Scalar len = normals.row(v).norm();
    if (len > static_cast<Scalar>(1e-20) && std::isfinite(len)) {
      normals.row(v) /= len;
    } else {
      normals.row(v) = Eigen::Matrix<Scalar, 1, 3>(0, 0, 1);
    }
  }
}

}  // namespace

void vertex_normals(const Positions& positions, const Triangles& triangles, Positions& normals) {
  area_weighted_normals(positions, triangles, normals);
}

Positions vertex_normals(const Positions& positions, const Triangles& triangles) {
  Positions n;
  vertex_normals(positions, triangles, n);
  return n;
}

Points vertex_normals(const Points& positions, const Triangles& triangles) {
  Points n;
  area_weighted_normals(positions, triangles, n);
  return n;
}

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

Points centroids(const Points& p, const Triangles& f) {
  Points c(f.rows(), 3);
  for (Eigen::Index t = 0; t < f.rows(); ++t)
    c.row(t) = (p.row(f(t, 0)) + p.row(f(t, 1)) + p.row(f(t, 2))) / 3.0;
  return c;
}

Points face_normals(const Points& p, const Triangles& f) {
  Points n(f.rows(), 3);
  for (Eigen::Index t = 0; t < f.rows(); ++t) {
    const Eigen::Vector3d a = p.row(f(t, 0)), b = p.row(f(t, 1)), c = p.row(f(t, 2));
    n.row(t) = (b - a).cross(c - a).normalized().transpose();
  }
  return n;
}

double diagonal(const Points& p) {
  return p.rows() ? (p.colwise().maxCoeff() - p.colwise().minCoeff()).norm() : 0.0;
}

}  // namespace facecast::rig
