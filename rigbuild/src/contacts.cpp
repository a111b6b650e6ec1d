#include "contacts.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdint>
#include <limits>
#include <numeric>

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
    : rest_(target_rest), faces_(target_faces), graph_(target_rest, target_faces) {
  if (margin <= 0) margin = 0.5 * graph_.median_edge_length();
  const anim::Positions p = target_rest.cast<float>();
  for (const auto& [a, b] : anim::near_triangle_pairs(p, target_faces, margin)) {
    if (component[static_cast<std::size_t>(target_faces(a, 0))] !=
        component[static_cast<std::size_t>(target_faces(b, 0))])
      continue;
    if (corner_distance(target_rest, target_faces, a, b) > margin) continue;
    if (!cross(target_rest, target_faces, a, b)) watched_.emplace_back(a, b);  // not the neutral's
  }
  // Per vertex, the watched pairs with a triangle at it (compressed rows).
  pair_start_.assign(static_cast<std::size_t>(target_rest.rows()) + 1, 0);
  const auto each_vertex = [&](auto&& f) {
    for (std::size_t i = 0; i < watched_.size(); ++i)
      for (const int t : {watched_[i].first, watched_[i].second})
        for (int c = 0; c < 3; ++c) f(target_faces(t, c), i);
  };
  each_vertex([&](int v, std::size_t) { ++pair_start_[static_cast<std::size_t>(v) + 1]; });
  for (std::size_t v = 0; v + 1 < pair_start_.size(); ++v) pair_start_[v + 1] += pair_start_[v];
  pair_index_.resize(static_cast<std::size_t>(pair_start_.back()));
  std::vector<int> fill(pair_start_.begin(), pair_start_.end() - 1);
  each_vertex([&](int v, std::size_t i) {
    pair_index_[static_cast<std::size_t>(fill[static_cast<std::size_t>(v)]++)] =
        static_cast<int>(i);
  });
}

bool ContactGuard::moves_at(const std::vector<char>& moved, int t) const {
  return moved[static_cast<std::size_t>(faces_(t, 0))] ||
         moved[static_cast<std::size_t>(faces_(t, 1))] ||
         moved[static_cast<std::size_t>(faces_(t, 2))];
}

std::vector<std::pair<int, int>> ContactGuard::new_crossings(const Points& shape,
                                                             const Points& reference,
                                                             const std::vector<char>& moved) const {
  std::vector<std::pair<int, int>> out;
  for (const auto& [a, b] : watched_) {
    if ((moves_at(moved, a) || moves_at(moved, b)) && cross(shape, faces_, a, b) &&
        !cross(reference, faces_, a, b))
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

std::pair<int, int> ContactGuard::untangle(
    Points& reference, const std::vector<char>& moved,
    const std::function<bool(int, int)>& template_crosses) const {
  // Pairs (indices into watched_) to fix: they cross in the reference, not in the template.
  std::vector<std::int8_t> in_template(watched_.size(), -1);  // asked once per pair
  const auto crossing = [&](const std::vector<std::size_t>& candidates) {
    std::vector<std::size_t> out;
    for (const std::size_t i : candidates) {
      const auto [a, b] = watched_[i];
      if (!(moves_at(moved, a) || moves_at(moved, b)) || !cross(reference, faces_, a, b)) continue;
      if (in_template[i] < 0) in_template[i] = template_crosses(a, b);
      if (!in_template[i]) out.push_back(i);
    }
    return out;
  };
  std::vector<std::size_t> all(watched_.size());
  std::iota(all.begin(), all.end(), std::size_t{0});
  auto pairs = crossing(all);
  const int found = static_cast<int>(pairs.size());
  if (pairs.empty()) return {0, 0};

  // A few Gauss-Seidel sweeps of the graph Laplacian of the displacement at a time, on the
  // crossing triangles' moved vertices with the rest of the mesh held, until nothing crosses:
  // the copied motion changes no more than it must. Still crossing after 20 steps: a ring wider.
  std::vector<char> in_region(static_cast<std::size_t>(rest_.rows()), 0);
  std::vector<int> region;
  const auto add = [&](int v) {
    if (!moved[static_cast<std::size_t>(v)] || in_region[static_cast<std::size_t>(v)]) return;
    in_region[static_cast<std::size_t>(v)] = 1;
    region.push_back(v);
  };
  Points d = reference - rest_;
  std::vector<std::size_t> near;
  // Smoothing can push the region into its surroundings: the fewest crossings seen are kept (the
  // region's rows at that step; a vertex that joined the region later keeps its copied value).
  const Points copied = reference;
  std::vector<Eigen::RowVector3d> best;  // rows of region[0, best.size()) at the fewest
  std::size_t fewest = pairs.size();
  for (int step = 0; step < 60 && !pairs.empty(); ++step) {
    for (const std::size_t i : pairs)
      for (int c = 0; c < 3; ++c) {
        add(faces_(watched_[i].first, c));
        add(faces_(watched_[i].second, c));
      }
    if (step % 20 == 19) {
      const std::vector<int> edge = region;
      for (int v : edge)
        for (const auto& [u, w] : graph_.neighbours(v)) add(u);
    }
    for (int sweep = 0; sweep < 2; ++sweep) {
      for (int v : region) {
        Eigen::RowVector3d sum = Eigen::RowVector3d::Zero();
        for (const auto& [u, w] : graph_.neighbours(v)) sum += d.row(u);
        d.row(v) = sum / static_cast<double>(graph_.degree(v));
      }
    }
    near.clear();
    for (int v : region) {
      reference.row(v) = rest_.row(v) + d.row(v);
      for (int k = pair_start_[static_cast<std::size_t>(v)];
           k < pair_start_[static_cast<std::size_t>(v) + 1]; ++k)
        near.push_back(static_cast<std::size_t>(pair_index_[static_cast<std::size_t>(k)]));
    }
    std::sort(near.begin(), near.end());
    near.erase(std::unique(near.begin(), near.end()), near.end());
    pairs = crossing(near);
    if (pairs.size() < fewest) {
      fewest = pairs.size();
      best.clear();
      for (int v : region) best.push_back(reference.row(v));
    }
  }
  if (pairs.size() > fewest) {
    for (std::size_t i = 0; i < region.size(); ++i)
      reference.row(region[i]) = i < best.size() ? best[i] : copied.row(region[i]);
  }
  return {found, static_cast<int>(fewest)};
}

}  // namespace facecast::rigbuild
