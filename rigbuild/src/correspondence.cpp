// Correspondence with a target of another topology, in four stages: align, register, pair the
// parts, map triangles and vertices. See docs/algorithms.md#correspondence.
#include "facecast/rigbuild/correspondence.hpp"

#include <Eigen/CholmodSupport>
#include <algorithm>
#include <chrono>
#include <map>
#include <mutex>

#include "facecast/core/error.hpp"
#include "geometry.hpp"
#include "mesh_graph.hpp"
#include "parallel.hpp"

namespace facecast::rigbuild {
namespace {

using SpMat = Eigen::SparseMatrix<double>;

// The rows of `p` at the markers' template (or target) vertices.
Points marker_rows(const Points& p, const std::vector<MarkerPair>& markers, bool on_template) {
  Points out(static_cast<Eigen::Index>(markers.size()), 3);
  for (std::size_t i = 0; i < markers.size(); ++i)
    out.row(static_cast<Eigen::Index>(i)) =
        p.row(on_template ? markers[i].template_vertex : markers[i].target_vertex);
  return out;
}

// 1. The similarity that moves the template's markers onto the target's.
Similarity align(const Points& template_rest, const Points& target_rest,
                 const std::vector<MarkerPair>& markers) {
  const Similarity s = procrustes(marker_rows(template_rest, markers, true),
                                  marker_rows(target_rest, markers, false), true);
  if (!(s.scale > 0) || !std::isfinite(s.scale))
    throw Error("markers: degenerate marker layout (all on a line?)");
  return s;
}

// 2. Registration: the template's vertices y minimise
//      identity * E_I + smoothness * E_S + rest_pull * |y - x0|^2 + w_C * E_C
// with the markers held at their target positions. Without E_C the energy is Q y = q over the
// free (non-marker) vertices, built once here.
struct RegistrationSystem {
  std::vector<int> free_index;  // per template vertex: its unknown, or -1 for a marker
  SpMat Q;                      // #free by #free
  Points q;                     // #free by 3, the markers' columns moved to the right
};

RegistrationSystem registration_system(const Points& x0, const MeshGraph& graph,
                                       const std::vector<MarkerPair>& markers,
                                       const Points& marker_targets,
                                       const RegistrationOptions& options) {
  const int ns = static_cast<int>(x0.rows());
  std::vector<int> marker_of(static_cast<std::size_t>(ns), -1);
  for (std::size_t i = 0; i < markers.size(); ++i)
    marker_of[markers[i].template_vertex] = static_cast<int>(i);
  RegistrationSystem sys;
  sys.free_index.assign(static_cast<std::size_t>(ns), -1);
  int nfree = 0;
  for (int v = 0; v < ns; ++v) {
    if (marker_of[v] < 0) sys.free_index[v] = nfree++;
  }
  // E_I: edge vectors keep their rest value; E_S: the uniform Laplacian of the displacement is 0.
  std::vector<Eigen::Triplet<double>> ti, ts;
  int row_i = 0, row_s = 0;
  std::vector<Eigen::RowVector3d> rest_edge;
  for (int v = 0; v < ns; ++v) {
    for (auto [u, w] : graph.neighbours(v)) {
      if (u < v) continue;
      rest_edge.push_back(x0.row(v) - x0.row(u));
      ti.emplace_back(row_i, v, 1.0);
      ti.emplace_back(row_i, u, -1.0);
      ++row_i;
    }
    if (graph.degree(v) > 0) {
      ts.emplace_back(row_s, v, 1.0);
      for (auto [u, w] : graph.neighbours(v)) ts.emplace_back(row_s, u, -1.0 / graph.degree(v));
      ++row_s;
    }
  }
  SpMat AI(row_i, ns), AS(row_s, ns);
  AI.setFromTriplets(ti.begin(), ti.end());
  AS.setFromTriplets(ts.begin(), ts.end());
  Points bI(row_i, 3);
  for (int r = 0; r < row_i; ++r) bI.row(r) = rest_edge[static_cast<std::size_t>(r)];
  const Points bS = AS * x0;  // Laplacian of the rest shape: the displacement's Laplacian is 0
  // A weak pull towards the aligned template keeps parts with no counterpart on the target (the
  // eyeballs and teeth of the template over a face mask) where the similarity put them.
  SpMat eye(ns, ns);
  eye.setIdentity();
  const SpMat Q = (options.identity * SpMat(AI.transpose() * AI) +
                   options.smoothness * SpMat(AS.transpose() * AS) + options.rest_pull * eye)
                      .eval();
  const Points q_rhs = options.identity * (AI.transpose() * bI) +
                       options.smoothness * (AS.transpose() * bS) + options.rest_pull * x0;

  // Split into free / marker columns once.
  std::vector<Eigen::Triplet<double>> qff, qfd;
  for (int k = 0; k < Q.outerSize(); ++k) {
    for (SpMat::InnerIterator it(Q, k); it; ++it) {
      const int r = static_cast<int>(it.row()), col = static_cast<int>(it.col());
      if (sys.free_index[r] < 0) continue;
      if (sys.free_index[col] >= 0) {
        qff.emplace_back(sys.free_index[r], sys.free_index[col], it.value());
      } else {
        qfd.emplace_back(sys.free_index[r], marker_of[col], it.value());
      }
    }
  }
  SpMat Qfd(nfree, static_cast<Eigen::Index>(markers.size()));
  sys.Q.resize(nfree, nfree);
  sys.Q.setFromTriplets(qff.begin(), qff.end());
  Qfd.setFromTriplets(qfd.begin(), qfd.end());
  sys.q.resize(nfree, 3);
  for (int v = 0; v < ns; ++v) {
    if (sys.free_index[v] >= 0) sys.q.row(sys.free_index[v]) = q_rhs.row(v);
  }
  sys.q -= Qfd * marker_targets;
  return sys;
}

// Steps of the registration, raising w_C: each vertex is pulled to its closest valid target point
// (normals within 90 degrees, not on the target's boundary, within max_distance of the target's
// diagonal). From `start` (when given): one step at the last w_C (the markers added there are few,
// and near where the registration already put them).
Points register_template(const Points& x0, const Triangles& faces, const MeshGraph& graph,
                         const std::vector<MarkerPair>& markers, const Points& marker_targets,
                         const SurfaceQuery& target, double max_dist,
                         const RegistrationOptions& options, const ProgressFn& progress,
                         const Points* start) {
  const int ns = static_cast<int>(x0.rows());
  const RegistrationSystem sys = registration_system(x0, graph, markers, marker_targets, options);
  Points y = start ? *start : x0;
  for (std::size_t i = 0; i < markers.size(); ++i)
    y.row(markers[i].template_vertex) = marker_targets.row(static_cast<Eigen::Index>(i));
  Eigen::CholmodSupernodalLLT<SpMat> solver;
  bool analyzed = false;
  const std::vector<double> weights = start && !options.closest_weights.empty()
                                          ? std::vector<double>{options.closest_weights.back()}
                                          : options.closest_weights;
  const int iterations = start ? 1 : options.iterations_per_step;
  const int steps = static_cast<int>(weights.size()) * iterations;
  int step = 0;
  for (double wc : weights) {
    for (int it = 0; it < iterations; ++it, ++step) {
      report(progress, "registration", static_cast<double>(step) / steps);
      const Points yn = rig::vertex_normals(y, faces);
      std::vector<double> weight(static_cast<std::size_t>(ns), 0.0);
      Points target_pt = Points::Zero(ns, 3);
      parallel_for(ns, [&](int v) {
        if (sys.free_index[v] < 0 || graph.degree(v) == 0) return;
        const auto hit = target.closest(y.row(v).transpose(), yn.row(v).transpose(), 8);
        if (hit.triangle < 0 || hit.on_boundary || hit.dist > max_dist) return;
        weight[static_cast<std::size_t>(v)] = wc;
        target_pt.row(v) = hit.point.transpose();
      });
      SpMat M = sys.Q;
      Points rhs = sys.q;
      for (int v = 0; v < ns; ++v) {
        if (sys.free_index[v] < 0) continue;
        M.coeffRef(sys.free_index[v], sys.free_index[v]) += weight[static_cast<std::size_t>(v)];
        rhs.row(sys.free_index[v]) += weight[static_cast<std::size_t>(v)] * target_pt.row(v);
      }
      if (!analyzed) {
        solver.analyzePattern(M);
        analyzed = true;
      }
      solver.factorize(M);
      if (solver.info() != Eigen::Success) throw Error("registration: singular system");
      const Eigen::MatrixXd x = solver.solve(Eigen::MatrixXd(rhs));
      for (int v = 0; v < ns; ++v) {
        if (sys.free_index[v] >= 0) y.row(v) = x.row(sys.free_index[v]);
      }
    }
  }
  return y;
}

// 3. Which template parts each target component may pair with: those that at least 10% of its
// vertices land on (skin to skin, teeth to teeth, eyes to eyes), so a lid is never paired with
// the eyeball under it nor a tooth with the lip in front of it.
class PartPairs {
 public:
  PartPairs(int target_count, int template_count)
      : template_count_(template_count),
        allowed_(static_cast<std::size_t>(target_count) * static_cast<std::size_t>(template_count),
                 0),
        template_paired_(static_cast<std::size_t>(template_count), 0) {}
  void allow(int tc, int sc) {
    allowed_[static_cast<std::size_t>(tc * template_count_ + sc)] = 1;
    template_paired_[static_cast<std::size_t>(sc)] = 1;
  }
  /// Target component tc may pair with template part sc.
  bool operator()(int tc, int sc) const {
    return tc >= 0 && sc >= 0 && allowed_[static_cast<std::size_t>(tc * template_count_ + sc)];
  }
  /// Some target component pairs with template part sc.
  bool paired(int sc) const { return template_paired_[static_cast<std::size_t>(sc)]; }

 private:
  int template_count_;
  std::vector<char> allowed_;
  std::vector<char> template_paired_;
};

// The template's parts per vertex: `parts` (per triangle) when given, else its `components`.
rig::Components template_labels(rig::Components components, const Triangles& faces,
                                const std::vector<int>& parts) {
  if (parts.empty()) return components;
  if (parts.size() != static_cast<std::size_t>(faces.rows()))
    throw Error("correspondence: one template part per triangle expected");
  components.count = *std::max_element(parts.begin(), parts.end()) + 1;
  for (Eigen::Index t = 0; t < faces.rows(); ++t) {
    for (int k = 0; k < 3; ++k) components.label[faces(t, k)] = parts[static_cast<std::size_t>(t)];
  }
  return components;
}

PartPairs pair_parts(const SurfaceQuery& registered, const Triangles& template_faces,
                     const rig::Components& template_parts, const Points& target_rest,
                     const Points& target_normals, const rig::Components& target_parts) {
  const int nt = static_cast<int>(target_rest.rows());
  std::vector<int> vote(static_cast<std::size_t>(nt), -1);
  parallel_for(nt, [&](int v) {
    if (target_parts.label[static_cast<std::size_t>(v)] < 0) return;
    const auto hit =
        registered.closest(target_rest.row(v).transpose(), target_normals.row(v).transpose(), 16);
    if (hit.triangle >= 0)
      vote[static_cast<std::size_t>(v)] = template_parts.label[template_faces(hit.triangle, 0)];
  });
  std::vector<std::map<int, int>> votes(static_cast<std::size_t>(target_parts.count));
  std::vector<int> total(static_cast<std::size_t>(target_parts.count), 0);
  for (int v = 0; v < nt; ++v) {
    if (vote[static_cast<std::size_t>(v)] < 0) continue;
    const int tc = target_parts.label[static_cast<std::size_t>(v)];
    ++votes[static_cast<std::size_t>(tc)][vote[static_cast<std::size_t>(v)]];
    ++total[static_cast<std::size_t>(tc)];
  }
  PartPairs pairs(target_parts.count, template_parts.count);
  for (int tc = 0; tc < target_parts.count; ++tc) {
    for (const auto& [sc, n] : votes[static_cast<std::size_t>(tc)]) {
      if (n >= 0.1 * total[static_cast<std::size_t>(tc)]) pairs.allow(tc, sc);
    }
  }
  return pairs;
}

// 4. Both sides of the triangle correspondence, and where each target vertex sits. Closest
// points in the part pairs only, with normals within 90 degrees (any normal when none has).
struct Sides {
  const Points& template_at;  // the registered template
  const Triangles& template_faces;
  const rig::Components& template_parts;
  const SurfaceQuery& template_surface;
  const Points& target_rest;
  const Triangles& target_faces;
  const rig::Components& target_parts;
  const SurfaceQuery& target_surface;
  const PartPairs& pairs;

  // On the registered template, near target point q of target component tc.
  SurfaceQuery::Hit on_template(const Eigen::Vector3d& q, const Eigen::Vector3d& normal,
                                int tc) const {
    const auto accept = [&](int s) {
      return pairs(tc, template_parts.label[template_faces(s, 0)]);
    };
    auto hit = template_surface.closest(q, normal, 16, accept);
    if (hit.triangle < 0) hit = template_surface.closest(q, Eigen::Vector3d::Zero(), 16, accept);
    return hit;
  }
};

TriangleMap map_triangles(const Sides& s, double pair_dist) {
  const Points tgt_cent = centroids(s.target_rest, s.target_faces);
  const Points tgt_norm = face_normals(s.target_rest, s.target_faces);
  TriangleMap map;
  map.sources.assign(static_cast<std::size_t>(s.target_faces.rows()), {});
  parallel_for(static_cast<int>(s.target_faces.rows()), [&](int t) {
    const auto hit = s.on_template(tgt_cent.row(t).transpose(), tgt_norm.row(t).transpose(),
                                   s.target_parts.label[s.target_faces(t, 0)]);
    if (hit.triangle >= 0) map.sources[static_cast<std::size_t>(t)].push_back(hit.triangle);
  });
  // Each template triangle with its closest target triangle, when it is near.
  const Points reg_cent = centroids(s.template_at, s.template_faces);
  const Points reg_norm = face_normals(s.template_at, s.template_faces);
  std::vector<std::pair<int, int>> back_pairs;
  std::mutex back_mutex;
  parallel_for(static_cast<int>(s.template_faces.rows()), [&](int t) {
    const int sc = s.template_parts.label[s.template_faces(t, 0)];
    if (!s.pairs.paired(sc)) return;  // nothing on the target for it
    const auto accept = [&](int u) {
      return s.pairs(s.target_parts.label[s.target_faces(u, 0)], sc);
    };
    const auto hit = s.target_surface.closest(reg_cent.row(t).transpose(),
                                              reg_norm.row(t).transpose(), 16, accept);
    if (hit.triangle >= 0 && hit.dist < pair_dist) {
      std::lock_guard lock(back_mutex);
      back_pairs.emplace_back(hit.triangle, t);
    }
  });
  std::sort(back_pairs.begin(), back_pairs.end());
  for (const auto& [t, from] : back_pairs) {
    auto& v = map.sources[static_cast<std::size_t>(t)];
    if (std::find(v.begin(), v.end(), from) == v.end()) v.push_back(from);
  }
  return map;
}

std::vector<SurfacePoint> map_vertices(const Sides& s, const Points& target_normals) {
  std::vector<SurfacePoint> out(static_cast<std::size_t>(s.target_rest.rows()));
  parallel_for(static_cast<int>(s.target_rest.rows()), [&](int v) {
    const auto hit =
        s.on_template(s.target_rest.row(v).transpose(), target_normals.row(v).transpose(),
                      s.target_parts.label[static_cast<std::size_t>(v)]);
    SurfacePoint& sp = out[static_cast<std::size_t>(v)];
    if (hit.triangle >= 0) {
      sp.v = {s.template_faces(hit.triangle, 0), s.template_faces(hit.triangle, 1),
              s.template_faces(hit.triangle, 2)};
      sp.w = hit.bary;
    }
  });
  return out;
}

}  // namespace

Correspondence compute_correspondence(const Points& template_rest, const Triangles& template_faces,
                                      const std::vector<int>& template_parts,
                                      const Points& target_rest, const Triangles& target_faces,
                                      const std::vector<MarkerPair>& markers,
                                      const RegistrationOptions& options,
                                      const ProgressFn& progress, const MarkerRefinement& refine) {
  return compute_correspondence(
      template_rest, template_faces,
      rig::connected_components(static_cast<int>(template_rest.rows()), template_faces),
      template_parts, target_rest, target_faces,
      rig::connected_components(static_cast<int>(target_rest.rows()), target_faces), markers,
      options, progress, refine);
}

Correspondence compute_correspondence(const Points& template_rest, const Triangles& template_faces,
                                      const rig::Components& template_components,
                                      const std::vector<int>& template_parts,
                                      const Points& target_rest, const Triangles& target_faces,
                                      const rig::Components& target_components,
                                      const std::vector<MarkerPair>& markers,
                                      const RegistrationOptions& options,
                                      const ProgressFn& progress, const MarkerRefinement& refine) {
  const auto t_start = std::chrono::steady_clock::now();
  check_components(template_components, static_cast<int>(template_rest.rows()),
                   "correspondence: template components");
  check_components(target_components, static_cast<int>(target_rest.rows()),
                   "correspondence: target components");
  Correspondence c;
  c.template_vertices = static_cast<int>(template_rest.rows());
  c.template_triangles = static_cast<int>(template_faces.rows());
  c.target_vertices = static_cast<int>(target_rest.rows());
  c.target_triangles = static_cast<int>(target_faces.rows());

  c.alignment = align(template_rest, target_rest, markers);
  const Points x0 = c.alignment.apply(template_rest);
  const SurfaceQuery target_surface(target_rest, target_faces);
  const double diag = diagonal(target_rest);
  const MeshGraph graph(x0, template_faces);
  const auto registered = [&](const std::vector<MarkerPair>& pairs, const Points* start) {
    return register_template(x0, template_faces, graph, pairs,
                             marker_rows(target_rest, pairs, false), target_surface,
                             options.max_distance * diag, options, progress, start);
  };
  c.registered = registered(markers, nullptr);
  const std::vector<MarkerPair> refined = refine ? refine(c.registered) : std::vector<MarkerPair>{};
  if (!refined.empty()) c.registered = registered(refined, &c.registered);
  const auto& used = refined.empty() ? markers : refined;
  c.registration_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  const Points marker_targets = marker_rows(target_rest, used, false);
  double merr = 0;
  for (std::size_t i = 0; i < used.size(); ++i)
    merr += (c.registered.row(used[i].template_vertex) -
             marker_targets.row(static_cast<Eigen::Index>(i)))
                .norm();
  c.mean_marker_error = merr / static_cast<double>(used.size());

  report(progress, "triangle correspondence", 0.0);
  const SurfaceQuery reg_surface(c.registered, template_faces);
  const rig::Components sparts =
      template_labels(template_components, template_faces, template_parts);
  const Points tgt_vn = rig::vertex_normals(target_rest, target_faces);
  const PartPairs pairs =
      pair_parts(reg_surface, template_faces, sparts, target_rest, tgt_vn, target_components);
  const Sides sides{c.registered, template_faces,    sparts,         reg_surface, target_rest,
                    target_faces, target_components, target_surface, pairs};
  c.map = map_triangles(sides, 0.02 * diag);
  c.vertex_map = map_vertices(sides, tgt_vn);
  c.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return c;
}

}  // namespace facecast::rigbuild
