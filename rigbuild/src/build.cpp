#include "facecast/rigbuild/build.hpp"

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <map>
#include <numeric>
#include <optional>
#include <tuple>
#include <unordered_map>

#include "contacts.hpp"
#include "facecast/core/config.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/rigbuild/quality.hpp"
#include "geometry.hpp"
#include "mesh_graph.hpp"
#include "parallel.hpp"

namespace facecast::rigbuild {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

Points to_points(const anim::Positions& p) {
  return p.cast<double>();
}
Faces to_faces(const anim::Triangles& t) {
  return t;
}

// Rigid motion x -> R x + t that best maps `from` onto `to` (Kabsch), and its RMS residual.
struct Rigid {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  double rms = 0;
};
Rigid fit_rigid(const Points& from, const Points& to) {
  const Eigen::RowVector3d cf = from.colwise().mean(), ct = to.colwise().mean();
  const Eigen::Matrix3d H = (from.rowwise() - cf).transpose() * (to.rowwise() - ct);
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1 : 1;
  Rigid r;
  r.R = svd.matrixV() * D * svd.matrixU().transpose();
  r.t = ct.transpose() - r.R * cf.transpose();
  const Points moved = (from * r.R.transpose()).rowwise() + r.t.transpose();
  r.rms = std::sqrt((moved - to).rowwise().squaredNorm().mean());
  return r;
}

double diagonal(const Points& p) {
  return p.rows() ? (p.colwise().maxCoeff() - p.colwise().minCoeff()).norm() : 0.0;
}

Eigen::RowVector3d at(const Points& p, const SurfacePoint& s) {
  return s.w[0] * p.row(s.v[0]) + s.w[1] * p.row(s.v[1]) + s.w[2] * p.row(s.v[2]);
}

// Template parts for the correspondence: each connected component labelled by its most common
// material, so that, say, all 32 teeth of the ICT FaceKit form one part. One material: components.
std::vector<int> template_parts(const anim::Rig& tmpl) {
  if (tmpl.materials.size() < 2) return {};
  const anim::Components comps = anim::connected_components(tmpl.vertex_count(), tmpl.triangles);
  std::vector<std::map<int, int>> count(static_cast<std::size_t>(comps.count));
  for (int t = 0; t < tmpl.triangle_count(); ++t) {
    ++count[static_cast<std::size_t>(comps.label[tmpl.triangles(t, 0)])][tmpl.triangle_material[t]];
  }
  std::vector<int> part_of(static_cast<std::size_t>(comps.count));
  for (int c = 0; c < comps.count; ++c) {
    const auto& m = count[static_cast<std::size_t>(c)];
    part_of[static_cast<std::size_t>(c)] =
        std::max_element(m.begin(), m.end(), [](auto& a, auto& b) {
          return a.second < b.second;
        })->first;
  }
  std::vector<int> parts(static_cast<std::size_t>(tmpl.triangle_count()));
  for (int t = 0; t < tmpl.triangle_count(); ++t) {
    parts[static_cast<std::size_t>(t)] =
        part_of[static_cast<std::size_t>(comps.label[tmpl.triangles(t, 0)])];
  }
  return parts;
}

// The template's rigid parts: connected components that every shape moves rigidly (teeth,
// eyeballs), those of one part of template_parts() that move together joined -- the ICT's 16
// upper teeth are one rigid part, its 16 lower teeth another.
struct RigidParts {
  std::vector<int> of_vertex;              // per template vertex: its rigid part, or -1
  std::vector<std::vector<Rigid>> motion;  // per part, per shape
};
RigidParts rigid_parts(const anim::Rig& tmpl, const Points& rest, const std::vector<Points>& shapes,
                       double tolerance) {
  const anim::Components comps = anim::connected_components(tmpl.vertex_count(), tmpl.triangles);
  const std::vector<int> parts = template_parts(tmpl);
  std::vector<std::vector<int>> members(static_cast<std::size_t>(comps.count));
  for (int v = 0; v < tmpl.vertex_count(); ++v)
    if (const int c = comps.label[static_cast<std::size_t>(v)]; c >= 0)
      members[static_cast<std::size_t>(c)].push_back(v);
  std::vector<int> material(static_cast<std::size_t>(comps.count), -1);
  for (int t = 0; t < tmpl.triangle_count(); ++t)
    material[static_cast<std::size_t>(comps.label[tmpl.triangles(t, 0)])] =
        parts.empty() ? comps.label[tmpl.triangles(t, 0)] : parts[static_cast<std::size_t>(t)];
  const auto rows = [](const Points& p, const std::vector<int>& vertices) {
    Points out(static_cast<Eigen::Index>(vertices.size()), 3);
    for (std::size_t i = 0; i < vertices.size(); ++i)
      out.row(static_cast<Eigen::Index>(i)) = p.row(vertices[i]);
    return out;
  };
  const auto fit = [&](const std::vector<int>& vertices) {
    const Points from = rows(rest, vertices);
    std::vector<Rigid> motion;
    for (const Points& shape : shapes) motion.push_back(fit_rigid(from, rows(shape, vertices)));
    return motion;
  };
  // Every shape moves `vertices` by `motion` within the tolerance (relative to their size).
  const auto moves_by = [&](const std::vector<int>& vertices, const std::vector<Rigid>& motion) {
    const Points from = rows(rest, vertices);
    const double size = std::max(diagonal(from), 1e-12);
    for (std::size_t k = 0; k < shapes.size(); ++k) {
      const Points moved = (from * motion[k].R.transpose()).rowwise() + motion[k].t.transpose();
      if (std::sqrt((moved - rows(shapes[k], vertices)).rowwise().squaredNorm().mean()) >
          tolerance * size)
        return false;
    }
    return true;
  };
  RigidParts out;
  out.of_vertex.assign(static_cast<std::size_t>(tmpl.vertex_count()), -1);
  std::vector<std::vector<int>> part_members;
  std::vector<int> part_material;
  for (int c = 0; c < comps.count; ++c) {
    const auto& mem = members[static_cast<std::size_t>(c)];
    if (mem.size() < 3) continue;
    std::vector<Rigid> own = fit(mem);
    if (!moves_by(mem, own)) continue;
    std::size_t p = 0;
    while (p < part_members.size() && !(part_material[p] == material[static_cast<std::size_t>(c)] &&
                                        moves_by(mem, out.motion[p])))
      ++p;
    if (p == part_members.size()) {
      part_members.emplace_back();
      part_material.push_back(material[static_cast<std::size_t>(c)]);
      out.motion.push_back(std::move(own));
    }
    part_members[p].insert(part_members[p].end(), mem.begin(), mem.end());
    for (int v : mem) out.of_vertex[static_cast<std::size_t>(v)] = static_cast<int>(p);
  }
  for (std::size_t p = 0; p < part_members.size(); ++p) out.motion[p] = fit(part_members[p]);
  return out;
}

// The closest triangles of one component of a mesh: a k-d tree over its vertices, then the
// triangles at the 8 nearest of them.
class ComponentSurface {
 public:
  ComponentSurface(const Points& p, const Faces& f, const std::vector<int>& label, int component)
      : p_(p),
        f_(f),
        index_(vertices_of(p, label, component)),
        at_(static_cast<std::size_t>(p.rows())) {
    for (Eigen::Index t = 0; t < f.rows(); ++t) {
      if (label[static_cast<std::size_t>(f(t, 0))] != component) continue;
      for (int c = 0; c < 3; ++c)
        at_[static_cast<std::size_t>(f(t, c))].push_back(static_cast<int>(t));
    }
  }
  /// The corners of the closest triangle to q, and the distance.
  std::pair<std::array<int, 3>, double> closest(const Eigen::RowVector3d& q) const {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    const Eigen::Vector3d x = q.transpose();
    index_.nearest(x.data(), 8, idx, d2);
    std::pair<std::array<int, 3>, double> best{{}, std::numeric_limits<double>::infinity()};
    for (const std::uint32_t i : idx) {
      for (const int t : at_[static_cast<std::size_t>(vertex_[i])]) {
        const std::array<int, 3> c{f_(t, 0), f_(t, 1), f_(t, 2)};
        const Eigen::Vector3d w = closest_on_triangle(
            x, p_.row(c[0]).transpose(), p_.row(c[1]).transpose(), p_.row(c[2]).transpose());
        const double d =
            (w[0] * p_.row(c[0]) + w[1] * p_.row(c[1]) + w[2] * p_.row(c[2]) - q).norm();
        if (d < best.second) best = {c, d};
      }
    }
    return best;
  }

 private:
  Points vertices_of(const Points& p, const std::vector<int>& label, int component) {
    for (Eigen::Index v = 0; v < p.rows(); ++v)
      if (label[static_cast<std::size_t>(v)] == component) vertex_.push_back(static_cast<int>(v));
    Points out(static_cast<Eigen::Index>(vertex_.size()), 3);
    for (std::size_t i = 0; i < vertex_.size(); ++i)
      out.row(static_cast<Eigen::Index>(i)) = p.row(vertex_[i]);
    return out;
  }
  const Points& p_;
  const Faces& f_;
  std::vector<int> vertex_;  // the component's vertices, in the index's order (filled by
                             // vertices_of() while index_, declared after it, is built)
  PointIndex index_;
  std::vector<std::vector<int>> at_;  // per vertex, the component's triangles at it
};

}  // namespace

BuildResult build_rig(const anim::Rig& tmpl, const anim::Rig& target, const BuildOptions& options,
                      const ProgressFn& progress) {
  const auto t_start = Clock::now();
  tmpl.validate("template");
  target.validate("target");
  if (tmpl.shapes.empty()) throw Error("template: rig has no blendshapes");
  if (options.lambda < 0) throw Error("--lambda must not be negative");

  BuildResult result;
  const Points src_rest = to_points(tmpl.positions);
  const Faces src_faces = to_faces(tmpl.triangles);
  const Points tgt_rest = to_points(target.positions);
  const Faces tgt_faces = to_faces(target.triangles);
  const int nv = target.vertex_count();
  for (int v : options.fixed) {
    if (v < 0 || v >= nv) {
      throw Error("--fixed: vertex " + std::to_string(v) + " out of range (" + std::to_string(nv) +
                  " vertices)");
    }
  }

  // 1. Correspondence.
  report(progress, "correspondence", 0.0);
  auto t0 = Clock::now();
  std::optional<Correspondence> same =
      options.markers.empty()
          ? same_topology_correspondence(tmpl.vertex_count(), src_faces, nv, tgt_faces)
          : std::nullopt;
  const bool same_topology = same.has_value();
  Correspondence corr;
  if (same) {
    corr = std::move(*same);
  } else {
    if (options.markers.empty()) {
      throw Error("target: topology differs from the template (" + std::to_string(nv) + " vs " +
                  std::to_string(tmpl.vertex_count()) + " vertices); give --markers");
    }
    const auto markers = read_markers(options.markers, tmpl.vertex_count(), nv);
    if (!options.correspondence.empty() && std::filesystem::exists(options.correspondence)) {
      corr = load_correspondence(options.correspondence, tmpl.vertex_count(), tmpl.triangle_count(),
                                 nv, target.triangle_count());
    } else {
      corr = compute_correspondence(src_rest, src_faces, template_parts(tmpl), tgt_rest, tgt_faces,
                                    markers, options.registration, progress);
      if (!options.correspondence.empty()) save_correspondence(options.correspondence, corr);
    }
  }
  result.timings.correspondence = seconds_since(t0);

  // 2. Source gradients of every template shape (independent: all cores).
  report(progress, "gradients", 0.0);
  t0 = Clock::now();
  const auto rest_inv = rest_frames_inverse(src_rest, src_faces, "template");
  const std::size_t n_shapes = tmpl.shapes.size();
  std::vector<Points> src_shape(n_shapes);
  std::vector<Gradients> grads(n_shapes);
  parallel_for(n_shapes, [&](std::size_t k) {
    src_shape[k] = src_rest;
    const auto& s = tmpl.shapes[k];
    for (std::size_t i = 0; i < s.vertices.size(); ++i) {
      src_shape[k].row(s.vertices[i]) += s.deltas.row(static_cast<Eigen::Index>(i)).cast<double>();
    }
    source_gradients(rest_inv, src_shape[k], src_faces, grads[k]);
  });
  result.timings.gradients = seconds_since(t0);

  // 3. Which target vertices the template moves, per shape, through the vertex map.
  const double still = options.still_tolerance * diagonal(src_rest);
  std::vector<std::vector<char>> moves(n_shapes,
                                       std::vector<char>(static_cast<std::size_t>(nv), 0));
  std::vector<char> ever_moves(static_cast<std::size_t>(nv), 0);
  parallel_for(n_shapes, [&](std::size_t k) {
    for (int v = 0; v < nv; ++v) {
      const SurfacePoint& sp = corr.vertex_map[static_cast<std::size_t>(v)];
      const double d = (at(src_shape[k], sp) - at(src_rest, sp)).norm();
      moves[k][static_cast<std::size_t>(v)] = d >= still;
    }
  });
  for (std::size_t k = 0; k < n_shapes; ++k) {
    for (int v = 0; v < nv; ++v)
      ever_moves[static_cast<std::size_t>(v)] |= moves[k][static_cast<std::size_t>(v)];
  }

  // 4. Anchoring, component by component.
  const anim::Components comps = anim::connected_components(nv, target.triangles);
  std::vector<char> is_fixed(static_cast<std::size_t>(nv), 0);
  for (int v = 0; v < nv; ++v)
    is_fixed[static_cast<std::size_t>(v)] =
        !ever_moves[static_cast<std::size_t>(v)] || comps.label[static_cast<std::size_t>(v)] < 0;
  for (int v : options.fixed) is_fixed[static_cast<std::size_t>(v)] = 1;
  std::vector<std::vector<int>> members(static_cast<std::size_t>(comps.count));
  for (int v = 0; v < nv; ++v) {
    if (comps.label[static_cast<std::size_t>(v)] >= 0)
      members[static_cast<std::size_t>(comps.label[static_cast<std::size_t>(v)])].push_back(v);
  }
  int largest = 0;
  for (int c = 1; c < comps.count; ++c) {
    if (members[static_cast<std::size_t>(c)].size() >
        members[static_cast<std::size_t>(largest)].size())
      largest = c;
  }
  struct Floating {
    int component;
    bool rigid;
    int anchor;
    Eigen::RowVector3d pivot;
    std::vector<Rigid> motion;  // per shape, in template coordinates about the template pivot
    Eigen::RowVector3d src_pivot;
    std::vector<std::array<int, 3>> carrier;  // attached: per member, the skin triangle under it
  };
  std::vector<Floating> floating;
  std::optional<RigidParts> rigid;
  std::optional<ComponentSurface> skin;
  double median_edge = 0;
  if (!same_topology) {
    median_edge = MeshGraph(tgt_rest, tgt_faces).median_edge_length();
    rigid = rigid_parts(tmpl, src_rest, src_shape, options.rigid_tolerance);
    skin.emplace(tgt_rest, tgt_faces, comps.label, largest);
  }
  result.components.resize(static_cast<std::size_t>(comps.count));
  for (int c = 0; c < comps.count; ++c) {
    const auto& mem = members[static_cast<std::size_t>(c)];
    auto& info = result.components[static_cast<std::size_t>(c)];
    info.vertices = static_cast<int>(mem.size());
    // Same topology: a component with still vertices is held by them. Another topology maps the
    // small parts (teeth, eyes, lashes) less exactly, and a few still vertices would tear them:
    // only the largest component is held that way; the others float unless all of them are still.
    const bool any_still = std::any_of(
        mem.begin(), mem.end(), [&](int v) { return is_fixed[static_cast<std::size_t>(v)]; });
    const bool all_still = std::all_of(
        mem.begin(), mem.end(), [&](int v) { return is_fixed[static_cast<std::size_t>(v)]; });
    const bool anchored = all_still || (any_still && (same_topology || c == largest));
    if (anchored) {
      const bool all = std::all_of(mem.begin(), mem.end(),
                                   [&](int v) { return is_fixed[static_cast<std::size_t>(v)]; });
      info.placement = all ? "fixed" : "anchored";
      continue;
    }
    for (int v : mem) is_fixed[static_cast<std::size_t>(v)] = 0;
    Floating fl;
    fl.component = c;
    Points from(static_cast<Eigen::Index>(mem.size()), 3),
        tgt(static_cast<Eigen::Index>(mem.size()), 3);
    for (std::size_t i = 0; i < mem.size(); ++i) {
      from.row(static_cast<Eigen::Index>(i)) =
          at(src_rest, corr.vertex_map[static_cast<std::size_t>(mem[i])]);
      tgt.row(static_cast<Eigen::Index>(i)) = tgt_rest.row(mem[i]);
    }
    fl.src_pivot = from.colwise().mean();
    fl.pivot = tgt.colwise().mean();
    const double size = std::max(diagonal(from), 1e-12);
    fl.rigid = true;
    Points to(from.rows(), 3);
    for (std::size_t k = 0; k < n_shapes; ++k) {
      for (std::size_t i = 0; i < mem.size(); ++i) {
        to.row(static_cast<Eigen::Index>(i)) =
            at(src_shape[k], corr.vertex_map[static_cast<std::size_t>(mem[i])]);
      }
      fl.motion.push_back(fit_rigid(from, to));
      if (fl.motion.back().rms > options.rigid_tolerance * size) fl.rigid = false;
    }
    // Another topology's teeth sit partly on the template's gums and lips, so the points they map
    // to do not move rigidly. If at least a third of its vertices map onto the template's rigid
    // parts, the component moves with the one that most of them map onto.
    if (!fl.rigid && rigid) {
      std::map<int, int> votes;
      for (int v : mem) {
        const SurfacePoint& sp = corr.vertex_map[static_cast<std::size_t>(v)];
        Eigen::Index heaviest = 0;
        sp.w.maxCoeff(&heaviest);
        if (const int p = rigid->of_vertex[static_cast<std::size_t>(sp.v[heaviest])]; p >= 0)
          ++votes[p];
      }
      int landed = 0;
      auto best_part = votes.end();
      for (auto it = votes.begin(); it != votes.end(); ++it) {
        landed += it->second;
        if (best_part == votes.end() || it->second > best_part->second) best_part = it;
      }
      if (3 * landed >= static_cast<int>(mem.size())) {
        fl.rigid = true;
        fl.motion = rigid->motion[static_cast<std::size_t>(best_part->first)];
      }
    }
    // The anchor: the member closest to the pivot.
    fl.anchor = mem[0];
    double best = std::numeric_limits<double>::max();
    for (int v : mem) {
      const double d = (tgt_rest.row(v) - fl.pivot).squaredNorm();
      if (d < best) {
        best = d;
        fl.anchor = v;
      }
    }
    // Another topology's thin parts that lie on the skin (eyelashes on the lids: most of their
    // vertices within a median edge of it) are carried by it, each vertex with its closest skin
    // triangle as it sat on it in the neutral; transferred on their own through the template's
    // lashes and lids they leave the lids.
    if (!fl.rigid && skin && c != largest) {
      std::vector<std::array<int, 3>> carrier;
      std::size_t on_skin = 0;
      for (int v : mem) {
        const auto [t, distance] = skin->closest(tgt_rest.row(v));
        carrier.push_back(t);
        on_skin += distance <= median_edge;
      }
      if (2 * on_skin >= mem.size()) fl.carrier = std::move(carrier);
    }
    info.placement = fl.rigid ? "rigid" : fl.carrier.empty() ? "floating" : "attached";
    floating.push_back(std::move(fl));
  }

  // Vertices of floating components move with their component, still or not.
  std::vector<char> floats(static_cast<std::size_t>(nv), 0);
  for (const auto& fl : floating) {
    for (int v : members[static_cast<std::size_t>(fl.component)])
      floats[static_cast<std::size_t>(v)] = !same_topology;
  }
  std::vector<int> dirichlet;
  std::vector<int> owner(static_cast<std::size_t>(nv),
                         -1);  // floating index for rigid/anchor vertices
  for (std::size_t f = 0; f < floating.size(); ++f) {
    const auto& fl = floating[f];
    if (fl.rigid) {
      for (int v : members[static_cast<std::size_t>(fl.component)])
        owner[static_cast<std::size_t>(v)] = static_cast<int>(f);
    } else {
      owner[static_cast<std::size_t>(fl.anchor)] = static_cast<int>(f);
    }
  }
  for (int v = 0; v < nv; ++v) {
    if (is_fixed[static_cast<std::size_t>(v)] || owner[static_cast<std::size_t>(v)] >= 0)
      dirichlet.push_back(v);
  }
  result.fixed_vertices = static_cast<int>(std::count(is_fixed.begin(), is_fixed.end(), 1));

  // 5. Virtual edges on the target neutral.
  report(progress, "virtual edges", 0.0);
  t0 = Clock::now();
  switch (options.virtual_edges) {
    case VirtualEdgeMode::kAuto:
    case VirtualEdgeMode::kOff:  // still detected: the report measures the gaps they span
      result.virtual_edges =
          detect_virtual_edges(tgt_rest, tgt_faces, options.ve, &result.ve_stats);
      break;
    case VirtualEdgeMode::kFile:
      result.virtual_edges = read_virtual_edges_json(options.virtual_edges_file, nv);
      break;
  }
  const bool use_edges = options.virtual_edges != VirtualEdgeMode::kOff;
  result.timings.detect = seconds_since(t0);

  // 6. Factor once.
  report(progress, "factor", 0.0);
  TransferSetup setup;
  setup.target_rest = tgt_rest;
  setup.target_faces = tgt_faces;
  setup.map = corr.map;
  result.triangle_map = corr.map;
  if (use_edges) setup.virtual_edges = result.virtual_edges;
  setup.lambda = options.lambda;
  setup.dirichlet = dirichlet;
  setup.solver = options.solver;
  const Transfer transfer(std::move(setup));
  result.timings.factor = transfer.factor_seconds();
  result.factor_nonzeros = transfer.factor_nonzeros();

  // 7. The copy of each shape: the template's displacement copied vertex by vertex (for the same
  // topology, the ICT ground truth's construction). Each virtual edge follows it: the target gap
  // e changes as the template gap r does, e' = e + (r' - r) = copy_a - copy_b. (Scaling the
  // change by |e|/|r| breaks translations such as jawForward at thin mouth corners: the ICT test
  // gained 28 crossing pairs with it.)
  std::vector<Points> copied(n_shapes, tgt_rest);
  parallel_for(n_shapes, [&](std::size_t k) {
    for (int v = 0; v < nv; ++v) {
      const SurfacePoint& sp = corr.vertex_map[static_cast<std::size_t>(v)];
      // In the target's frame and units (the correspondence's similarity).
      copied[k].row(v) +=
          corr.scale * (at(src_shape[k], sp) - at(src_rest, sp)) * corr.rotation.transpose();
    }
  });
  // Placed vertices (still, or moved rigidly with their part) have their places; the copy takes
  // them too, so the edges and contacts at them measure from where they are.
  std::vector<Points> prescribed(n_shapes);
  for (std::size_t k = 0; k < n_shapes; ++k) {
    Points& P = prescribed[k];
    P.resize(static_cast<Eigen::Index>(dirichlet.size()), 3);
    for (std::size_t i = 0; i < dirichlet.size(); ++i) {
      const int v = dirichlet[i];
      const int f = owner[static_cast<std::size_t>(v)];
      if (f < 0) {
        P.row(static_cast<Eigen::Index>(i)) = tgt_rest.row(v);
        continue;
      }
      // The template component's rigid motion, applied about the target component's own pivot
      // (in the target's frame and units: the correspondence's similarity).
      const Floating& fl = floating[static_cast<std::size_t>(f)];
      const Rigid& m = fl.motion[k];
      const Eigen::Matrix3d turn = corr.rotation * m.R * corr.rotation.transpose();
      const Eigen::RowVector3d pivot_shift =
          (m.R * fl.src_pivot.transpose() + m.t).transpose() - fl.src_pivot;
      P.row(static_cast<Eigen::Index>(i)) = (tgt_rest.row(v) - fl.pivot) * turn.transpose() +
                                            fl.pivot +
                                            corr.scale * pivot_shift * corr.rotation.transpose();
    }
    for (std::size_t i = 0; i < dirichlet.size(); ++i)
      copied[k].row(dirichlet[i]) = P.row(static_cast<Eigen::Index>(i));
  }
  // The contacts' reference: the copy, moved out of the rigidly moved parts where it crosses them
  // and smoothed where it crosses itself, where the template does not (a target's fuller lips and
  // lids closed as far as the template's; lips that lie on the teeth; a mouth corner that the
  // correspondence splits between the lips). The edges keep the copy: they close the lids, the
  // contacts keep them from crossing.
  result.quality.resize(n_shapes);
  std::vector<Points> reference;
  std::optional<ContactGuard> guard;
  std::optional<ReferenceCrossings> template_sites;
  // Does the template's shape k cross where built triangles a and b sit? Asked again and again
  // for the same pairs while the reference is cleared and the contacts are solved: kept per
  // shape (each shape is one task).
  std::vector<std::unordered_map<std::uint64_t, bool>> template_answers(n_shapes);
  const auto template_cross = [&](std::size_t k, int a, int b) {
    const auto key = (static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint32_t>(b);
    const auto [it, fresh] = template_answers[k].try_emplace(key, false);
    if (fresh) it->second = template_sites->crosses_at(src_shape[k], a, b);
    return it->second;
  };
  if (options.contacts.enabled) {
    template_sites.emplace(tmpl, corr.map, 3);
    report(progress, "contacts", 0.0);
    t0 = Clock::now();
    std::vector<char> held(static_cast<std::size_t>(nv), 0);  // moved rigidly with their part
    for (int v = 0; v < nv; ++v)
      held[static_cast<std::size_t>(v)] =
          owner[static_cast<std::size_t>(v)] >= 0 &&
          floating[static_cast<std::size_t>(owner[static_cast<std::size_t>(v)])].rigid;
    guard.emplace(tgt_rest, tgt_faces, comps.label, held, options.contacts.margin,
                  options.contacts.part_margin);
    result.watched_pairs = guard->watched();
    reference = copied;
    parallel_for(n_shapes, [&](std::size_t k) {
      const auto template_crosses = [&](int a, int b) { return template_cross(k, a, b); };
      std::tie(result.quality[k].part_crossings, result.quality[k].part_crossings_left) =
          guard->clear_parts(reference[k], moves[k], template_crosses);
      std::tie(result.quality[k].copy_crossings, result.quality[k].copy_crossings_left) =
          guard->untangle(reference[k], moves[k], template_crosses);
    });
    result.timings.contacts = seconds_since(t0);
  }

  // 8. Solve every shape: prescribed positions, then one block solve.
  report(progress, "solve", 0.0);
  t0 = Clock::now();
  const std::size_t ne = result.virtual_edges.size();
  std::vector<Points> edge_targets(ne ? n_shapes : 0);
  parallel_for(edge_targets.size(), [&](std::size_t k) {
    Points& E = edge_targets[k];
    E.resize(static_cast<Eigen::Index>(ne), 3);
    for (std::size_t i = 0; i < ne; ++i) {
      const auto& ve = result.virtual_edges[i];
      E.row(static_cast<Eigen::Index>(i)) = copied[k].row(ve.a) - copied[k].row(ve.b);
    }
  });
  std::vector<const Gradients*> src_ptrs(n_shapes);
  for (std::size_t k = 0; k < n_shapes; ++k) src_ptrs[k] = &grads[k];
  // Solve in blocks so the right-hand sides stay small; report progress per block.
  std::vector<Points> solved(n_shapes);
  const std::size_t block = 20;
  for (std::size_t b = 0; b < n_shapes; b += block) {
    const std::size_t e = std::min(n_shapes, b + block);
    std::vector<const Gradients*> s(src_ptrs.begin() + static_cast<long>(b),
                                    src_ptrs.begin() + static_cast<long>(e));
    std::vector<Points> p(prescribed.begin() + static_cast<long>(b),
                          prescribed.begin() + static_cast<long>(e));
    std::vector<Points> et;
    if (ne)
      et.assign(edge_targets.begin() + static_cast<long>(b),
                edge_targets.begin() + static_cast<long>(e));
    auto out = transfer.solve(s, p, et);
    for (std::size_t k = b; k < e; ++k) solved[k] = std::move(out[k - b]);
    report(progress, "solve", static_cast<double>(e) / static_cast<double>(n_shapes));
  }
  // Vertices the template shape leaves still stay exactly still (contacts hold them too).
  const auto is_still = [&](std::size_t k, int v) {
    return !moves[k][static_cast<std::size_t>(v)] && !floats[static_cast<std::size_t>(v)];
  };
  parallel_for(n_shapes, [&](std::size_t k) {
    for (int v = 0; v < nv; ++v)
      if (is_still(k, v)) solved[k].row(v) = tgt_rest.row(v);
  });
  result.timings.solve = seconds_since(t0);

  // 9. Contacts: watched triangle pairs that cross where the reference does not (contacts.hpp).
  if (guard) {
    t0 = Clock::now();
    parallel_for(n_shapes, [&](std::size_t k) {
      const Points& ref = reference[k];
      const auto template_crosses = [&](int a, int b) { return template_cross(k, a, b); };
      auto crossing = guard->new_crossings(solved[k], ref, moves[k], template_crosses);
      ShapeQuality& q = result.quality[k];
      q.crossings = static_cast<int>(crossing.size());
      if (crossing.empty()) return;
      std::vector<char> held(static_cast<std::size_t>(nv));
      for (int v = 0; v < nv; ++v) held[static_cast<std::size_t>(v)] = is_still(k, v);
      const Points transferred = solved[k];
      GuardContacts contacts;
      double weight = options.contacts.weight;
      for (int round = 0; round < options.contacts.rounds && !crossing.empty(); ++round) {
        guard->add_contacts(crossing, ref, contacts);
        solved[k] =
            transfer.solve_with_contacts(transferred, held, contacts.contacts,
                                         guard->targets(contacts, ref, transferred), weight);
        crossing = guard->new_crossings(solved[k], ref, moves[k], template_crosses);
        weight *= 10;
      }
      q.crossings_left = static_cast<int>(crossing.size());
      q.contacts = static_cast<int>(contacts.contacts.size());
    });
    result.timings.contacts += seconds_since(t0);
  }

  // Attached parts ride on the skin (after the contacts have placed it).
  for (const auto& fl : floating) {
    if (fl.carrier.empty()) continue;
    const auto& mem = members[static_cast<std::size_t>(fl.component)];
    parallel_for(n_shapes, [&](std::size_t k) {
      for (std::size_t i = 0; i < mem.size(); ++i)
        solved[k].row(mem[i]) = carried(tgt_rest, solved[k], tgt_rest.row(mem[i]), fl.carrier[i]);
    });
  }

  // 10. Deltas.
  result.rig = target;
  result.rig.shapes.clear();
  const double tgt_diag = diagonal(tgt_rest);
  const float keep = static_cast<float>(1e-7 * tgt_diag);
  for (std::size_t k = 0; k < n_shapes; ++k) {
    const anim::Positions d = (solved[k] - tgt_rest).cast<float>();
    result.rig.shapes.push_back(anim::Blendshape::from_dense(tmpl.shapes[k].name, d, keep));
    ShapeQuality& q = result.quality[k];
    q.shape = tmpl.shapes[k].name;
    q.max_displacement = result.rig.shapes.back().max_displacement();
    q.min_gap = ne ? std::numeric_limits<double>::max() : 0.0;
    for (std::size_t i = 0; i < ne; ++i) {
      const auto& ve = result.virtual_edges[i];
      const double rest = (tgt_rest.row(ve.a) - tgt_rest.row(ve.b)).norm();
      if (rest < 1e-9 * tgt_diag) continue;  // coincident vertices: no gap to measure
      const Eigen::RowVector3f got = result.rig.positions.row(ve.a) + d.row(ve.a) -
                                     result.rig.positions.row(ve.b) - d.row(ve.b);
      const double built = 10.0 * got.cast<double>().norm() / rest;
      const double wanted = 10.0 * edge_targets[k].row(static_cast<Eigen::Index>(i)).norm() / rest;
      q.gap_change += std::abs(built - wanted) / static_cast<double>(ne);
      // A gap that flips direction has crossed: count it as closed.
      const double sign =
          got.cast<double>().dot(tgt_rest.row(ve.a) - tgt_rest.row(ve.b)) < 0 ? 0.0 : 1.0;
      q.min_gap = std::min(q.min_gap, sign * built);
    }
  }
  result.timings.total = seconds_since(t_start);
  report(progress, "done", 1.0);
  return result;
}

BuildOptions load_build_options() {
  const auto path = config_path("rigbuild/build.json");
  const nlohmann::json j = load_json(path);
  const auto get = [&](const nlohmann::json& obj, const char* key, auto& value,
                       const std::string& where) {
    if (!obj.contains(key)) throw Error(path.string() + ": missing field '" + where + key + "'");
    try {
      obj.at(key).get_to(value);
    } catch (const nlohmann::json::exception&) {
      throw Error(path.string() + ": field '" + where + key + "' has the wrong type");
    }
  };
  BuildOptions o;
  std::string mode, solver;
  get(j, "virtual_edges", mode, "");
  if (mode == "auto")
    o.virtual_edges = VirtualEdgeMode::kAuto;
  else if (mode == "off")
    o.virtual_edges = VirtualEdgeMode::kOff;
  else
    throw Error(path.string() + ": field 'virtual_edges' must be auto or off");
  get(j, "lambda", o.lambda, "");
  get(j, "still_tolerance", o.still_tolerance, "");
  get(j, "rigid_tolerance", o.rigid_tolerance, "");
  get(j, "solver", solver, "");
  if (solver != "cholmod" && solver != "eigen")
    throw Error(path.string() + ": field 'solver' must be cholmod or eigen");
  o.solver = solver == "eigen" ? SolverKind::kEigenLDLT : SolverKind::kCholmod;
  if (!j.contains("ve") || !j.contains("registration"))
    throw Error(path.string() + ": needs the 've' and 'registration' sections");
  const auto& ve = j.at("ve");
  get(ve, "d", o.ve.d, "ve.");
  get(ve, "f", o.ve.f, "ve.");
  get(ve, "per_vertex", o.ve.per_vertex, "ve.");
  get(ve, "spacing", o.ve.spacing, "ve.");
  if (!j.contains("contacts")) throw Error(path.string() + ": needs the 'contacts' section");
  const auto& contacts = j.at("contacts");
  get(contacts, "enabled", o.contacts.enabled, "contacts.");
  get(contacts, "margin", o.contacts.margin, "contacts.");
  get(contacts, "part_margin", o.contacts.part_margin, "contacts.");
  get(contacts, "weight", o.contacts.weight, "contacts.");
  get(contacts, "rounds", o.contacts.rounds, "contacts.");
  const auto& reg = j.at("registration");
  get(reg, "closest_weights", o.registration.closest_weights, "registration.");
  get(reg, "iterations_per_step", o.registration.iterations_per_step, "registration.");
  get(reg, "smoothness", o.registration.smoothness, "registration.");
  get(reg, "identity", o.registration.identity, "registration.");
  get(reg, "rest_pull", o.registration.rest_pull, "registration.");
  get(reg, "max_distance", o.registration.max_distance, "registration.");
  return o;
}

nlohmann::json build_report_json(const BuildResult& r, const BuildOptions& options) {
  nlohmann::json j;
  const bool edges_on = options.virtual_edges != VirtualEdgeMode::kOff;
  j["vertices"] = r.rig.vertex_count();
  j["virtual_edges"] = {{"mode", options.virtual_edges == VirtualEdgeMode::kAuto   ? "auto"
                                 : options.virtual_edges == VirtualEdgeMode::kFile ? "file"
                                                                                   : "off"},
                        {"count", edges_on ? r.virtual_edges.size() : 0},
                        {"d", r.ve_stats.d},
                        {"spacing", r.ve_stats.spacing},
                        {"candidate_pairs", r.ve_stats.candidate_pairs},
                        {"qualifying_pairs", r.ve_stats.qualifying_pairs},
                        {"lambda", options.lambda}};
  int copy_crossings = 0, copy_left = 0, part_crossings = 0, part_left = 0, crossings = 0, left = 0,
      contacts = 0;
  for (const auto& q : r.quality) {
    copy_crossings += q.copy_crossings;
    copy_left += q.copy_crossings_left;
    part_crossings += q.part_crossings;
    part_left += q.part_crossings_left;
    crossings += q.crossings;
    left += q.crossings_left;
    contacts += q.contacts;
  }
  j["contacts"] = {{"enabled", options.contacts.enabled},
                   {"watched_pairs", r.watched_pairs},
                   {"copy_crossings", copy_crossings},
                   {"copy_crossings_left", copy_left},
                   {"part_crossings", part_crossings},
                   {"part_crossings_left", part_left},
                   {"crossings", crossings},
                   {"crossings_left", left},
                   {"contacts", contacts}};
  j["timings_s"] = {{"correspondence", r.timings.correspondence},
                    {"gradients", r.timings.gradients},
                    {"virtual_edges", r.timings.detect},
                    {"factor", r.timings.factor},
                    {"solve", r.timings.solve},
                    {"contacts", r.timings.contacts},
                    {"total", r.timings.total}};
  j["factor_nonzeros"] = r.factor_nonzeros;
  j["fixed_vertices"] = r.fixed_vertices;
  j["components"] = nlohmann::json::array();
  for (const auto& c : r.components)
    j["components"].push_back({{"vertices", c.vertices}, {"placement", c.placement}});
  j["shapes"] = nlohmann::json::array();
  for (const auto& q : r.quality) {
    j["shapes"].push_back({{"name", q.shape},
                           {"max_displacement", q.max_displacement},
                           {"gap_change", q.gap_change},
                           {"min_gap", q.min_gap},
                           {"copy_crossings", q.copy_crossings},
                           {"copy_crossings_left", q.copy_crossings_left},
                           {"part_crossings", q.part_crossings},
                           {"part_crossings_left", q.part_crossings_left},
                           {"crossings", q.crossings},
                           {"crossings_left", q.crossings_left},
                           {"contacts", q.contacts}});
  }
  return j;
}

void write_virtual_edges_json(const std::filesystem::path& path,
                              const std::vector<VirtualEdge>& edges,
                              const VirtualEdgeStats& stats) {
  nlohmann::json j;
  j["d"] = stats.d;
  j["spacing"] = stats.spacing;
  j["edges"] = nlohmann::json::array();
  for (const auto& e : edges) j["edges"].push_back({e.a, e.b});
  write_file_atomic(path, j.dump() + "\n");
}

std::vector<VirtualEdge> read_virtual_edges_json(const std::filesystem::path& path,
                                                 int vertex_count) {
  const nlohmann::json j = load_json(path);
  if (!j.contains("edges") || !j["edges"].is_array())
    throw Error(path.string() + ": no \"edges\" array");
  std::vector<VirtualEdge> out;
  for (std::size_t i = 0; i < j["edges"].size(); ++i) {
    const auto& e = j["edges"][i];
    if (!e.is_array() || e.size() != 2 || !e[0].is_number_integer() || !e[1].is_number_integer()) {
      throw Error(path.string() + ": edges[" + std::to_string(i) +
                  "] is not a pair of vertex indices");
    }
    const int a = e[0].get<int>(), b = e[1].get<int>();
    if (a < 0 || b < 0 || a >= vertex_count || b >= vertex_count || a == b) {
      throw Error(path.string() + ": edges[" + std::to_string(i) + "] vertex out of range (" +
                  std::to_string(vertex_count) + " vertices)");
    }
    out.push_back({a, b});
  }
  return out;
}

void write_virtual_edges_obj(const std::filesystem::path& path, const anim::Positions& positions,
                             const std::vector<VirtualEdge>& edges) {
  std::string s = "# facecast virtual edges: the target neutral's vertices, one 'l' per edge\n";
  char buf[96];
  for (Eigen::Index v = 0; v < positions.rows(); ++v) {
    std::snprintf(buf, sizeof buf, "v %.7g %.7g %.7g\n", positions(v, 0), positions(v, 1),
                  positions(v, 2));
    s += buf;
  }
  for (const auto& e : edges)
    s += "l " + std::to_string(e.a + 1) + " " + std::to_string(e.b + 1) + "\n";
  write_file_atomic(path, s);
}

}  // namespace facecast::rigbuild
