// The photo avatar's cameras and its RBF calibration. See docs/algorithms.md#photo-avatar.
#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>

#include "photo_detail.hpp"

namespace facecast::rigbuild {

Eigen::Vector2d PhotoCamera::project(const Eigen::Vector3d& p) const {
  const Eigen::Vector3d q = R * p;
  const Eigen::Vector2d u(s * q.x() + t.x(), t.y() - s * q.y());
  if (kappa <= 0) return u;
  return centre + (u - centre) / (1 - kappa * q.z());
}

Eigen::Vector3d PhotoCamera::eye() const {
  // Where every ray meets: (R p).z = 1 / kappa, and the origin's offset from the principal point
  // undone.
  return R.transpose() *
         Eigen::Vector3d((centre.x() - t.x()) / s, (t.y() - centre.y()) / s, 1 / kappa);
}

Eigen::Vector3d PhotoCamera::towards(const Eigen::Vector3d& p) const {
  if (kappa <= 0) return towards();
  return (eye() - p).normalized();
}

Eigen::Matrix<double, 2, 3> PhotoCamera::jacobian(const Eigen::Vector3d& p) const {
  if (kappa <= 0) return s * R.topRows<2>();
  // y up: Q = c + U / d, U = (t - c) + s (R p).xy, d = 1 - kappa (R p).z:
  // dQ/dp = (s R12 + kappa (Q - c) R3) / d.
  const Eigen::Vector3d q = R * p;
  const double d = 1 - kappa * q.z();
  const Eigen::Vector2d pixel = project(p);
  const Eigen::Vector2d offset(pixel.x() - centre.x(), centre.y() - pixel.y());
  return (s * R.topRows<2>() + kappa * offset * R.row(2)) / d;
}

PhotoCamera fit_ortho_camera(const std::vector<Eigen::Vector3d>& points,
                             const std::vector<Eigen::Vector2d>& pixels) {
  const auto n = static_cast<Eigen::Index>(points.size());
  // y up: q = (x, -y) = s R12 p + b.
  Eigen::Vector3d pm = Eigen::Vector3d::Zero();
  Eigen::Vector2d qm = Eigen::Vector2d::Zero();
  for (Eigen::Index i = 0; i < n; ++i) {
    pm += points[static_cast<std::size_t>(i)];
    qm += Eigen::Vector2d(pixels[static_cast<std::size_t>(i)].x(),
                          -pixels[static_cast<std::size_t>(i)].y());
  }
  pm /= static_cast<double>(n);
  qm /= static_cast<double>(n);
  Eigen::MatrixXd P(n, 3), Q(n, 2);
  for (Eigen::Index i = 0; i < n; ++i) {
    P.row(i) = (points[static_cast<std::size_t>(i)] - pm).transpose();
    const auto& q = pixels[static_cast<std::size_t>(i)];
    Q.row(i) = Eigen::RowVector2d(q.x(), -q.y()) - qm.transpose();
  }
  // Affine 2x3 part by least squares, then the nearest s * (orthonormal rows).
  const Eigen::Matrix<double, 3, 2> At = (P.transpose() * P).ldlt().solve(P.transpose() * Q);
  Eigen::JacobiSVD<Eigen::Matrix<double, 2, 3>> svd(At.transpose(),
                                                    Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix<double, 2, 3> rows =
      svd.matrixU() * Eigen::Matrix<double, 2, 3>::Identity() * svd.matrixV().transpose();
  PhotoCamera cam;
  cam.R.row(0) = rows.row(0);
  cam.R.row(1) = rows.row(1);
  cam.R.row(2) = rows.row(0).cross(rows.row(1));
  const Eigen::MatrixXd proj = P * rows.transpose();
  cam.s = std::max(1e-9, (proj.array() * Q.array()).sum() / proj.squaredNorm());
  const Eigen::Vector2d b = qm - cam.s * rows * pm;
  cam.t = {b.x(), -b.y()};
  return cam;
}

namespace {

// Wendland's C2 function (positive definite in 3D), support `radius`.
double wendland(double r, double radius) {
  const double x = r / radius;
  if (x >= 1) return 0;
  const double a = 1 - x;
  return a * a * a * a * (4 * x + 1);
}

}  // namespace

void rbf_deform(rig::Positions& positions, const std::vector<RbfCentre>& centres,
                const std::vector<int>& rigid, double radius, double merge, double smoothing) {
  // Merge centres that (nearly) coincide: their moves are averaged.
  std::vector<Eigen::Vector3d> at, move;
  std::vector<int> count;
  for (const auto& c : centres) {
    const Eigen::Vector3d p = positions.row(c.vertex).cast<double>().transpose();
    std::size_t j = 0;
    while (j < at.size() && (at[j] - p).norm() > merge) ++j;
    if (j == at.size()) {
      at.push_back(p);
      move.push_back(c.move);
      count.push_back(1);
    } else {
      move[j] = (move[j] * count[j] + c.move) / (count[j] + 1);
      ++count[j];
    }
  }
  const auto n = static_cast<Eigen::Index>(at.size());
  if (n == 0) return;
  Eigen::MatrixXd K(n, n), D(n, 3);
  for (Eigen::Index i = 0; i < n; ++i) {
    D.row(i) = move[static_cast<std::size_t>(i)].transpose();
    for (Eigen::Index j = 0; j < n; ++j)
      K(i, j) = wendland((at[static_cast<std::size_t>(i)] - at[static_cast<std::size_t>(j)]).norm(),
                         radius);
    K(i, i) += smoothing + 1e-9;
  }
  const Eigen::MatrixXd W = K.ldlt().solve(D);
  const auto field = [&](const Eigen::Vector3d& p) {
    Eigen::Vector3d d = Eigen::Vector3d::Zero();
    for (Eigen::Index j = 0; j < n; ++j) {
      const double w = wendland((p - at[static_cast<std::size_t>(j)]).norm(), radius);
      if (w > 0) d += w * W.row(j).transpose();
    }
    return d;
  };
  const int groups = rigid.empty() ? 0 : *std::max_element(rigid.begin(), rigid.end());
  std::vector<Eigen::Vector3d> group_move(static_cast<std::size_t>(groups) + 1,
                                          Eigen::Vector3d::Zero());
  std::vector<int> group_count(group_move.size(), 0);
  rig::Positions out = positions;
  for (Eigen::Index v = 0; v < positions.rows(); ++v) {
    const Eigen::Vector3d d = field(positions.row(v).cast<double>().transpose());
    const int g = rigid.empty() ? 0 : rigid[static_cast<std::size_t>(v)];
    if (g > 0) {
      group_move[static_cast<std::size_t>(g)] += d;
      ++group_count[static_cast<std::size_t>(g)];
    } else {
      out.row(v) += d.cast<float>().transpose();
    }
  }
  for (Eigen::Index v = 0; v < positions.rows(); ++v) {
    const int g = rigid.empty() ? 0 : rigid[static_cast<std::size_t>(v)];
    if (g > 0)
      out.row(v) += (group_move[static_cast<std::size_t>(g)] /
                     std::max(1, group_count[static_cast<std::size_t>(g)]))
                        .cast<float>()
                        .transpose();
  }
  positions = std::move(out);
}

render::Camera render_camera(const PhotoCamera& camera, const rig::Positions& positions, int width,
                             int height) {
  const Eigen::Vector3d centre = rig::to_points(positions).colwise().mean().transpose();
  const double radius =
      (rig::to_points(positions).rowwise() - centre.transpose()).rowwise().norm().maxCoeff();
  render::Camera out;
  out.up = camera.R.row(1).transpose().cast<float>();
  if (camera.perspective()) {
    // The camera itself, looking down its axis; the principal point is the photo's centre.
    const Eigen::Vector3d eye = camera.eye();
    const double distance = 1 / camera.kappa;
    out.eye = eye.cast<float>();
    out.target = (eye - distance * camera.towards()).cast<float>();
    out.fov_y_deg = static_cast<float>(2 * std::atan(0.5 * height / camera.focal()) * 180.0 / M_PI);
    const double to_head = (eye - centre).norm();
    out.near_plane = static_cast<float>(std::max(1e-3 * to_head, to_head - 2 * radius));
    out.far_plane = static_cast<float>(to_head + 2 * radius);
    return out;
  }
  // A narrow perspective camera far away approximates the orthographic projection: the photo's
  // centre pixel back-projected at the head's mean depth is the target.
  const double z0 = camera.depth(centre);
  const Eigen::Vector3d target =
      camera.R.transpose() * Eigen::Vector3d((0.5 * (width - 1) - camera.t.x()) / camera.s,
                                             (camera.t.y() - 0.5 * (height - 1)) / camera.s, z0);
  out.fov_y_deg = 1.0f;
  const double half = 0.5 * height / camera.s;
  const double distance = half / std::tan(0.5 * out.fov_y_deg * M_PI / 180.0);
  out.target = target.cast<float>();
  out.eye = (target + distance * camera.towards()).cast<float>();
  out.near_plane = static_cast<float>(std::max(1e-3, distance - 2 * radius));
  out.far_plane = static_cast<float>(distance + 2 * radius);
  return out;
}

}  // namespace facecast::rigbuild
