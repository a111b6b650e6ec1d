#pragma once
// Correspondence between a template and a target of another topology (Sumner & Popovic 2004, s. 5;
// seed notes 002):
//   1. similarity alignment (scale, rotation, translation) of the template onto the target from the
//      marker pairs (Umeyama);
//   2. non-rigid registration of the template neutral onto the target: minimise
//        w_S E_S (neighbouring triangles deform alike) + w_I E_I (triangles stay undeformed)
//        + w_C E_C (vertices reach their closest valid target point: normals within 90 degrees)
//      with the markers as hard constraints, raising w_C in steps; closest points by nanoflann;
//   3. triangle correspondence: each target triangle pairs with its closest compatible registered
//      template triangle and each template triangle with its closest target triangle; a target
//      triangle's source gradient is the mean over its pairs.
// The result can be saved and reused (--correspondence FILE).
#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "facecast/core/progress.hpp"
#include "facecast/rigbuild/transfer.hpp"

namespace facecast::rigbuild {

struct MarkerPair {
  std::string name;
  int template_vertex = 0;
  int target_vertex = 0;
};

/// Reads the marker JSON format of ../shared/data/markers (pairs of template/target vertex indices,
/// index_base 0 or 1). Errors name the file, the pair and the index out of range.
std::vector<MarkerPair> read_markers(const std::filesystem::path& path, int template_vertices,
                                     int target_vertices);

/// A point on the template surface: three template vertices and barycentric weights.
struct SurfacePoint {
  std::array<int, 3> v{0, 0, 0};
  Eigen::Vector3d w{1, 0, 0};
};

struct RegistrationOptions {
  std::vector<double> closest_weights{1, 10, 100, 1000};  // w_C per step
  int iterations_per_step = 3;
  double smoothness = 1.0;    // w_S
  double identity = 0.01;     // w_I
  double rest_pull = 1e-4;    // pull towards the similarity-aligned template (keeps it regular)
  double max_distance = 0.1;  // closest points farther than this * target diagonal are invalid
};

struct Correspondence {
  int template_vertices = 0, template_triangles = 0;
  int target_vertices = 0, target_triangles = 0;
  TriangleMap map;                       // per target triangle: its template triangles
  std::vector<SurfacePoint> vertex_map;  // per target vertex: where it sits on the template
  // The similarity x -> scale * rotation * x + translation that aligns the template with the target
  // (identity for the same topology).
  double scale = 1.0;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Points registered;  // the template neutral registered onto the target
  double seconds = 0;
  double mean_marker_error = 0;  // after registration, in target units
};

/// Same topology: triangle t <-> t, vertex v <-> v.
Correspondence identity_correspondence(int vertex_count, const Faces& faces);

/// Same vertices and the same triangles in another order (a GLB groups triangles by material, so
/// a user's material split reorders them): vertex v <-> v, each target triangle <-> the template
/// triangle with the same corners in the same cyclic order. nullopt when the topologies differ.
std::optional<Correspondence> same_topology_correspondence(int template_vertices,
                                                           const Faces& template_faces,
                                                           int target_vertices,
                                                           const Faces& target_faces);

/// `template_parts` (per template triangle, may be empty) groups the template into parts that a
/// target component may correspond to, e.g. materials (all teeth are one part); empty: components.
Correspondence compute_correspondence(const Points& template_rest, const Faces& template_faces,
                                      const std::vector<int>& template_parts,
                                      const Points& target_rest, const Faces& target_faces,
                                      const std::vector<MarkerPair>& markers,
                                      const RegistrationOptions& options,
                                      const ProgressFn& progress = {});

/// Binary cache with a header that records the mesh sizes; load checks them.
void save_correspondence(const std::filesystem::path& path, const Correspondence& c);
Correspondence load_correspondence(const std::filesystem::path& path, int template_vertices,
                                   int template_triangles, int target_vertices,
                                   int target_triangles);

}  // namespace facecast::rigbuild
