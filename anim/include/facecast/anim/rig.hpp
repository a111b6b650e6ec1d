#pragma once
// The Rig: a neutral mesh plus named blendshapes stored as sparse vertex deltas.
//
// Units are those of the source mesh (ICT FaceKit: centimetres); +Y up, the face looks along +Z.
// Vertex order is the order of the source file and is never changed by Facecast: expressions of the
// ICT FaceKit and marker files refer to vertices by index.
#include <Eigen/Core>
#include <string>
#include <string_view>
#include <vector>

namespace facecast::anim {

/// #V by 3 positions (or normals, or deltas), row-major so the rows are packed xyz triples.
using Positions = Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>;
/// #V by 2 texture coordinates.
using UVs = Eigen::Matrix<float, Eigen::Dynamic, 2, Eigen::RowMajor>;
/// #F by 3 vertex indices, counter-clockwise seen from outside.
using Triangles = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;

struct Material {
  std::string name;
  Eigen::Vector4f base_color{0.8f, 0.8f, 0.8f, 1.0f};  // linear RGBA
};

/// A blendshape: the vertices it moves (ascending, unique) and their deltas from the neutral.
struct Blendshape {
  std::string name;
  std::vector<int> vertices;
  Positions deltas;  // vertices.size() by 3

  /// Builds the sparse form from #V by 3 deltas, keeping rows whose largest |component| >
  /// tolerance.
  static Blendshape from_dense(std::string name, const Positions& dense, float tolerance = 0.0f);
  /// #V by 3 deltas with zeros where the shape does not move.
  Positions dense(int vertex_count) const;
  /// Largest vertex displacement (Euclidean length of a delta).
  float max_displacement() const;
};

/// A named vertex: a landmark or a marker.
struct Landmark {
  std::string name;
  int vertex = 0;
};

struct Rig {
  Positions positions;                 // #V by 3, the neutral face
  Positions normals;                   // #V by 3, unit length
  UVs uvs;                             // #V by 2, or 0 rows when the mesh has none
  Triangles triangles;                 // #F by 3
  std::vector<int> triangle_material;  // #F, index into materials
  std::vector<Material> materials;     // at least one
  std::vector<int> triangle_group;     // #F, index into groups (OBJ "g"); may be empty
  std::vector<std::string> groups;
  std::vector<Blendshape> shapes;
  std::vector<Landmark> landmarks;

  int vertex_count() const { return static_cast<int>(positions.rows()); }
  int triangle_count() const { return static_cast<int>(triangles.rows()); }
  /// Index of the shape named `name`, or -1.
  int find_shape(std::string_view name) const;
  std::vector<std::string> shape_names() const;
  /// Checks sizes, index ranges and finiteness; throws facecast::Error naming `what` and the
  /// problem.
  void validate(std::string_view what = "rig") const;
};

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
/// The same in double precision (the rig builder's geometry).
using PositionsD = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
PositionsD vertex_normals(const PositionsD& positions, const Triangles& triangles);

}  // namespace facecast::anim
