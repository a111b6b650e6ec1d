#include "contacts.hpp"

#include <algorithm>
#include <limits>

#include "facecast/anim/intersections.hpp"
#include "geometry.hpp"

namespace facecast::rigbuild {
namespace {

bool cross(const Points& p, const Faces& f, int a, int b) {
  const auto corner = [&](int t, int c) -> Eigen::Vector3d { return p.row(f(t, c)).transpose(); };
  return anim::triangles_intersect(corner(a, 0), corner(a, 1), corner(a, 2), corner(b, 0),
                                   corner(b, 1), corner(b, 2));
}

// The smallest distance from a corner of either triangle to the other triangle (close to the
// triangles' distance; edge-to-edge closeness across a sliver is missed, which a margin absorbs).
double corner_distance(const Points& p, const Faces& f, int a, int b) {
  double best = std::numeric_limits<double>::max();
  for (const auto& [from, to] : {std::pair{a, b}, std::pair{b, a}}) {
    const Eigen::Vector3d t0 = p.row(f(to, 0)).transpose(), t1 = p.row(f(to, 1)).transpose(),
                          t2 = p.row(f(to, 2)).transpose();
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector3d q = p.row(f(from, c)).transpose();
      const Eigen::Vector3d w = closest_on_triangle(q, t0, t1, t2);
      best = std::min(best, (w[0] * t0 + w[1] * t1 + w[2] * t2 - q).norm());
    }
  }
  return best;
}

}  // namespace

ContactGuard::ContactGuard(const Points& target_rest, const Faces& target_faces,
                           const std::vector<int>& component, double margin)
    : rest_(target_rest), faces_(target_faces) {
  const anim::Positions p = target_rest.cast<float>();
  for (const auto& [a, b] : anim::near_triangle_pairs(p, target_faces, margin)) {
    if (component[static_cast<std::size_t>(target_faces(a, 0))] !=
        component[static_cast<std::size_t>(target_faces(b, 0))])
      continue;
    if (corner_distance(target_rest, target_faces, a, b) > margin) continue;
    if (!cross(target_rest, target_faces, a, b)) watched_.emplace_back(a, b);  // not the neutral's
  }
}

std::vector<std::pair<int, int>> ContactGuard::new_crossings(const Points& shape,
                                                             const Points& reference,
                                                             const std::vector<char>& moved) const {
  std::vector<std::pair<int, int>> out;
  const auto moves = [&](int t) {
    return moved[static_cast<std::size_t>(faces_(t, 0))] ||
           moved[static_cast<std::size_t>(faces_(t, 1))] ||
           moved[static_cast<std::size_t>(faces_(t, 2))];
  };
  for (const auto& [a, b] : watched_) {
    if ((moves(a) || moves(b)) && cross(shape, faces_, a, b) && !cross(reference, faces_, a, b))
      out.emplace_back(a, b);
  }
  return out;
}

void ContactGuard::add_contacts(const std::vector<std::pair<int, int>>& crossings,
                                std::vector<Contact>& contacts) const {
  const auto add = [&](int vertex, int triangle) {
    Contact c;
    c.a = vertex;
    for (int i = 0; i < 3; ++i) c.b[static_cast<std::size_t>(i)] = faces_(triangle, i);
    if (std::any_of(contacts.begin(), contacts.end(),
                    [&](const Contact& x) { return x.a == c.a && x.b == c.b; }))
      return;
    const Eigen::Vector3d w =
        closest_on_triangle(rest_.row(vertex).transpose(), rest_.row(c.b[0]).transpose(),
                            rest_.row(c.b[1]).transpose(), rest_.row(c.b[2]).transpose());
    for (int i = 0; i < 3; ++i) c.w[static_cast<std::size_t>(i)] = w[i];
    contacts.push_back(c);
  };
  for (const auto& [a, b] : crossings) {
    for (int c = 0; c < 3; ++c) {
      add(faces_(a, c), b);
      add(faces_(b, c), a);
    }
  }
}

}  // namespace facecast::rigbuild
