#include "contacts.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdint>
#include <limits>
#include <numeric>
#include <utility>

#include "facecast/rig/intersections.hpp"
#include "geometry.hpp"
#include "parallel.hpp"

namespace facecast::rigbuild {
namespace {

bool cross(const Points& p, const Triangles& f, int a, int b) {
  const auto corner = [&](int t, int c) -> Eigen::Vector3d { return p.row(f(t, c)).transpose(); };
  // Most watched pairs are apart: their boxes do not even overlap.
  const auto box = [&](int t) {
    Eigen::AlignedBox3d bounds(corner(t, 0));
    bounds.extend(corner(t, 1));
    return bounds.extend(corner(t, 2));
  };
  if (!box(a).intersects(box(b))) return false;
  return rig::triangles_intersect(corner(a, 0), corner(a, 1), corner(a, 2), corner(b, 0),
                                  corner(b, 1), corner(b, 2));
}

// The smallest distance from a corner of either triangle to the other triangle (close to the
// triangles' distance; edge-to-edge closeness across a sliver is missed, which a margin absorbs).
double corner_distance(const Points& p, const Triangles& f, int a, int b) {
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

ContactGuard::ContactGuard(const TargetMesh& target, const std::vector<char>& held, double margin,
                           double part_margin, const std::vector<char>& floating,
                           const std::vector<char>& attached)
    : rest_(target.rest), faces_(target.faces), parts_(target.parts), graph_(target.graph) {
  if (margin <= 0) margin = 0.5 * graph_.median_edge_length();
  if (part_margin <= 0) part_margin = 2 * graph_.median_edge_length();
  const auto held_corners = [&](int t) {
    return held[static_cast<std::size_t>(faces_(t, 0))] +
           held[static_cast<std::size_t>(faces_(t, 1))] +
           held[static_cast<std::size_t>(faces_(t, 2))];
  };
  // Candidates by their boxes, then the exact tests on all cores.
  const auto keep = [&](std::vector<std::pair<int, int>> candidates, auto&& test) {
    std::vector<char> kept(candidates.size());
    parallel_for(candidates.size(), [&](std::size_t i) { kept[i] = test(candidates[i]); });
    std::vector<std::pair<int, int>> out;
    for (std::size_t i = 0; i < candidates.size(); ++i)
      if (kept[i]) out.push_back(candidates[i]);
    return out;
  };
  const rig::Positions p = rig::to_positions(rest_);
  const auto one_part = [&](int a, int b) { return part_of(a) == part_of(b); };
  watched_ = keep(rig::near_triangle_pairs(p, faces_, margin, {}, one_part), [&](auto pair) {
    const auto [a, b] = pair;
    return corner_distance(rest_, faces_, a, b) <= margin &&
           !cross(rest_, faces_, a, b);  // not the neutral's own
  });
  // A placed triangle against a free one of the skin, in that order.
  const int skin = parts_.skin;
  std::vector<char> placed(static_cast<std::size_t>(faces_.rows()), 0);
  for (Eigen::Index t = 0; t < faces_.rows(); ++t)
    placed[static_cast<std::size_t>(t)] = held_corners(static_cast<int>(t)) == 3;
  const auto placed_free = [&](int a, int b) {  // (placed, free skin) in either order
    if (!placed[static_cast<std::size_t>(a)]) std::swap(a, b);
    return held_corners(b) == 0 && part_of(b) == skin && part_of(a) != skin;
  };
  auto candidates = rig::near_triangle_pairs(p, faces_, part_margin, placed, placed_free);
  for (auto& [a, b] : candidates)
    if (!placed[static_cast<std::size_t>(a)]) std::swap(a, b);
  part_pairs_ = keep(std::move(candidates), [&](auto pair) {
    const auto [a, b] = pair;
    return corner_distance(rest_, faces_, a, b) <= part_margin && !cross(rest_, faces_, a, b);
  });
  placed_ = std::move(placed);
  // A floating part's triangles (a tongue): checked in each shape against every triangle near
  // them there (crossings_of), since the part moves apart from what lies around it. Not a round
  // one (an eyeball, which turns in place a little in most shapes): the placed-part pairs hold
  // the skin off it. An attached part's (lashes): lifted off what it runs into after it is
  // carried (lift_attached).
  std::vector<signed char> round(parts_.members.size(), -1);  // per part, once known
  const auto round_at = [&](int t) {
    auto& r = round[static_cast<std::size_t>(part_of(t))];
    if (r < 0) r = on_sphere(part_of(t));
    return r == 1;
  };
  const auto all_in = [&](const std::vector<char>& vertices, int t) {
    return !vertices.empty() && vertices[static_cast<std::size_t>(faces_(t, 0))] &&
           vertices[static_cast<std::size_t>(faces_(t, 1))] &&
           vertices[static_cast<std::size_t>(faces_(t, 2))];
  };
  floating_ = group([&](int t) { return all_in(floating, t) && !round_at(t); });
  attached_ = group([&](int t) { return all_in(attached, t); });
  // Which placed parts are round (see is_round): the placed-part pairs move them radially.
  round_.assign(parts_.members.size(), 0);
  std::vector<char> seen(parts_.members.size(), 0);
  for (const auto& pair : part_pairs_) {
    const auto c = static_cast<std::size_t>(part_of(pair.first));
    if (!std::exchange(seen[c], 1)) round_[c] = is_round(static_cast<int>(c));
  }
  // Per vertex, the watched pairs with a triangle at it (compressed rows).
  pair_start_.assign(static_cast<std::size_t>(rest_.rows()) + 1, 0);
  const auto each_vertex = [&](auto&& f) {
    for (std::size_t i = 0; i < watched_.size(); ++i)
      for (const int t : {watched_[i].first, watched_[i].second})
        for (int c = 0; c < 3; ++c) f(faces_(t, c), i);
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

bool ContactGuard::wrong_side(const Points& reference, const Contact& c) const {
  // The vertex's side of the triangle's plane, in the neutral and in the reference.
  const auto side = [&](const Points& p) {
    const Eigen::RowVector3d a = p.row(c.b[0]), b = p.row(c.b[1]), d = p.row(c.b[2]);
    Eigen::RowVector3d on = Eigen::RowVector3d::Zero();
    for (std::size_t j = 0; j < 3; ++j) on += c.w[j] * p.row(c.b[j]);
    return (p.row(c.a) - on).dot((b - a).cross(d - a));
  };
  if (side(rest_) * side(reference) >= 0) return false;
  // ... and through the triangle itself: the vertex is within a triangle's size of it there (a
  // floating part that moves far, a tongue out past the lips' plane, passed nothing).
  const Eigen::Vector3d a = reference.row(c.b[0]).transpose(),
                        b = reference.row(c.b[1]).transpose(),
                        d = reference.row(c.b[2]).transpose(), x = reference.row(c.a).transpose();
  const Eigen::Vector3d w = closest_on_triangle(x, a, b, d);
  const double size = std::max({(b - a).norm(), (d - b).norm(), (a - d).norm()});
  return (x - (w[0] * a + w[1] * b + w[2] * d)).norm() < size;
}

bool ContactGuard::is_round(int part) const {
  const auto& members = parts_.members[static_cast<std::size_t>(part)];
  const Eigen::RowVector3d centre = centre_of(rest_, part);
  double sum = 0, sum2 = 0;
  for (int v : members) {
    const double r = (rest_.row(v) - centre).norm();
    sum += r;
    sum2 += r * r;
  }
  const double n = static_cast<double>(members.size()), mean = sum / n;
  return sum2 / n - mean * mean < 0.15 * 0.15 * mean * mean;
}

bool ContactGuard::on_sphere(int part) const {
  // |x|^2 = 2 c.x + k (k = r^2 - |c|^2), least squares over the part's vertices; then the RMS of
  // |x - c| - r against r.
  const auto& members = parts_.members[static_cast<std::size_t>(part)];
  if (members.size() < 8) return false;
  const Eigen::RowVector3d mean = centre_of(rest_, part);  // for conditioning
  Eigen::MatrixXd A(static_cast<Eigen::Index>(members.size()), 4);
  Eigen::VectorXd b(A.rows());
  for (std::size_t i = 0; i < members.size(); ++i) {
    const Eigen::RowVector3d x = rest_.row(members[i]) - mean;
    A.row(static_cast<Eigen::Index>(i)) << 2 * x, 1;
    b(static_cast<Eigen::Index>(i)) = x.squaredNorm();
  }
  const Eigen::Vector4d s = A.colPivHouseholderQr().solve(b);
  const Eigen::RowVector3d c = s.head<3>().transpose();
  const double r2 = s(3) + c.squaredNorm();
  if (!(r2 > 0)) return false;
  const double r = std::sqrt(r2);
  double sum2 = 0;
  for (int v : members) {
    const double e = (rest_.row(v) - mean - c).norm() - r;
    sum2 += e * e;
  }
  return std::sqrt(sum2 / static_cast<double>(members.size())) < 0.05 * r;
}

int ContactGuard::part_of_vertex(int v) const {
  return parts_.of(v);
}

int ContactGuard::part_of(int t) const {
  return parts_.of(faces_(t, 0));
}

Eigen::RowVector3d ContactGuard::centre_of(const Points& p, int part) const {
  const auto& members = parts_.members[static_cast<std::size_t>(part)];
  Eigen::RowVector3d sum = Eigen::RowVector3d::Zero();
  for (int v : members) sum += p.row(v);
  return sum / static_cast<double>(members.size());
}

void ContactGuard::smooth(Points& d, const std::vector<int>& region, int sweeps) const {
  for (int sweep = 0; sweep < sweeps; ++sweep) {
    for (int v : region) {
      Eigen::RowVector3d sum = Eigen::RowVector3d::Zero();
      for (const auto& [u, w] : graph_.neighbours(v)) sum += d.row(u);
      d.row(v) = sum / static_cast<double>(graph_.degree(v));
    }
  }
}

bool ContactGuard::moves_at(const std::vector<char>& moved, int t) const {
  return moved[static_cast<std::size_t>(faces_(t, 0))] ||
         moved[static_cast<std::size_t>(faces_(t, 1))] ||
         moved[static_cast<std::size_t>(faces_(t, 2))];
}

std::vector<std::pair<int, int>> ContactGuard::new_crossings(
    const Points& shape, const Points& reference, const std::vector<char>& moved,
    const std::function<bool(int, int)>& template_crosses) const {
  std::vector<std::pair<int, int>> out;
  for (const auto& [a, b] : watched_)
    if (moving_cross(shape, moved, a, b) && !cross(reference, faces_, a, b)) out.emplace_back(a, b);
  for (const auto& [a, b] : part_pairs_)
    if (moving_cross(shape, moved, a, b) && !template_crosses(a, b)) out.emplace_back(a, b);
  for (const auto& [a, b] : crossings_of(shape, floating_))
    if (!template_crosses(a, b)) out.emplace_back(a, b);
  return out;
}

ContactGuard::PartTriangles ContactGuard::group(const std::function<bool(int)>& in) const {
  PartTriangles g;
  g.member.assign(static_cast<std::size_t>(faces_.rows()), 0);
  for (int t = 0; t < static_cast<int>(faces_.rows()); ++t)
    if (in(t)) {
      g.member[static_cast<std::size_t>(t)] = 1;
      g.triangles.push_back(t);
    }
  if (g.triangles.empty()) return g;
  std::stable_sort(g.triangles.begin(), g.triangles.end(),
                   [&](int a, int b) { return part_of(a) < part_of(b); });
  for (std::size_t i = 0; i < g.triangles.size(); ++i)
    if (i == 0 || part_of(g.triangles[i]) != part_of(g.triangles[i - 1]))
      g.start.push_back(static_cast<int>(i));
  g.start.push_back(static_cast<int>(g.triangles.size()));
  const auto near = rig::near_triangle_pairs(rig::to_positions(rest_), faces_, 0.0, g.member);
  std::vector<char> crossing(near.size());
  parallel_for(near.size(), [&](std::size_t i) {
    crossing[i] = cross(rest_, faces_, near[i].first, near[i].second);
  });
  for (std::size_t i = 0; i < near.size(); ++i)
    if (crossing[i])
      g.neutral.emplace_back(std::min(near[i].first, near[i].second),
                             std::max(near[i].first, near[i].second));
  std::sort(g.neutral.begin(), g.neutral.end());
  return g;
}

std::vector<std::pair<int, int>> ContactGuard::crossings_of(const Points& shape,
                                                            const PartTriangles& g) const {
  std::vector<std::pair<int, int>> out;
  if (g.triangles.empty()) return out;
  const auto box_of = [&](int t) {
    Eigen::AlignedBox3d b(shape.row(faces_(t, 0)).transpose());
    b.extend(shape.row(faces_(t, 1)).transpose());
    return b.extend(shape.row(faces_(t, 2)).transpose());
  };
  // A pair that the shape leaves where it is in the neutral does not cross: a triangle counts
  // when a corner moved (a still vertex is set exactly still).
  std::vector<char> displaced(static_cast<std::size_t>(shape.rows()), 0);
  for (Eigen::Index v = 0; v < shape.rows(); ++v)
    displaced[static_cast<std::size_t>(v)] = shape.row(v) != rest_.row(v);
  const auto moves = [&](int t) {
    return displaced[static_cast<std::size_t>(faces_(t, 0))] ||
           displaced[static_cast<std::size_t>(faces_(t, 1))] ||
           displaced[static_cast<std::size_t>(faces_(t, 2))];
  };
  const rig::Positions p = rig::to_positions(shape);
  // Per part, a prefilter: the other triangles whose boxes meet the part's box in this
  // shape (only moving ones when the part itself stays), then the box pairs among those (a
  // bounding-volume hierarchy over the part and what lies around it).
  for (std::size_t i = 0; i + 1 < g.start.size(); ++i) {
    const auto first = g.triangles.begin() + g.start[i],
               last = g.triangles.begin() + g.start[i + 1];
    const bool part_moves = std::any_of(first, last, moves);
    Eigen::AlignedBox3d around;
    for (auto t = first; t != last; ++t) around.extend(box_of(*t));
    std::vector<int> local(first, last);  // local triangle -> mesh triangle; the part's first
    const auto own = static_cast<std::size_t>(last - first);
    const int part = part_of(*first);
    for (int t = 0; t < static_cast<int>(faces_.rows()); ++t)
      if (part_of(t) != part && (part_moves || moves(t)) &&
          !(g.member[static_cast<std::size_t>(t)] && part_of(t) < part) &&  // that pair was seen
          box_of(t).intersects(around))
        local.push_back(t);
    if (local.size() == own && !part_moves) continue;
    Triangles sub(static_cast<Eigen::Index>(local.size()), 3);
    for (std::size_t k = 0; k < local.size(); ++k)
      sub.row(static_cast<Eigen::Index>(k)) = faces_.row(local[k]);
    std::vector<char> from(local.size(), 0);
    std::fill(from.begin(), from.begin() + static_cast<std::ptrdiff_t>(own), 1);
    for (const auto& [x, y] : rig::near_triangle_pairs(p, sub, 0.0, from)) {
      const int a = local[static_cast<std::size_t>(x)], b = local[static_cast<std::size_t>(y)];
      if (!(moves(a) || moves(b)) || !cross(shape, faces_, a, b)) continue;
      if (std::binary_search(g.neutral.begin(), g.neutral.end(),
                             std::pair{std::min(a, b), std::max(a, b)}))
        continue;
      out.emplace_back(a, b);  // x < y: the part's triangle first
    }
  }
  return out;
}

bool ContactGuard::moving_cross(const Points& shape, const std::vector<char>& moved, int a,
                                int b) const {
  return (moves_at(moved, a) || moves_at(moved, b)) && cross(shape, faces_, a, b);
}

void ContactGuard::add_contacts(const std::vector<std::pair<int, int>>& crossings,
                                const Points& reference, GuardContacts& out) const {
  const auto add = [&](int vertex, int triangle, bool turns) {
    Contact c;
    c.a = vertex;
    for (int i = 0; i < 3; ++i) c.b[static_cast<std::size_t>(i)] = faces_(triangle, i);
    if (std::any_of(out.contacts.begin(), out.contacts.end(),
                    [&](const Contact& x) { return x.a == c.a && x.b == c.b; }))
      return;
    const Eigen::Vector3d w =
        closest_on_triangle(rest_.row(vertex).transpose(), rest_.row(c.b[0]).transpose(),
                            rest_.row(c.b[1]).transpose(), rest_.row(c.b[2]).transpose());
    for (int i = 0; i < 3; ++i) c.w[static_cast<std::size_t>(i)] = w[i];
    out.contacts.push_back(c);
    out.turns.push_back(turns ||
                        (part_of_vertex(vertex) != part_of(triangle) && wrong_side(reference, c)));
  };
  for (const auto& [a, b] : crossings) {
    // Of two parts the reference may cross where the template does not (it was not cleared
    // there): then the neutral's offset, turned with the triangle.
    const bool turns = cross(reference, faces_, a, b);
    const auto is_placed = [&](int t) {
      return !placed_.empty() && placed_[static_cast<std::size_t>(t)];
    };
    if (is_placed(a) || is_placed(b)) {  // (placed, free): the free corners on the placed one
      const int fixed = is_placed(a) ? a : b, free = is_placed(a) ? b : a;
      for (int c = 0; c < 3; ++c) add(faces_(free, c), fixed, turns);
      continue;
    }
    for (int c = 0; c < 3; ++c) {
      add(faces_(a, c), b, turns);
      add(faces_(b, c), a, turns);
    }
  }
}

Points ContactGuard::targets(const GuardContacts& g, const Points& reference,
                             const Points& shape) const {
  Points out(static_cast<Eigen::Index>(g.contacts.size()), 3);
  for (std::size_t i = 0; i < g.contacts.size(); ++i) {
    const Contact& c = g.contacts[i];
    const Points& p = g.turns[i] ? shape : reference;
    Eigen::RowVector3d offset =
        g.turns[i] ? carried(rest_, shape, rest_.row(c.a), c.b) : reference.row(c.a);
    for (int j = 0; j < 3; ++j) offset -= c.w[static_cast<std::size_t>(j)] * p.row(c.b[j]);
    out.row(static_cast<Eigen::Index>(i)) = offset;
  }
  return out;
}

std::pair<int, int> ContactGuard::clear_parts(
    Points& reference, const std::vector<char>& moved,
    const std::function<bool(int, int)>& template_crosses) const {
  const auto crossing = [&]() {
    std::vector<std::pair<int, int>> out;
    for (const auto& [h, f] : part_pairs_)
      if (moving_cross(reference, moved, h, f) && !template_crosses(h, f)) out.emplace_back(h, f);
    // A floating part (a tongue) comes off the part it runs into: its corners move.
    for (const auto& [f, h] : crossings_of(reference, floating_))
      if (part_of(f) != part_of(h) && !template_crosses(f, h)) out.emplace_back(h, f);
    return out;
  };
  auto pairs = crossing();
  const int found = static_cast<int>(pairs.size());
  std::vector<char> in_region(static_cast<std::size_t>(rest_.rows()), 0);
  std::vector<int> cleared;  // vertices moved out of a part so far
  std::vector<Eigen::RowVector3d> sum(static_cast<std::size_t>(rest_.rows()));
  std::vector<int> count(static_cast<std::size_t>(rest_.rows()), 0);
  for (int step = 0; step < 5 && !pairs.empty(); ++step) {
    // Each free corner a quarter of the way more towards where it should be (no further than it
    // must), averaged over its crossing pairs.
    const double toward = std::min(1.0, 0.25 * (step + 1));
    std::vector<int> now;
    for (const auto& [h, f] : pairs) {
      const int part = part_of(h);
      const Eigen::RowVector3d centre = round_[static_cast<std::size_t>(part)]
                                            ? centre_of(reference, part)
                                            : Eigen::RowVector3d::Zero();
      for (int c = 0; c < 3; ++c) {
        const int v = faces_(f, c);
        Eigen::RowVector3d to =
            carried(rest_, reference, rest_.row(v), {faces_(h, 0), faces_(h, 1), faces_(h, 2)});
        if (round_[static_cast<std::size_t>(part)]) {  // radially, to the neutral's distance
          const Eigen::RowVector3d out = reference.row(v) - centre;
          to = centre + std::max(out.norm(), (to - centre).norm()) * out.normalized();
        }
        to = reference.row(v) + toward * (to - reference.row(v));
        if (count[static_cast<std::size_t>(v)]++ == 0) {
          now.push_back(v);
          sum[static_cast<std::size_t>(v)].setZero();
        }
        sum[static_cast<std::size_t>(v)] += to;
      }
    }
    for (int v : now) {
      reference.row(v) = sum[static_cast<std::size_t>(v)] / count[static_cast<std::size_t>(v)];
      count[static_cast<std::size_t>(v)] = 0;
      if (in_region[static_cast<std::size_t>(v)] != 2) {
        in_region[static_cast<std::size_t>(v)] = 2;
        cleared.push_back(v);
      }
    }
    // Two rings around follow smoothly: sweeps of the graph Laplacian of the displacement with
    // the cleared vertices held.
    std::vector<int> region, ring = cleared;
    for (int r = 0; r < 2; ++r) {
      std::vector<int> next;
      for (int v : ring)
        for (const auto& [u, w] : graph_.neighbours(v))
          if (!in_region[static_cast<std::size_t>(u)] && moved[static_cast<std::size_t>(u)]) {
            in_region[static_cast<std::size_t>(u)] = 1;
            next.push_back(u);
          }
      region.insert(region.end(), next.begin(), next.end());
      ring = std::move(next);
    }
    Points d = reference - rest_;
    smooth(d, region, 10);
    for (int v : region) {
      reference.row(v) = rest_.row(v) + d.row(v);
      in_region[static_cast<std::size_t>(v)] = 0;
    }
    pairs = crossing();
  }
  return {found, static_cast<int>(pairs.size())};
}

std::pair<int, int> ContactGuard::lift_attached(Points& shape) const {
  const auto crossing = [&] {
    std::vector<std::pair<int, int>> out;  // (attached triangle, the skin's)
    for (const auto& [a, b] : crossings_of(shape, attached_))
      if (part_of(b) == parts_.skin) out.emplace_back(a, b);
    return out;
  };
  auto pairs = crossing();
  const int found = static_cast<int>(pairs.size());
  std::vector<Eigen::RowVector3d> sum(static_cast<std::size_t>(rest_.rows()));
  std::vector<int> count(static_cast<std::size_t>(rest_.rows()), 0);
  for (int step = 0; step < 3 && !pairs.empty(); ++step) {
    // Each corner of the attached triangle where the crossed triangle carries it from the
    // neutral (on its side there), averaged over its pairs.
    std::vector<int> now;
    for (const auto& [a, b] : pairs)
      for (int c = 0; c < 3; ++c) {
        const int v = faces_(a, c);
        if (count[static_cast<std::size_t>(v)]++ == 0) {
          now.push_back(v);
          sum[static_cast<std::size_t>(v)].setZero();
        }
        sum[static_cast<std::size_t>(v)] +=
            carried(rest_, shape, rest_.row(v), {faces_(b, 0), faces_(b, 1), faces_(b, 2)});
      }
    for (int v : now) {
      shape.row(v) = sum[static_cast<std::size_t>(v)] / count[static_cast<std::size_t>(v)];
      count[static_cast<std::size_t>(v)] = 0;
    }
    pairs = crossing();
  }
  return {found, static_cast<int>(pairs.size())};
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
  std::vector<std::size_t> near;                 // the region's watched pairs, each once:
  std::vector<int> listed(watched_.size(), -1);  // the step that listed a pair
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
    smooth(d, region, 2);
    near.clear();
    for (int v : region) {
      reference.row(v) = rest_.row(v) + d.row(v);
      for (int k = pair_start_[static_cast<std::size_t>(v)];
           k < pair_start_[static_cast<std::size_t>(v) + 1]; ++k)
        if (const auto i = static_cast<std::size_t>(pair_index_[static_cast<std::size_t>(k)]);
            listed[i] != step) {
          listed[i] = step;
          near.push_back(i);
        }
    }
    pairs = crossing(near);
    std::sort(pairs.begin(), pairs.end());  // the region grows in pair order
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

TemplateCrossings::TemplateCrossings(const rig::Rig& tmpl, const TriangleMap& map,
                                     const std::vector<Points>& shapes)
    : sites_(tmpl, map, 3), shapes_(shapes), answers_(shapes.size()) {}

bool TemplateCrossings::crosses(std::size_t k, int a, int b) {
  const auto key = (static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint32_t>(b);
  const auto [it, fresh] = answers_[k].try_emplace(key, false);
  if (fresh) it->second = sites_.crosses_at(shapes_[k], a, b);
  return it->second;
}

}  // namespace facecast::rigbuild
