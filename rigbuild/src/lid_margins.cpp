#include "lid_margins.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include "geometry.hpp"

namespace facecast::rigbuild {

LidMargins::LidMargins(const rig::Rig& head, const rig::Components& comps,
                       const render::Camera& camera)
    : rest_(rig::to_points(head.positions)),
      forward_((camera.target - camera.eye).cast<double>().normalized()),
      up_(camera.up.cast<double>()) {
  std::vector<char> skin(static_cast<std::size_t>(head.triangle_count()));
  for (int t = 0; t < head.triangle_count(); ++t)
    skin[static_cast<std::size_t>(t)] =
        comps.label[static_cast<std::size_t>(head.triangles(t, 0))] == comps.largest;
  std::vector<char> on = silhouette(head.positions, head.triangles, -forward_, skin);
  std::map<std::pair<int, int>, int> edges;  // the skin's, with their triangle counts
  for (int t = 0; t < head.triangle_count(); ++t)
    if (skin[static_cast<std::size_t>(t)])
      for (int k = 0; k < 3; ++k)
        ++edges[std::minmax(head.triangles(t, k), head.triangles(t, (k + 1) % 3))];
  for (const auto& [e, n] : edges)
    if (n == 1) on[static_cast<std::size_t>(e.first)] = on[static_cast<std::size_t>(e.second)] = 1;
  for (int v = 0; v < head.vertex_count(); ++v)
    if (on[static_cast<std::size_t>(v)]) contour_.push_back(v);
}

LidMargins::Frame LidMargins::frame(const Points& points, const Eye& e) const {
  Frame f;
  if (!has_point(points, e.inner) || !has_point(points, e.outer)) return f;
  // In the image plane: a corner deeper than the other must not turn depth into "along".
  const Eigen::Vector3d a = points.row(e.outer).transpose(), b = points.row(e.inner).transpose();
  const Eigen::Vector3d across = (b - a) - (b - a).dot(forward_) * forward_;
  if (across.norm() <= 0) return f;
  f.mid = 0.5 * (a + b);
  f.width = across.norm();
  f.along = across / f.width;
  f.up = forward_.cross(f.along).normalized();
  if (f.up.dot(up_) < 0) f.up = -f.up;
  return f;
}

// The margin vertex on `side` (+1 above the corners' line, -1 below) nearest to where `x` is
// along the line (at most 10 % of the eye's width from it); -1 when there is none. A contour
// vertex is on the margin when no contour vertex within 3 % of the width along the line is
// nearer the line (that one is the lid's posterior margin, this its front rim).
int LidMargins::margin(const Frame& f, int side, const Eigen::Vector3d& x) const {
  const double at = (x - f.mid).dot(f.along);
  struct Near {
    int vertex;
    double along, height;
  };
  std::vector<Near> near;
  for (int v : contour_) {
    const Eigen::Vector3d d = rest_.row(v).transpose() - f.mid;
    const double along = d.dot(f.along), height = side * d.dot(f.up);
    if (std::abs(along - at) <= 0.15 * f.width && height > 0 && height < 0.5 * f.width &&
        std::abs(d.dot(forward_)) <= 0.3 * f.width)
      near.push_back({v, along, height});
  }
  int best = -1;
  double best_gap = 0.1 * f.width;
  for (const Near& n : near) {
    const bool rim = std::any_of(near.begin(), near.end(), [&](const Near& o) {
      return std::abs(o.along - n.along) <= 0.03 * f.width && o.height < n.height;
    });
    if (!rim && std::abs(n.along - at) < best_gap) {
      best = n.vertex;
      best_gap = std::abs(n.along - at);
    }
  }
  return best;
}

// The lid points of both eyes moved onto the margins.
void LidMargins::snap(Points& points) const {
  for (const Eye& e : kEyes) {
    const Frame f = frame(points, e);
    if (f.width <= 0) continue;
    for (int side : {1, -1})
      for (int k : side > 0 ? e.upper : e.lower) {
        if (!has_point(points, k)) continue;
        if (const int v = margin(f, side, points.row(k).transpose()); v >= 0)
          points.row(k) = rest_.row(v);
      }
  }
}

}  // namespace facecast::rigbuild
