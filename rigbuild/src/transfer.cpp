#include "facecast/rigbuild/transfer.hpp"

#include <Eigen/CholmodSupport>
#include <Eigen/Geometry>
#include <Eigen/SparseCholesky>
#include <chrono>
#include <cmath>

#include "facecast/core/error.hpp"
#include "parallel.hpp"

namespace facecast::rigbuild {

namespace {
using SpMat = Eigen::SparseMatrix<double>;
using Dense = Eigen::MatrixXd;

// CHOLMOD's supernodal Cholesky, with the factor's size (m_cholmodFactor is protected).
class Cholmod : public Eigen::CholmodSupernodalLLT<SpMat> {
 public:
  long factor_nonzeros() const {
    return m_cholmodFactor ? static_cast<long>(m_cholmodFactor->xsize) : 0;
  }
};

Eigen::Matrix3d frame(const Eigen::Vector3d& v1, const Eigen::Vector3d& v2,
                      const Eigen::Vector3d& v3) {
  const Eigen::Vector3d e1 = v2 - v1, e2 = v3 - v1;
  const Eigen::Vector3d n = e1.cross(e2);
  const double len = n.norm();
  Eigen::Matrix3d V;
  V.col(0) = e1;
  V.col(1) = e2;
  V.col(2) = len > 0 ? Eigen::Vector3d(n / std::sqrt(len)) : Eigen::Vector3d::Zero();
  return V;
}
}  // namespace

std::vector<Eigen::Matrix3d> rest_frames_inverse(const Points& rest, const Triangles& faces,
                                                 const char* what) {
  std::vector<Eigen::Matrix3d> out(static_cast<std::size_t>(faces.rows()));
  for (Eigen::Index t = 0; t < faces.rows(); ++t) {
    const Eigen::Matrix3d V =
        frame(rest.row(faces(t, 0)).transpose(), rest.row(faces(t, 1)).transpose(),
              rest.row(faces(t, 2)).transpose());
    const double det = V.determinant();
    if (!(std::abs(det) > 0) || !std::isfinite(det)) {
      throw Error(std::string(what) + ": triangle " + std::to_string(t) + " (vertices " +
                  std::to_string(faces(t, 0)) + ", " + std::to_string(faces(t, 1)) + ", " +
                  std::to_string(faces(t, 2)) + ") has zero area");
    }
    out[static_cast<std::size_t>(t)] = V.inverse();
  }
  return out;
}

void source_gradients(const std::vector<Eigen::Matrix3d>& rest_inverse, const Points& deformed,
                      const Triangles& faces, Gradients& out) {
  out.resize(rest_inverse.size());
  for (Eigen::Index t = 0; t < faces.rows(); ++t) {
    const Eigen::Matrix3d Vt =
        frame(deformed.row(faces(t, 0)).transpose(), deformed.row(faces(t, 1)).transpose(),
              deformed.row(faces(t, 2)).transpose());
    out[static_cast<std::size_t>(t)] = Vt * rest_inverse[static_cast<std::size_t>(t)];
  }
}

TriangleMap TriangleMap::identity(int triangle_count) {
  TriangleMap m;
  m.sources.resize(static_cast<std::size_t>(triangle_count));
  for (int t = 0; t < triangle_count; ++t) m.sources[static_cast<std::size_t>(t)] = {t};
  return m;
}

struct Transfer::Impl {
  TransferSetup setup;
  int n = 0, nf = 0, free_n = 0;
  std::vector<int> free_index;             // per vertex: index among free vertices, or -1
  std::vector<int> dirichlet_index;        // per vertex: index among Dirichlet vertices, or -1
  std::vector<int> free_vertex;            // per free index: the vertex
  std::vector<Eigen::Matrix3d> projector;  // P_t = E E^+ per target triangle
  std::vector<double> sqrt_w;              // per target triangle
  SpMat At_free;                           // free columns of A, transposed: #free by #rows
  SpMat A_dir;                             // Dirichlet columns of A: #rows by #D
  SpMat M;                                 // the normal matrix over the free vertices
  Cholmod cholmod;
  Eigen::SimplicialLDLT<SpMat> ldlt;

  // A^T of one shape's right-hand side over the free vertices (#free by 3).
  Dense rhs(const Gradients& src, const Points& prescribed, const Points* edge_targets) const;
  // The positions of one shape from columns col..col+2 of a solution.
  Points positions(const Dense& x, Eigen::Index col, const Points& prescribed) const;

  Dense solve(const Dense& rhs) const {
    if (setup.solver == SolverKind::kCholmod) {
      // CHOLMOD solves all right-hand sides in one supernodal (BLAS-3) sweep.
      const OpenMpThreads omp_threads;  // CHOLMOD's OpenMP regions, within the thread budget
      return const_cast<Cholmod&>(cholmod).solve(rhs);
    }
    // Eigen's solve is const and thread-safe: split the columns over the cores.
    Dense out(rhs.rows(), rhs.cols());
    parallel_for(rhs.cols(), [&](Eigen::Index c) { out.col(c) = ldlt.solve(rhs.col(c)); });
    return out;
  }
};

Transfer::Transfer(TransferSetup setup) : impl_(std::make_unique<Impl>()) {
  Impl& I = *impl_;
  I.setup = std::move(setup);
  const TransferSetup& S = I.setup;
  I.n = static_cast<int>(S.target_rest.rows());
  I.nf = static_cast<int>(S.target_faces.rows());
  if (static_cast<int>(S.map.sources.size()) != I.nf) {
    throw Error("transfer: triangle map size differs from the target's triangle count");
  }
  I.free_index.assign(static_cast<std::size_t>(I.n), -1);
  I.dirichlet_index.assign(static_cast<std::size_t>(I.n), -1);
  for (std::size_t k = 0; k < S.dirichlet.size(); ++k)
    I.dirichlet_index[S.dirichlet[k]] = static_cast<int>(k);
  for (int v = 0; v < I.n; ++v) {
    if (I.dirichlet_index[v] < 0) {
      I.free_index[v] = I.free_n++;
      I.free_vertex.push_back(v);
    }
  }

  // Rows of A: 3 per target triangle (its gradient), 1 per virtual edge.
  const int rows = 3 * I.nf + static_cast<int>(S.virtual_edges.size());
  std::vector<Eigen::Triplet<double>> free_t, dir_t;
  free_t.reserve(static_cast<std::size_t>(9 * I.nf));
  auto put = [&](int row, int v, double value) {
    if (I.free_index[v] >= 0) {
      free_t.emplace_back(I.free_index[v], row, value);
    } else {
      dir_t.emplace_back(row, I.dirichlet_index[v], value);
    }
  };
  I.projector.resize(static_cast<std::size_t>(I.nf));
  I.sqrt_w.resize(static_cast<std::size_t>(I.nf));
  for (int t = 0; t < I.nf; ++t) {
    const int a = S.target_faces(t, 0), b = S.target_faces(t, 1), c = S.target_faces(t, 2);
    Eigen::Matrix<double, 3, 2> E;
    E.col(0) = (S.target_rest.row(b) - S.target_rest.row(a)).transpose();
    E.col(1) = (S.target_rest.row(c) - S.target_rest.row(a)).transpose();
    const Eigen::Matrix2d EtE = E.transpose() * E;
    const double area2 = EtE.determinant();  // (2 * area)^2
    if (!(area2 > 1e-24 * EtE.trace() * EtE.trace()) || !std::isfinite(area2)) {
      throw Error("target: triangle " + std::to_string(t) + " (vertices " + std::to_string(a) +
                  ", " + std::to_string(b) + ", " + std::to_string(c) +
                  ") has zero area and makes the system singular");
    }
    const Eigen::Matrix<double, 2, 3> Ep = EtE.inverse() * E.transpose();
    I.projector[static_cast<std::size_t>(t)] = E * Ep;
    const double count =
        std::max<std::size_t>(1, S.map.sources[static_cast<std::size_t>(t)].size());
    const double w = std::sqrt(0.5 * std::sqrt(area2) * count);
    I.sqrt_w[static_cast<std::size_t>(t)] = w;
    for (int r = 0; r < 3; ++r) {
      put(3 * t + r, a, -w * (Ep(0, r) + Ep(1, r)));
      put(3 * t + r, b, w * Ep(0, r));
      put(3 * t + r, c, w * Ep(1, r));
    }
  }
  const double sl = std::sqrt(S.lambda);
  for (std::size_t i = 0; i < S.virtual_edges.size(); ++i) {
    const int row = 3 * I.nf + static_cast<int>(i);
    put(row, S.virtual_edges[i].a, sl);
    put(row, S.virtual_edges[i].b, -sl);
  }
  I.At_free.resize(I.free_n, rows);
  I.At_free.setFromTriplets(free_t.begin(), free_t.end());
  I.A_dir.resize(rows, static_cast<Eigen::Index>(S.dirichlet.size()));
  I.A_dir.setFromTriplets(dir_t.begin(), dir_t.end());

  const auto t0 = std::chrono::steady_clock::now();
  I.M = SpMat(I.At_free * I.At_free.transpose());
  const SpMat& M = I.M;
  bool ok = true;
  if (I.free_n == 0) {
    // Every vertex is prescribed: nothing to factor.
  } else if (S.solver == SolverKind::kCholmod) {
    const OpenMpThreads omp_threads;
    I.cholmod.compute(M);
    ok = I.cholmod.info() == Eigen::Success;
  } else {
    I.ldlt.compute(M);
    ok = I.ldlt.info() == Eigen::Success && (I.ldlt.vectorD().array() > 0).all();
  }
  if (!ok) {
    throw Error("transfer: the system is singular (a connected component without a fixed vertex?)");
  }
  factor_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

Transfer::~Transfer() = default;
Transfer::Transfer(Transfer&&) noexcept = default;

int Transfer::free_count() const {
  return impl_->free_n;
}

const std::vector<VirtualEdge>& Transfer::virtual_edges() const {
  return impl_->setup.virtual_edges;
}

long Transfer::factor_nonzeros() const {
  if (impl_->setup.solver == SolverKind::kCholmod) {
    return impl_->cholmod.factor_nonzeros();
  }
  return static_cast<long>(impl_->ldlt.matrixL().nestedExpression().nonZeros());
}

Dense Transfer::Impl::rhs(const Gradients& src, const Points& prescribed,
                          const Points* edge_targets) const {
  Dense C(At_free.cols(), 3);
  for (int t = 0; t < nf; ++t) {
    const auto& from = setup.map.sources[static_cast<std::size_t>(t)];
    Eigen::Matrix3d G = Eigen::Matrix3d::Identity();
    if (!from.empty()) {
      G.setZero();
      for (int s : from) G += src[static_cast<std::size_t>(s)];
      G /= static_cast<double>(from.size());
    }
    const Eigen::Matrix3d SP = G * projector[static_cast<std::size_t>(t)];
    for (int r = 0; r < 3; ++r)
      C.row(3 * t + r) = sqrt_w[static_cast<std::size_t>(t)] * SP.col(r).transpose();
  }
  if (!setup.virtual_edges.empty()) {
    C.bottomRows(static_cast<Eigen::Index>(setup.virtual_edges.size())) =
        std::sqrt(setup.lambda) * *edge_targets;
  }
  if (A_dir.cols() > 0) C -= A_dir * Eigen::MatrixXd(prescribed);
  return At_free * C;
}

Points Transfer::Impl::positions(const Dense& x, Eigen::Index col, const Points& prescribed) const {
  Points P(n, 3);
  for (int v = 0; v < n; ++v) {
    if (free_index[v] >= 0) {
      P.row(v) = x.block(free_index[v], col, 1, 3);
    } else {
      P.row(v) = prescribed.row(dirichlet_index[v]);
    }
  }
  return P;
}

std::vector<Points> Transfer::solve(const std::vector<const Gradients*>& source,
                                    const std::vector<Points>& prescribed,
                                    const std::vector<Points>& edge_targets) const {
  const Impl& I = *impl_;
  const std::size_t shapes = source.size();
  if (prescribed.size() != shapes) throw Error("transfer: one prescribed set per shape expected");
  if (!I.setup.virtual_edges.empty() && edge_targets.size() != shapes) {
    throw Error("transfer: one set of virtual-edge targets per shape expected");
  }
  Dense rhs(I.free_n, static_cast<Eigen::Index>(3 * shapes));
  parallel_for(shapes, [&](std::size_t k) {  // right-hand sides are independent per shape
    rhs.middleCols(static_cast<Eigen::Index>(3 * k), 3) =
        I.rhs(*source[k], prescribed[k], edge_targets.empty() ? nullptr : &edge_targets[k]);
  });
  const Dense x = I.free_n ? I.solve(rhs) : Dense(0, rhs.cols());
  std::vector<Points> out(shapes);
  for (std::size_t k = 0; k < shapes; ++k)
    out[k] = I.positions(x, static_cast<Eigen::Index>(3 * k), prescribed[k]);
  return out;
}

std::vector<Points> Transfer::solve_edge_change(const std::vector<Points>& edge_change) const {
  const Impl& I = *impl_;
  const auto ne = static_cast<Eigen::Index>(I.setup.virtual_edges.size());
  const std::size_t shapes = edge_change.size();
  Dense rhs(I.free_n, static_cast<Eigen::Index>(3 * shapes));
  const auto edge_columns = I.At_free.rightCols(ne);  // the virtual edges' rows of A
  for (std::size_t k = 0; k < shapes; ++k) {
    if (edge_change[k].rows() != ne) throw Error("transfer: one change per virtual edge expected");
    rhs.middleCols(static_cast<Eigen::Index>(3 * k), 3) =
        edge_columns * (std::sqrt(I.setup.lambda) * edge_change[k]);
  }
  const Dense x = I.free_n ? I.solve(rhs) : Dense(0, rhs.cols());
  const Points still = Points::Zero(static_cast<Eigen::Index>(I.setup.dirichlet.size()), 3);
  std::vector<Points> out(shapes);
  for (std::size_t k = 0; k < shapes; ++k)
    out[k] = I.positions(x, static_cast<Eigen::Index>(3 * k), still);
  return out;
}

Points Transfer::solve_with_contacts(const Points& solved, const std::vector<char>& held,
                                     const std::vector<Contact>& contacts, const Points& targets,
                                     double weight, int rings) const {
  const Impl& I = *impl_;
  if (targets.rows() != static_cast<Eigen::Index>(contacts.size()))
    throw Error("transfer: one target per contact expected");
  // `solved` minimises the energy, so its gradient over the free vertices is zero and the contact
  // terms change it by the delta that minimises
  //     d^T M d + weight * sum_i (u_i^T (x + d) - t_i)^2,   u_i = e_a - sum_j w_j e_b[j],
  // over the free vertices within `rings` rings (of M's pattern) of the contacts; the others
  // stay. The patch's principal submatrix of M is small: an LDLT of a few hundred unknowns.
  // Free vertices of the patch: slot >= 0 while growing; held free vertices get -2.
  std::vector<int> patch, slot(static_cast<std::size_t>(I.free_n), -1);
  if (!held.empty()) {
    for (int v = 0; v < I.n; ++v)
      if (held[static_cast<std::size_t>(v)] && I.free_index[v] >= 0) slot[I.free_index[v]] = -2;
  }
  const auto seed = [&](int v) {
    if (const int f = I.free_index[v]; f >= 0 && slot[f] == -1) {
      slot[f] = 0;
      patch.push_back(f);
    }
  };
  for (const auto& c : contacts) {
    seed(c.a);
    for (const int v : c.b) seed(v);
  }
  for (int ring = 0, begin = 0; ring < rings; ++ring) {
    const int end = static_cast<int>(patch.size());
    for (int i = begin; i < end; ++i)
      for (SpMat::InnerIterator it(I.M, patch[i]); it; ++it)
        if (slot[it.index()] == -1) {
          slot[it.index()] = 0;
          patch.push_back(static_cast<int>(it.index()));
        }
    begin = end;
  }
  const auto np = static_cast<Eigen::Index>(patch.size());
  for (Eigen::Index i = 0; i < np; ++i) slot[patch[i]] = static_cast<int>(i);
  std::vector<Eigen::Triplet<double>> t;
  for (Eigen::Index i = 0; i < np; ++i)
    for (SpMat::InnerIterator it(I.M, patch[i]); it; ++it)
      if (slot[it.index()] >= 0) t.emplace_back(slot[it.index()], i, it.value());
  Dense rhs = Dense::Zero(np, 3);
  std::vector<std::pair<int, double>> u;  // the contact's row over the patch
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    const Contact& k = contacts[c];
    Eigen::RowVector3d r = targets.row(static_cast<Eigen::Index>(c)) - solved.row(k.a);
    u.clear();
    const auto term = [&](int v, double coefficient) {
      if (const int f = I.free_index[v]; f >= 0 && slot[f] >= 0)
        u.emplace_back(slot[f], coefficient);
    };
    term(k.a, 1.0);
    for (int j = 0; j < 3; ++j) {
      r += k.w[j] * solved.row(k.b[j]);
      term(k.b[j], -k.w[j]);
    }
    for (const auto& [i, ci] : u) {
      rhs.row(i) += ci * weight * r;
      for (const auto& [j, cj] : u) t.emplace_back(i, j, ci * cj * weight);
    }
  }
  SpMat local(np, np);
  local.setFromTriplets(t.begin(), t.end());
  Eigen::SimplicialLDLT<SpMat> ldlt(local);
  if (ldlt.info() != Eigen::Success) throw Error("transfer: the contact system is singular");
  const Dense delta = ldlt.solve(rhs);
  Points out = solved;
  for (Eigen::Index i = 0; i < np; ++i) {
    const int f = patch[static_cast<std::size_t>(i)];
    out.row(I.free_vertex[f]) += delta.row(i);
  }
  return out;
}

}  // namespace facecast::rigbuild
