#pragma once
// The geometry vocabulary of every module, and the primitives on a triangle mesh.
//
// A mesh is #V rows of xyz and #F rows of three vertex indices. `Positions` (float) is what a rig
// stores, a file holds and the GPU draws; `Points` (double) is the same rows where a solver needs
// the precision (the rig builder, the photo fit). A module converts at its boundary, with
// to_points / to_positions, and computes in one of them inside.
#include <Eigen/Core>
#include <vector>

namespace facecast::rig {

/// #V by 3 positions (or normals, or deltas), row-major so the rows are packed xyz triples.
using Positions = Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>;
/// The same in double precision.
using Points = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
/// #V by 2 texture coordinates.
using UVs = Eigen::Matrix<float, Eigen::Dynamic, 2, Eigen::RowMajor>;
/// #F by 3 vertex indices, counter-clockwise seen from outside.
using Triangles = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;

inline Points to_points(const Positions& p) {
  return p.cast<double>();
}
inline Positions to_positions(const Points& p) {
  return p.cast<float>();
}

/// Connected components of the mesh (vertices joined by triangle edges). The largest is the skin
/// of a head (the face); the others are its parts: teeth, eyeballs, lashes, a tongue. This is the
/// one place that decides it.
struct Components {
  std::vector<int> label;  // #V, component of each vertex; -1 for a vertex in no triangle
  int count = 0;
  int largest = -1;  // the component with the most vertices (the first of equal ones); -1: none
};
Components connected_components(int vertex_count, const Triangles& triangles);

/// Area-weighted unit vertex normals; a vertex in no (or only degenerate) triangles gets +Z.
Positions vertex_normals(const Positions& positions, const Triangles& triangles);
/// The same, written into `normals` (resized) so a per-frame caller can reuse the memory.
void vertex_normals(const Positions& positions, const Triangles& triangles, Positions& normals);
/// The same in double precision.
Points vertex_normals(const Points& positions, const Triangles& triangles);

/// Per triangle (#F by 3): its centroid; its unit normal.
Points centroids(const Points& p, const Triangles& f);
Points face_normals(const Points& p, const Triangles& f);

/// The length of the diagonal of the points' bounding box (0 for no points).
double diagonal(const Points& p);

/// Closest point to p on triangle (a, b, c) (Ericson, Real-Time Collision Detection 5.1.5);
/// returns barycentric weights of a, b, c.
Eigen::Vector3d closest_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                    const Eigen::Vector3d& b, const Eigen::Vector3d& c);

}  // namespace facecast::rig
