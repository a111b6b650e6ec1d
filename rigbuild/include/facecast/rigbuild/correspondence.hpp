#pragma once
// Correspondence between a template and a target of another topology
// (docs/algorithms.md#correspondence):
//   1. similarity alignment (scale, rotation, translation) of the template onto the target from the
//      marker pairs (procrustes with scale, docs/algorithms.md#procrustes);
//   2. non-rigid registration of the template neutral onto the target: minimise
//        w_S E_S (the displacement's Laplacian is zero) + w_I E_I (edges keep their vectors)
//        + w_C E_C (vertices reach their closest valid target point: normals within 90 degrees)
//      with the markers as hard constraints, raising w_C in steps;
//   3. part pairs: a target component may pair with the template parts that 10% of its vertices
//      land on;
//   4. triangle correspondence: each target triangle pairs with its closest compatible registered
//      template triangle and each template triangle with its closest target triangle; a target
//      triangle's source gradient is the mean over its pairs.
// The result can be saved and reused (save_correspondence, load_correspondence).
#include <array>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "facecast/core/progress.hpp"
#include "facecast/rig/rig.hpp"
#include "facecast/rigbuild/geometry.hpp"
#include "facecast/rigbuild/transfer.hpp"

namespace facecast::rigbuild {

struct MarkerPair {
  std::string name;
  int template_vertex = 0;
  int target_vertex = 0;
};

/// Marker pairs from the JSON format of ../shared/data/markers ({"index_base": 0 or 1, "pairs":
/// [{"name":.., "template": i, "target": j}, ...]}). Errors start with `where` and name the pair
/// and the index out of range: "markers: pairs[3] (nose_tip): target vertex 99 out of range (5
/// vertices)".
std::vector<MarkerPair> parse_markers(const nlohmann::json& markers, int template_vertices,
                                      int target_vertices, const std::string& where = "markers");

/// parse_markers() of a file; errors start with the file's path.
std::vector<MarkerPair> read_markers(const std::filesystem::path& path, int template_vertices,
                                     int target_vertices);

/// Throws naming `where` and the pair when a marker's vertex is out of range, or when there are
/// fewer than 3 pairs.
void check_markers(const std::vector<MarkerPair>& markers, int template_vertices,
                   int target_vertices, const std::string& where = "markers");

/// A point on the template surface: three template vertices and barycentric weights.
struct SurfacePoint {
  std::array<int, 3> v{0, 0, 0};
  Eigen::Vector3d w{1, 0, 0};
  /// The point on the template with its vertices at `p` (#V by 3).
  Eigen::RowVector3d on(const Points& p) const {
    return w[0] * p.row(v[0]) + w[1] * p.row(v[1]) + w[2] * p.row(v[2]);
  }
};

struct RegistrationOptions {
  std::vector<double> closest_weights{1, 10, 100, 1000};  // w_C per step
  int iterations_per_step = 2;
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
  // The similarity that aligns the template with the target (identity for the same topology).
  Similarity alignment;
  Points registered;  // the template neutral registered onto the target
  double seconds = 0;
  double registration_seconds = 0;  // of `seconds`: step 2
  double mean_marker_error = 0;     // after registration, in target units
};

/// Same topology: triangle t <-> t, vertex v <-> v.
Correspondence identity_correspondence(int vertex_count, const Triangles& faces);

/// When `target` holds the triangles of `tmpl` in another order (a GLB groups triangles by
/// material, so a user's material split reorders them), per target triangle the template triangle
/// with the same corners in the same cyclic order, each template triangle once; nullopt when the
/// triangles differ.
std::optional<std::vector<int>> match_triangle_order(const Triangles& tmpl,
                                                     const Triangles& target);

/// Same vertices and the same triangles, maybe in another order (match_triangle_order): vertex
/// v <-> v, each target triangle <-> its template triangle. nullopt when the topologies differ.
std::optional<Correspondence> same_topology_correspondence(int template_vertices,
                                                           const Triangles& template_faces,
                                                           int target_vertices,
                                                           const Triangles& target_faces);

/// Puts the target's triangles (with their materials and groups) in the template's order when
/// they are the template's triangles in another order (match_triangle_order); false, and the
/// target unchanged, when the topologies differ.
bool reorder_triangles_like(const rig::Rig& tmpl, rig::Rig& target);

/// `template_parts` (per template triangle, may be empty) groups the template into parts that a
/// target component may correspond to, e.g. materials (all teeth are one part); empty: components.
/// `refine` (when given) sees the template registered onto the target; markers it returns
/// replace `markers`, and the registration goes on from there, one step at the last of
/// options.closest_weights (the lids' middles, docs/algorithms.md#landmarks, step 7).
using MarkerRefinement = std::function<std::vector<MarkerPair>(const Points& registered)>;
Correspondence compute_correspondence(const Points& template_rest, const Triangles& template_faces,
                                      const std::vector<int>& template_parts,
                                      const Points& target_rest, const Triangles& target_faces,
                                      const std::vector<MarkerPair>& markers,
                                      const RegistrationOptions& options,
                                      const ProgressFn& progress = {},
                                      const MarkerRefinement& refine = {});
/// The same with both meshes' connected components (rig::connected_components) given, for a
/// caller that has them already (build_rig computes each mesh's once).
Correspondence compute_correspondence(const Points& template_rest, const Triangles& template_faces,
                                      const rig::Components& template_components,
                                      const std::vector<int>& template_parts,
                                      const Points& target_rest, const Triangles& target_faces,
                                      const rig::Components& target_components,
                                      const std::vector<MarkerPair>& markers,
                                      const RegistrationOptions& options,
                                      const ProgressFn& progress = {},
                                      const MarkerRefinement& refine = {});

/// Binary cache with a header that records the mesh sizes; load checks them.
void save_correspondence(const std::filesystem::path& path, const Correspondence& c);
Correspondence load_correspondence(const std::filesystem::path& path, int template_vertices,
                                   int template_triangles, int target_vertices,
                                   int target_triangles);

}  // namespace facecast::rigbuild
