#include "facecast/rigbuild/correspondence.hpp"

#include <Eigen/CholmodSupport>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <chrono>
#include <cstring>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <unordered_map>

#include "facecast/anim/rig.hpp"
#include "facecast/core/config.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "geometry.hpp"
#include "mesh_graph.hpp"
#include "parallel.hpp"

namespace facecast::rigbuild {

std::vector<MarkerPair> read_markers(const std::filesystem::path& path, int template_vertices,
                                     int target_vertices) {
  const nlohmann::json j = load_json(path);
  const std::string f = path.string();
  if (!j.is_object() || !j.contains("pairs") || !j["pairs"].is_array()) {
    throw Error(f + ": expected an object with a \"pairs\" array");
  }
  const int base = j.value("index_base", 0);
  if (base != 0 && base != 1) throw Error(f + ": index_base must be 0 or 1");
  std::vector<MarkerPair> out;
  for (std::size_t i = 0; i < j["pairs"].size(); ++i) {
    const auto& p = j["pairs"][i];
    const std::string where = f + ": pairs[" + std::to_string(i) + "]";
    if (!p.is_object() || !p.contains("template") || !p.contains("target") ||
        !p["template"].is_number_integer() || !p["target"].is_number_integer()) {
      throw Error(where + ": needs integer \"template\" and \"target\" vertex indices");
    }
    MarkerPair m;
    m.name = p.value("name", "pair" + std::to_string(i));
    m.template_vertex = p["template"].get<int>() - base;
    m.target_vertex = p["target"].get<int>() - base;
    if (m.template_vertex < 0 || m.template_vertex >= template_vertices) {
      throw Error(where + " (" + m.name + "): template vertex " +
                  std::to_string(m.template_vertex + base) + " out of range (" +
                  std::to_string(template_vertices) + " vertices)");
    }
    if (m.target_vertex < 0 || m.target_vertex >= target_vertices) {
      throw Error(where + " (" + m.name + "): target vertex " +
                  std::to_string(m.target_vertex + base) + " out of range (" +
                  std::to_string(target_vertices) + " vertices)");
    }
    out.push_back(std::move(m));
  }
  if (out.size() < 3) throw Error(f + ": at least 3 marker pairs are needed");
  return out;
}

Correspondence identity_correspondence(int vertex_count, const Faces& faces) {
  Correspondence c;
  c.template_vertices = c.target_vertices = vertex_count;
  c.template_triangles = c.target_triangles = static_cast<int>(faces.rows());
  c.map = TriangleMap::identity(static_cast<int>(faces.rows()));
  c.vertex_map.resize(static_cast<std::size_t>(vertex_count));
  for (int v = 0; v < vertex_count; ++v) c.vertex_map[static_cast<std::size_t>(v)].v = {v, v, v};
  return c;
}

std::optional<Correspondence> same_topology_correspondence(int template_vertices,
                                                           const Faces& template_faces,
                                                           int target_vertices,
                                                           const Faces& target_faces) {
  if (template_vertices != target_vertices || template_faces.rows() != target_faces.rows())
    return std::nullopt;
  Correspondence c = identity_correspondence(target_vertices, target_faces);
  if (template_faces == target_faces) return c;
  // A triangle's key: its corners rotated so the smallest comes first (keeps the orientation).
  const auto key = [](const Faces& f, Eigen::Index t) {
    std::array<int, 3> k{f(t, 0), f(t, 1), f(t, 2)};
    std::rotate(k.begin(), std::min_element(k.begin(), k.end()), k.end());
    return static_cast<std::uint64_t>(k[0]) << 42 | static_cast<std::uint64_t>(k[1]) << 21 |
           static_cast<std::uint64_t>(k[2]);
  };
  std::unordered_map<std::uint64_t, int> index;
  index.reserve(static_cast<std::size_t>(template_faces.rows()));
  for (Eigen::Index t = 0; t < template_faces.rows(); ++t)
    index.emplace(key(template_faces, t), static_cast<int>(t));
  for (Eigen::Index t = 0; t < target_faces.rows(); ++t) {
    const auto it = index.find(key(target_faces, t));
    if (it == index.end()) return std::nullopt;
    c.map.sources[static_cast<std::size_t>(t)] = {it->second};
  }
  return c;
}

namespace {

using SpMat = Eigen::SparseMatrix<double>;

Points centroids(const Points& p, const Faces& f) {
  Points c(f.rows(), 3);
  for (Eigen::Index t = 0; t < f.rows(); ++t)
    c.row(t) = (p.row(f(t, 0)) + p.row(f(t, 1)) + p.row(f(t, 2))) / 3.0;
  return c;
}

Points face_normals(const Points& p, const Faces& f) {
  Points n(f.rows(), 3);
  for (Eigen::Index t = 0; t < f.rows(); ++t) {
    const Eigen::Vector3d a = p.row(f(t, 0)), b = p.row(f(t, 1)), c = p.row(f(t, 2));
    n.row(t) = (b - a).cross(c - a).normalized().transpose();
  }
  return n;
}

Points vertex_normals_of(const Points& p, const Faces& f) {
  Points n = Points::Zero(p.rows(), 3);
  for (Eigen::Index t = 0; t < f.rows(); ++t) {
    const Eigen::Vector3d a = p.row(f(t, 0)), b = p.row(f(t, 1)), c = p.row(f(t, 2));
    const Eigen::RowVector3d fn = (b - a).cross(c - a).transpose();
    for (int k = 0; k < 3; ++k) n.row(f(t, k)) += fn;
  }
  for (Eigen::Index v = 0; v < n.rows(); ++v) {
    const double l = n.row(v).norm();
    if (l > 0) n.row(v) /= l;
  }
  return n;
}

// Umeyama: the similarity that maps `from` onto `to` in the least-squares sense.
void similarity(const Points& from, const Points& to, double& s, Eigen::Matrix3d& R,
                Eigen::Vector3d& t) {
  const Eigen::RowVector3d mf = from.colwise().mean(), mt = to.colwise().mean();
  const Points a = from.rowwise() - mf, b = to.rowwise() - mt;
  const Eigen::Matrix3d H = a.transpose() * b / static_cast<double>(from.rows());
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0) D(2, 2) = -1;
  R = svd.matrixV() * D * svd.matrixU().transpose();
  const double var = a.rowwise().squaredNorm().mean();
  s = (svd.singularValues().asDiagonal() * D).trace() / var;
  t = mt.transpose() - s * R * mf.transpose();
}

// Closest points on a mesh through a k-d tree over triangle centroids.
class SurfaceQuery {
 public:
  SurfaceQuery(const Points& p, const Faces& f)
      : p_(p), f_(f), cent_(centroids(p, f)), normals_(face_normals(p, f)) {
    // Boundary edges: used by exactly one triangle.
    std::map<std::pair<int, int>, int> count;
    for (Eigen::Index t = 0; t < f.rows(); ++t) {
      for (int k = 0; k < 3; ++k) {
        const int a = f(t, k), b = f(t, (k + 1) % 3);
        ++count[{std::min(a, b), std::max(a, b)}];
      }
    }
    for (const auto& [e, n] : count) {
      if (n == 1) boundary_.insert(e);
    }
  }

  struct Hit {
    int triangle = -1;
    Eigen::Vector3d bary;
    Eigen::Vector3d point;
    double dist = std::numeric_limits<double>::infinity();
    bool on_boundary = false;
  };

  // The closest point among the k nearest-centroid triangles that `accept` allows and whose normal
  // agrees with `normal` (dot > min_dot; a zero normal accepts every direction). When no triangle
  // qualifies, the search widens (4k, 16k, ...) before it gives up.
  template <typename Accept>
  Hit closest(const Eigen::Vector3d& q, const Eigen::Vector3d& normal, double min_dot,
              std::size_t k, std::vector<std::uint32_t>& idx, std::vector<double>& d2,
              const Accept& accept) const {
    Hit best;
    const std::size_t all = static_cast<std::size_t>(f_.rows());
    for (; best.triangle < 0; k *= 4) {
      cent_.nearest(q.data(), std::min(k, all), idx, d2);
      for (std::uint32_t t : idx) {
        if (!accept(static_cast<int>(t))) continue;
        if (normal.squaredNorm() > 0 && normals_.row(t).dot(normal.transpose()) <= min_dot)
          continue;
        const Eigen::Vector3d a = p_.row(f_(t, 0)), b = p_.row(f_(t, 1)), c = p_.row(f_(t, 2));
        const Eigen::Vector3d w = closest_on_triangle(q, a, b, c);
        const Eigen::Vector3d x = w[0] * a + w[1] * b + w[2] * c;
        const double d = (x - q).norm();
        if (d < best.dist) {
          best.triangle = static_cast<int>(t);
          best.bary = w;
          best.point = x;
          best.dist = d;
        }
      }
      if (k >= all) break;
    }
    if (best.triangle >= 0) {
      for (int k2 = 0; k2 < 3; ++k2) {
        if (best.bary[k2] < 1e-9) {  // on the edge opposite corner k2
          const int a = f_(best.triangle, (k2 + 1) % 3), b = f_(best.triangle, (k2 + 2) % 3);
          if (boundary_.count({std::min(a, b), std::max(a, b)})) best.on_boundary = true;
        }
      }
    }
    return best;
  }
  Hit closest(const Eigen::Vector3d& q, const Eigen::Vector3d& normal, double min_dot,
              std::size_t k, std::vector<std::uint32_t>& idx, std::vector<double>& d2) const {
    return closest(q, normal, min_dot, k, idx, d2, [](int) { return true; });
  }

  const Points& normals() const { return normals_; }
  const PointIndex& centroid_index() const { return cent_; }

 private:
  const Points& p_;
  const Faces& f_;
  PointIndex cent_;
  Points normals_;
  std::set<std::pair<int, int>> boundary_;
};

}  // namespace

Correspondence compute_correspondence(const Points& template_rest, const Faces& template_faces,
                                      const std::vector<int>& template_parts,
                                      const Points& target_rest, const Faces& target_faces,
                                      const std::vector<MarkerPair>& markers,
                                      const RegistrationOptions& options,
                                      const ProgressFn& progress) {
  const auto t_start = std::chrono::steady_clock::now();
  Correspondence c;
  const int ns = static_cast<int>(template_rest.rows()), nt = static_cast<int>(target_rest.rows());
  c.template_vertices = ns;
  c.template_triangles = static_cast<int>(template_faces.rows());
  c.target_vertices = nt;
  c.target_triangles = static_cast<int>(target_faces.rows());

  // 1. Similarity from the markers.
  Points mf(static_cast<Eigen::Index>(markers.size()), 3),
      mt(static_cast<Eigen::Index>(markers.size()), 3);
  for (std::size_t i = 0; i < markers.size(); ++i) {
    mf.row(static_cast<Eigen::Index>(i)) = template_rest.row(markers[i].template_vertex);
    mt.row(static_cast<Eigen::Index>(i)) = target_rest.row(markers[i].target_vertex);
  }
  similarity(mf, mt, c.scale, c.rotation, c.translation);
  if (!(c.scale > 0) || !std::isfinite(c.scale))
    throw Error("markers: degenerate marker layout (all on a line?)");
  const Points x0 =
      ((c.scale * template_rest * c.rotation.transpose()).rowwise() + c.translation.transpose())
          .eval();

  // 2. Non-rigid registration. Unknowns: the template's vertices y; markers are Dirichlet.
  const MeshGraph graph(x0, template_faces);
  std::vector<int> marker_of(static_cast<std::size_t>(ns), -1);
  for (std::size_t i = 0; i < markers.size(); ++i)
    marker_of[markers[i].template_vertex] = static_cast<int>(i);
  std::vector<int> free_index(static_cast<std::size_t>(ns), -1);
  int nfree = 0;
  for (int v = 0; v < ns; ++v) {
    if (marker_of[v] < 0) free_index[v] = nfree++;
  }
  // E_I: edge vectors keep their rest value; E_S: the uniform Laplacian of the displacement is 0.
  std::vector<Eigen::Triplet<double>> ti, ts;
  int row_i = 0, row_s = 0;
  std::vector<std::pair<int, double>> entries;
  Points rhs_i_rest;  // E_I right-hand side per row
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
      if (free_index[r] < 0) continue;
      if (free_index[col] >= 0) {
        qff.emplace_back(free_index[r], free_index[col], it.value());
      } else {
        qfd.emplace_back(free_index[r], marker_of[col], it.value());
      }
    }
  }
  SpMat Qff(nfree, nfree), Qfd(nfree, static_cast<Eigen::Index>(markers.size()));
  Qff.setFromTriplets(qff.begin(), qff.end());
  Qfd.setFromTriplets(qfd.begin(), qfd.end());
  Points q_free(nfree, 3);
  for (int v = 0; v < ns; ++v) {
    if (free_index[v] >= 0) q_free.row(free_index[v]) = q_rhs.row(v);
  }
  q_free -= Qfd * mt;

  const SurfaceQuery target_surface(target_rest, target_faces);
  const double diag = (target_rest.colwise().maxCoeff() - target_rest.colwise().minCoeff()).norm();
  const double max_dist = options.max_distance * diag;
  Points y = x0;
  for (std::size_t i = 0; i < markers.size(); ++i)
    y.row(markers[i].template_vertex) = mt.row(static_cast<Eigen::Index>(i));
  Eigen::CholmodSupernodalLLT<SpMat> solver;
  bool analyzed = false;
  const int steps = static_cast<int>(options.closest_weights.size()) * options.iterations_per_step;
  int step = 0;
  for (double wc : options.closest_weights) {
    for (int it = 0; it < options.iterations_per_step; ++it, ++step) {
      report(progress, "registration", static_cast<double>(step) / steps);
      const Points yn = vertex_normals_of(y, template_faces);
      std::vector<double> weight(static_cast<std::size_t>(ns), 0.0);
      Points target_pt = Points::Zero(ns, 3);
      parallel_for(ns, [&](int v) {
        if (free_index[v] < 0 || graph.degree(v) == 0) return;
        thread_local std::vector<std::uint32_t> idx;
        thread_local std::vector<double> d2;
        const auto hit =
            target_surface.closest(y.row(v).transpose(), yn.row(v).transpose(), 0.0, 8, idx, d2);
        if (hit.triangle < 0 || hit.on_boundary || hit.dist > max_dist) return;
        weight[static_cast<std::size_t>(v)] = wc;
        target_pt.row(v) = hit.point.transpose();
      });
      SpMat M = Qff;
      Points rhs = q_free;
      for (int v = 0; v < ns; ++v) {
        if (free_index[v] < 0) continue;
        M.coeffRef(free_index[v], free_index[v]) += weight[static_cast<std::size_t>(v)];
        rhs.row(free_index[v]) += weight[static_cast<std::size_t>(v)] * target_pt.row(v);
      }
      if (!analyzed) {
        solver.analyzePattern(M);
        analyzed = true;
      }
      solver.factorize(M);
      if (solver.info() != Eigen::Success) throw Error("registration: singular system");
      const Eigen::MatrixXd x = solver.solve(Eigen::MatrixXd(rhs));
      for (int v = 0; v < ns; ++v) {
        if (free_index[v] >= 0) y.row(v) = x.row(free_index[v]);
      }
    }
  }
  c.registered = y;
  double merr = 0;
  for (std::size_t i = 0; i < markers.size(); ++i)
    merr += (y.row(markers[i].template_vertex) - mt.row(static_cast<Eigen::Index>(i))).norm();
  c.mean_marker_error = merr / static_cast<double>(markers.size());

  // 3. Component relations: each target component corresponds to the template parts that at least
  // 10% of its vertices land on (skin to skin, teeth to teeth, eyes to eyes), so a lid is never
  // paired with the eyeball under it nor a tooth with the lip in front of it.
  report(progress, "triangle correspondence", 0.0);
  const SurfaceQuery reg_surface(y, template_faces);
  anim::Components scomp = anim::connected_components(ns, template_faces);
  if (!template_parts.empty()) {  // parts instead of components: label each vertex by its part
    if (template_parts.size() != static_cast<std::size_t>(template_faces.rows())) {
      throw Error("correspondence: one template part per triangle expected");
    }
    scomp.count = *std::max_element(template_parts.begin(), template_parts.end()) + 1;
    for (Eigen::Index t = 0; t < template_faces.rows(); ++t) {
      for (int k = 0; k < 3; ++k)
        scomp.label[template_faces(t, k)] = template_parts[static_cast<std::size_t>(t)];
    }
  }
  const anim::Components tcomp = anim::connected_components(nt, target_faces);
  const Points tgt_vn = vertex_normals_of(target_rest, target_faces);
  std::vector<int> vote(static_cast<std::size_t>(nt), -1);
  parallel_for(nt, [&](int v) {
    if (tcomp.label[static_cast<std::size_t>(v)] < 0) return;
    thread_local std::vector<std::uint32_t> idx;
    thread_local std::vector<double> d2;
    const auto hit = reg_surface.closest(target_rest.row(v).transpose(), tgt_vn.row(v).transpose(),
                                         0.0, 16, idx, d2);
    if (hit.triangle >= 0)
      vote[static_cast<std::size_t>(v)] = scomp.label[template_faces(hit.triangle, 0)];
  });
  std::vector<std::map<int, int>> votes(static_cast<std::size_t>(tcomp.count));
  std::vector<int> total(static_cast<std::size_t>(tcomp.count), 0);
  for (int v = 0; v < nt; ++v) {
    if (vote[static_cast<std::size_t>(v)] < 0) continue;
    const int tc = tcomp.label[static_cast<std::size_t>(v)];
    ++votes[static_cast<std::size_t>(tc)][vote[static_cast<std::size_t>(v)]];
    ++total[static_cast<std::size_t>(tc)];
  }
  // allowed[tc * scomp.count + sc]: template component sc may pair with target component tc.
  std::vector<char> allowed(
      static_cast<std::size_t>(tcomp.count) * static_cast<std::size_t>(scomp.count), 0);
  for (int tc = 0; tc < tcomp.count; ++tc) {
    for (const auto& [sc, n] : votes[static_cast<std::size_t>(tc)]) {
      if (n >= 0.1 * total[static_cast<std::size_t>(tc)])
        allowed[static_cast<std::size_t>(tc * scomp.count + sc)] = 1;
    }
  }
  std::vector<char> template_paired(static_cast<std::size_t>(scomp.count), 0);
  for (int tc = 0; tc < tcomp.count; ++tc) {
    for (int sc = 0; sc < scomp.count; ++sc) {
      if (allowed[static_cast<std::size_t>(tc * scomp.count + sc)])
        template_paired[static_cast<std::size_t>(sc)] = 1;
    }
  }
  auto pairs_with = [&](int tc, int sc) {
    return tc >= 0 && sc >= 0 && allowed[static_cast<std::size_t>(tc * scomp.count + sc)];
  };

  // 4. Triangle correspondence in both directions, and where each target vertex sits.
  const Points tgt_cent = centroids(target_rest, target_faces);
  const Points tgt_norm = face_normals(target_rest, target_faces);
  c.map.sources.assign(static_cast<std::size_t>(target_faces.rows()), {});
  parallel_for(static_cast<int>(target_faces.rows()), [&](int t) {
    thread_local std::vector<std::uint32_t> idx;
    thread_local std::vector<double> d2;
    const int tc = tcomp.label[target_faces(t, 0)];
    auto accept = [&](int s) { return pairs_with(tc, scomp.label[template_faces(s, 0)]); };
    auto hit = reg_surface.closest(tgt_cent.row(t).transpose(), tgt_norm.row(t).transpose(), 0.0,
                                   16, idx, d2, accept);
    if (hit.triangle < 0) {
      hit = reg_surface.closest(tgt_cent.row(t).transpose(), Eigen::Vector3d::Zero(), 0.0, 16, idx,
                                d2, accept);
    }
    if (hit.triangle >= 0) c.map.sources[static_cast<std::size_t>(t)].push_back(hit.triangle);
  });
  const double pair_dist = 0.02 * diag;
  const Points reg_cent = centroids(y, template_faces);
  const Points reg_norm = face_normals(y, template_faces);
  std::vector<std::pair<int, int>> back_pairs;
  std::mutex back_mutex;
  parallel_for(static_cast<int>(template_faces.rows()), [&](int s) {
    thread_local std::vector<std::uint32_t> idx;
    thread_local std::vector<double> d2;
    const int sc = scomp.label[template_faces(s, 0)];
    if (!template_paired[static_cast<std::size_t>(sc)]) return;  // nothing on the target for it
    auto accept = [&](int t) { return pairs_with(tcomp.label[target_faces(t, 0)], sc); };
    const auto hit = target_surface.closest(reg_cent.row(s).transpose(),
                                            reg_norm.row(s).transpose(), 0.0, 16, idx, d2, accept);
    if (hit.triangle >= 0 && hit.dist < pair_dist) {
      std::lock_guard lock(back_mutex);
      back_pairs.emplace_back(hit.triangle, s);
    }
  });
  std::sort(back_pairs.begin(), back_pairs.end());
  for (const auto& [t, s] : back_pairs) {
    auto& v = c.map.sources[static_cast<std::size_t>(t)];
    if (std::find(v.begin(), v.end(), s) == v.end()) v.push_back(s);
  }
  c.vertex_map.resize(static_cast<std::size_t>(nt));
  parallel_for(nt, [&](int v) {
    thread_local std::vector<std::uint32_t> idx;
    thread_local std::vector<double> d2;
    const int tc = tcomp.label[static_cast<std::size_t>(v)];
    auto accept = [&](int s) { return pairs_with(tc, scomp.label[template_faces(s, 0)]); };
    auto hit = reg_surface.closest(target_rest.row(v).transpose(), tgt_vn.row(v).transpose(), 0.0,
                                   16, idx, d2, accept);
    if (hit.triangle < 0) {
      hit = reg_surface.closest(target_rest.row(v).transpose(), Eigen::Vector3d::Zero(), 0.0, 16,
                                idx, d2, accept);
    }
    SurfacePoint& sp = c.vertex_map[static_cast<std::size_t>(v)];
    if (hit.triangle >= 0) {
      sp.v = {template_faces(hit.triangle, 0), template_faces(hit.triangle, 1),
              template_faces(hit.triangle, 2)};
      sp.w = hit.bary;
    }
  });
  c.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return c;
}

namespace {
constexpr char kMagic[8] = {'F', 'C', 'C', 'O', 'R', 'R', '1', '\n'};

template <typename T>
void put(std::string& s, const T& v) {
  s.append(reinterpret_cast<const char*>(&v), sizeof v);
}
template <typename T>
T get(std::string_view& s, const std::string& what) {
  if (s.size() < sizeof(T)) throw Error(what + ": truncated correspondence file");
  T v;
  std::memcpy(&v, s.data(), sizeof v);
  s.remove_prefix(sizeof v);
  return v;
}
}  // namespace

void save_correspondence(const std::filesystem::path& path, const Correspondence& c) {
  std::string s(kMagic, sizeof kMagic);
  for (int n : {c.template_vertices, c.template_triangles, c.target_vertices, c.target_triangles})
    put(s, n);
  put(s, c.scale);
  for (int i = 0; i < 9; ++i) put(s, c.rotation.data()[i]);
  for (int i = 0; i < 3; ++i) put(s, c.translation[i]);
  for (const auto& src : c.map.sources) {
    put(s, static_cast<std::int32_t>(src.size()));
    for (int t : src) put(s, static_cast<std::int32_t>(t));
  }
  for (const auto& sp : c.vertex_map) {
    for (int k = 0; k < 3; ++k) put(s, static_cast<std::int32_t>(sp.v[k]));
    for (int k = 0; k < 3; ++k) put(s, sp.w[k]);
  }
  write_file_atomic(path, s);
}

Correspondence load_correspondence(const std::filesystem::path& path, int template_vertices,
                                   int template_triangles, int target_vertices,
                                   int target_triangles) {
  const std::string bytes = read_file(path);
  const std::string what = path.string();
  std::string_view s(bytes);
  if (s.size() < sizeof kMagic || std::memcmp(s.data(), kMagic, sizeof kMagic) != 0) {
    throw Error(what + ": not a facecast correspondence file");
  }
  s.remove_prefix(sizeof kMagic);
  Correspondence c;
  c.template_vertices = get<int>(s, what);
  c.template_triangles = get<int>(s, what);
  c.target_vertices = get<int>(s, what);
  c.target_triangles = get<int>(s, what);
  if (c.template_vertices != template_vertices || c.template_triangles != template_triangles ||
      c.target_vertices != target_vertices || c.target_triangles != target_triangles) {
    throw Error(what + ": correspondence was made for other meshes (" +
                std::to_string(c.template_vertices) + "/" + std::to_string(c.target_vertices) +
                " vertices); delete it to recompute");
  }
  c.scale = get<double>(s, what);
  for (int i = 0; i < 9; ++i) c.rotation.data()[i] = get<double>(s, what);
  for (int i = 0; i < 3; ++i) c.translation[i] = get<double>(s, what);
  c.map.sources.resize(static_cast<std::size_t>(target_triangles));
  for (auto& src : c.map.sources) {
    const auto n = get<std::int32_t>(s, what);
    if (n < 0 || n > template_triangles) throw Error(what + ": corrupt triangle map");
    for (int k = 0; k < n; ++k) {
      const auto t = get<std::int32_t>(s, what);
      if (t < 0 || t >= template_triangles) throw Error(what + ": corrupt triangle map");
      src.push_back(t);
    }
  }
  c.vertex_map.resize(static_cast<std::size_t>(target_vertices));
  for (auto& sp : c.vertex_map) {
    for (int k = 0; k < 3; ++k) {
      sp.v[k] = get<std::int32_t>(s, what);
      if (sp.v[k] < 0 || sp.v[k] >= template_vertices) throw Error(what + ": corrupt vertex map");
    }
    for (int k = 0; k < 3; ++k) sp.w[k] = get<double>(s, what);
  }
  return c;
}

}  // namespace facecast::rigbuild
