#pragma once
// Deformation transfer with virtual-edge constraints. See docs/algorithms.md#deformation-transfer
// and docs/algorithms.md#virtual-edges.
//
// Source side: every template triangle's deformation gradient S = V~ V^-1, with the fourth vertex
// v4 = v1 + (v2-v1)x(v3-v1)/sqrt(|(v2-v1)x(v3-v1)|) (source_gradients()).
// Target side: the unknowns are the target's vertex positions; a target triangle's gradient is the
// linear map E~ E^+ of its edges (E = rest edges, E^+ their pseudo-inverse), so the energy
//     sum_t w_t ||G_t x - S_t P_t||^2  +  lambda * sum_i ||x_a - x_b - e_i'||^2
// (P_t projects onto the rest triangle's plane; e_i' = S_i e_i is the virtual edge's deformed
// vector, given by the caller from the source deformation at the edge) is quadratic in x. Its
// normal matrix depends only on the target neutral, the correspondence and the virtual edges, so
// Transfer factors it ONCE; every shape is a back-substitution with three right-hand sides (x, y,
// z), and many shapes are solved as one block of right-hand sides.
//
// Anchoring: translation is free per connected component, so some vertices are Dirichlet
// (prescribed) vertices: their positions go to the right-hand side, the matrix does not change
// (docs/algorithms.md#rigid-parts).
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <array>
#include <memory>
#include <vector>

#include "facecast/rigbuild/geometry.hpp"

namespace facecast::rigbuild {

using Gradients = std::vector<Eigen::Matrix3d>;  // one per triangle

/// The inverse rest frames V^-1 of a mesh's triangles (with the fourth vertex). Throws Error naming
/// the first triangle whose area is zero.
std::vector<Eigen::Matrix3d> rest_frames_inverse(const Points& rest, const Triangles& faces,
                                                 const char* what);

/// Per-triangle deformation gradients S_t = V~ V^-1 of `deformed` against the rest frames.
void source_gradients(const std::vector<Eigen::Matrix3d>& rest_inverse, const Points& deformed,
                      const Triangles& faces, Gradients& out);

/// A virtual edge between two target vertices.
struct VirtualEdge {
  int a = 0, b = 0;
};

/// A vertex and a point of a triangle (barycentric weights over its corners) to be kept at a
/// given offset from each other: contacts (build.cpp, contacts.hpp).
struct Contact {
  int a = 0;
  std::array<int, 3> b{};
  std::array<double, 3> w{};
};

/// Which source triangles drive each target triangle. Same topology: {t} for every t. Otherwise
/// the pairs of the correspondence; a target triangle with no pair keeps its rest shape (S = I).
struct TriangleMap {
  std::vector<std::vector<int>> sources;  // per target triangle
  static TriangleMap identity(int triangle_count);
};

enum class SolverKind { kCholmod, kEigenLDLT };

struct TransferSetup {
  Points target_rest;  // the target neutral
  Triangles target_faces;
  TriangleMap map;
  std::vector<VirtualEdge> virtual_edges;
  double lambda = 1.0;         // weight of the virtual-edge term
  std::vector<int> dirichlet;  // prescribed vertices (ascending, unique)
  SolverKind solver = SolverKind::kCholmod;
};

class Transfer {
 public:
  /// Builds and factors the system. Throws Error if the target has a zero-area triangle or the
  /// system is singular (a component without a prescribed vertex).
  explicit Transfer(TransferSetup setup);
  ~Transfer();
  Transfer(Transfer&&) noexcept;

  /// Solves for several shapes at once. `source[k]` holds the source triangles' gradients of shape
  /// k; `prescribed[k]` the positions of the Dirichlet vertices (in setup order), #D by 3;
  /// `edge_targets[k]` the deformed vectors x_a - x_b of the virtual edges, #E by 3 (may be empty
  /// without virtual edges). Returns the target positions of every shape, #V by 3 each.
  std::vector<Points> solve(const std::vector<const Gradients*>& source,
                            const std::vector<Points>& prescribed,
                            const std::vector<Points>& edge_targets) const;

  /// How solve()'s result moves when only the virtual-edge targets change, by `edge_change[k]`
  /// (#E by 3) for shape k: the solution is linear in its right-hand side, so the gradients' and
  /// the prescribed vertices' part is not built again. #V by 3 each, zero at prescribed vertices.
  std::vector<Points> solve_edge_change(const std::vector<Points>& edge_change) const;

  /// A solved shape (a row of solve()'s result) with contact terms
  /// weight * ||x_a - sum_i w_i x_b[i] - t||^2 added to the energy (`targets` #contacts by 3).
  /// The change is local: only the free vertices within `rings` rings of the contacts move,
  /// solved on that patch's block of the normal matrix (the factor is not touched); vertices
  /// with `held` set (per vertex; may be empty) stay where they are.
  Points solve_with_contacts(const Points& solved, const std::vector<char>& held,
                             const std::vector<Contact>& contacts, const Points& targets,
                             double weight, int rings = 8) const;

  int free_count() const;
  const std::vector<VirtualEdge>& virtual_edges() const;
  long factor_nonzeros() const;
  double factor_seconds() const { return factor_seconds_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  double factor_seconds_ = 0;
};

}  // namespace facecast::rigbuild
