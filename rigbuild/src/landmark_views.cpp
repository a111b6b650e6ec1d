// The landmark views: cameras and CPU z-buffers. See docs/algorithms.md#landmarks.
#include "landmark_views.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>

namespace facecast::rigbuild {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct Projected {
  Eigen::Vector2d xy;  // continuous pixel coordinates: pixel (i, j) covers [i, i+1) x [j, j+1)
  double w = 0;        // view distance along the axis; <= 0 behind the camera
};

Projected project(const Eigen::Matrix4d& mvp, const Eigen::RowVector3d& p, int size) {
  const Eigen::Vector4d clip = mvp * Eigen::Vector4d(p.x(), p.y(), p.z(), 1.0);
  Projected out;
  out.w = clip.w();
  if (out.w <= 0) return out;
  out.xy = {(clip.x() / clip.w() + 1) * 0.5 * size, (1 - clip.y() / clip.w()) * 0.5 * size};
  return out;
}

}  // namespace

render::Camera wide_camera(const rig::Rig& head, float margin, int image_size) {
  render::RenderOptions o;
  o.width = o.height = image_size;
  o.margin = margin;
  return render::frame_avatar(head, 1.0f, o);
}

render::Camera face_camera(const render::Camera& wide, const Eigen::Vector3d& centre, double zoom) {
  render::Camera c = wide;
  c.target = centre.cast<float>();
  c.eye = c.target + (wide.eye - wide.target);
  c.fov_y_deg = static_cast<float>(
      2 * std::atan(std::tan(0.5 * wide.fov_y_deg * kPi / 180.0) / zoom) * 180.0 / kPi);
  return c;
}

render::Camera orbit(const render::Camera& camera, double yaw_deg) {
  render::Camera c = camera;
  const Eigen::AngleAxisf turn(static_cast<float>(yaw_deg * kPi / 180.0), Eigen::Vector3f::UnitY());
  c.eye = c.target + turn * (c.eye - c.target);
  return c;
}

SkinBuffer::SkinBuffer(const Points& rest, const Triangles& faces, const std::vector<char>& skin,
                       const render::Camera& camera, int size, double depth_tolerance)
    : rest_(rest), faces_(faces), size_(size), tolerance_(depth_tolerance) {
  const Eigen::Matrix4d mvp = render::view_projection(camera, 1.0);
  inverse_ = mvp.inverse();
  eye_ = camera.eye.cast<double>();
  const auto pixels = static_cast<std::size_t>(size) * static_cast<std::size_t>(size);
  depth_all_.assign(pixels, std::numeric_limits<float>::infinity());
  depth_skin_ = depth_all_;
  skin_triangle_.assign(pixels, -1);
  std::vector<Projected> proj(static_cast<std::size_t>(rest.rows()));
  for (Eigen::Index v = 0; v < rest.rows(); ++v)
    proj[static_cast<std::size_t>(v)] = project(mvp, rest.row(v), size);
  for (int t = 0; t < faces.rows(); ++t) {
    const Projected& a = proj[static_cast<std::size_t>(faces(t, 0))];
    const Projected& b = proj[static_cast<std::size_t>(faces(t, 1))];
    const Projected& c = proj[static_cast<std::size_t>(faces(t, 2))];
    if (a.w <= camera.near_plane || b.w <= camera.near_plane || c.w <= camera.near_plane) continue;
    const double area =
        (b.xy - a.xy).x() * (c.xy - a.xy).y() - (b.xy - a.xy).y() * (c.xy - a.xy).x();
    if (std::abs(area) < 1e-12) continue;
    const Eigen::Vector2d lo = a.xy.cwiseMin(b.xy).cwiseMin(c.xy);
    const Eigen::Vector2d hi = a.xy.cwiseMax(b.xy).cwiseMax(c.xy);
    const int x0 = std::max(0, static_cast<int>(std::floor(lo.x())));
    const int y0 = std::max(0, static_cast<int>(std::floor(lo.y())));
    const int x1 = std::min(size - 1, static_cast<int>(std::ceil(hi.x())));
    const int y1 = std::min(size - 1, static_cast<int>(std::ceil(hi.y())));
    const bool on_skin = skin[static_cast<std::size_t>(t)] != 0;
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const Eigen::Vector2d q(x + 0.5, y + 0.5);
        // Barycentric weights in screen space; 1/w is linear there.
        const auto edge = [&](const Eigen::Vector2d& p0, const Eigen::Vector2d& p1) {
          return ((p1 - p0).x() * (q - p0).y() - (p1 - p0).y() * (q - p0).x()) / area;
        };
        const double wa = edge(b.xy, c.xy), wb = edge(c.xy, a.xy), wc = 1 - wa - wb;
        if (wa < 0 || wb < 0 || wc < 0) continue;
        const auto depth = static_cast<float>(1.0 / (wa / a.w + wb / b.w + wc / c.w));
        const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(size) +
                              static_cast<std::size_t>(x);
        depth_all_[i] = std::min(depth_all_[i], depth);
        if (on_skin && depth < depth_skin_[i]) {
          depth_skin_[i] = depth;
          skin_triangle_[i] = t;
        }
      }
    }
  }
}

std::optional<Eigen::RowVector3d> SkinBuffer::hit(int triangle,
                                                  const Eigen::Vector2d& pixel) const {
  // The ray from the eye through the pixel position, cut with the triangle's plane.
  const Eigen::Vector4d ndc(2 * pixel.x() / size_ - 1, 1 - 2 * pixel.y() / size_, 0.0, 1.0);
  const Eigen::Vector4d h = inverse_ * ndc;
  const Eigen::Vector3d dir = h.head<3>() / h.w() - eye_;
  const Eigen::Vector3d a = rest_.row(faces_(triangle, 0)).transpose();
  const Eigen::Vector3d b = rest_.row(faces_(triangle, 1)).transpose();
  const Eigen::Vector3d c = rest_.row(faces_(triangle, 2)).transpose();
  const Eigen::Vector3d n = (b - a).cross(c - a);
  const double denom = n.dot(dir);
  if (std::abs(denom) < 1e-15 * n.norm() * dir.norm()) return std::nullopt;
  const Eigen::Vector3d p = eye_ + (n.dot(a - eye_) / denom) * dir;
  // Barycentric weights of p, clamped onto the triangle (the pixel centre may lie just outside).
  const double nn = n.squaredNorm();
  Eigen::Vector3d w(n.dot((c - b).cross(p - b)) / nn, n.dot((a - c).cross(p - c)) / nn, 0.0);
  w.z() = 1 - w.x() - w.y();
  w = w.cwiseMax(0.0);
  w /= w.sum();
  return (w.x() * a + w.y() * b + w.z() * c).transpose();
}

std::optional<Eigen::RowVector3d> SkinBuffer::lift(const Eigen::Vector2d& at, double search) const {
  const Eigen::Vector2d q = at + Eigen::Vector2d(0.5, 0.5);  // dlib: pixel centres at integers
  const int cx = static_cast<int>(std::floor(q.x())), cy = static_cast<int>(std::floor(q.y()));
  const int r = static_cast<int>(std::ceil(search));
  int best = -1;
  double best_d2 = search * search;
  Eigen::Vector2d best_pixel;
  for (int y = cy - r; y <= cy + r; ++y) {
    for (int x = cx - r; x <= cx + r; ++x) {
      if (x < 0 || y < 0 || x >= size_ || y >= size_) continue;
      const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(size_) +
                            static_cast<std::size_t>(x);
      if (skin_triangle_[i] < 0 || depth_skin_[i] > depth_all_[i] + tolerance_) continue;
      const Eigen::Vector2d centre(x + 0.5, y + 0.5);
      const double d2 = (x == cx && y == cy) ? 0.0 : (centre - q).squaredNorm();
      if (d2 <= best_d2 && (best < 0 || d2 < best_d2)) {
        best = skin_triangle_[i];
        best_d2 = d2;
        best_pixel = (x == cx && y == cy) ? q : centre;
      }
    }
  }
  if (best < 0) return std::nullopt;
  return hit(best, best_pixel);
}

}  // namespace facecast::rigbuild
