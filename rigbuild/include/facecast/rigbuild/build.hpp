#pragma once
// Building a user's rig: the template's blendshapes transferred onto the user's neutral head
// (docs/algorithms.md#deformation-transfer). The stages, in rigbuild/src/stages.hpp:
//
//   template rig + target neutral (+ markers for another topology)
//     -> correspondence: identity, or registration + triangle map (correspondence.hpp)
//     -> which target vertices each template shape moves
//     -> placement (docs/algorithms.md#rigid-parts): vertices that move in no template shape and
//        `fixed` vertices stay put; every separate component is placed: one that the template
//        moves rigidly (teeth, eyeballs; for another topology also one whose points lie mostly on
//        one of the template's rigid parts, e.g. its lower teeth row) gets that rigid motion about
//        its own pivot; other separate components (lashes, tongue) are transferred with one anchor
//        vertex that follows the same rigid fit, and for another topology those lying on the skin
//        (lashes) are then carried by the skin triangles under them
//     -> virtual edges on the target neutral (docs/algorithms.md#virtual-edges)
//     -> deformation transfer, factored once, all shapes solved as one block of right-hand sides
//     -> the template's motion copied vertex by vertex (the virtual edges' targets), and the
//        contacts' reference: that copy moved out of the rigid parts and smoothed where it
//        crosses itself, where the template does not
//     -> contacts (docs/algorithms.md#contacts): where a shape crosses itself or a rigid part and
//        the reference does not, vertex-to-triangle constraints, solved again on a patch
//     -> deltas, with every vertex the template shape leaves still set exactly still.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "facecast/core/progress.hpp"
#include "facecast/rig/rig.hpp"
#include "facecast/rigbuild/correspondence.hpp"
#include "facecast/rigbuild/landmarks.hpp"
#include "facecast/rigbuild/transfer.hpp"
#include "facecast/rigbuild/virtual_edges.hpp"

namespace facecast::rigbuild {

/// kAuto: detected on the target neutral; kOff: none in the system (still detected, for the
/// report's gap measure); kFile: BuildOptions::given_edges (the CLI reads them from a file).
enum class VirtualEdgeMode { kAuto, kOff, kFile };

/// Contacts (docs/algorithms.md#contacts): triangle pairs near each other in the target neutral are
/// watched; where a built shape crosses there and the reference (the template's displacement
/// copied vertex by vertex, smoothed where that copy crosses itself and the template does not)
/// does not, contacts that keep the reference's offsets are added and the shape is solved again
/// around them (the factor is not touched).
struct ContactOptions {
  bool enabled = true;
  double margin = 0.0;       // watch pairs within this distance; <= 0: half the median edge length
  double part_margin = 0.0;  // ... of a placed part (teeth) and the skin; <= 0: two median edges
  double weight = 100.0;     // weight of a contact (the units of lambda), x10 each next round
  int rounds = 7;            // solve again at most this many times per shape
};

/// The gaze of separate eyeball meshes when the template's eyeLook* shapes do not turn its eyeballs
/// (the ICT FaceKit's move the lids only): each eyeLook shape turns its side's eyeball by these
/// angles (degrees; the built-in avatar's). See docs/algorithms.md#eyes.
struct EyeLookOptions {
  double in_out = 25.0;  // eyeLookIn / eyeLookOut, about the vertical axis
  double up = 20.0;      // eyeLookUp, about the horizontal axis
  double down = 22.0;    // eyeLookDown
};

/// Defaults mirrored in configs/rigbuild/build.json (load_build_options reads it; a test checks
/// that the two agree). Data only: callers read files (markers, a saved correspondence, virtual
/// edges) and put what they hold here.
struct BuildOptions {
  VirtualEdgeMode virtual_edges = VirtualEdgeMode::kAuto;
  std::vector<VirtualEdge> given_edges;  // with kFile: the edges (read_virtual_edges_json)
  VirtualEdgeOptions ve;
  double lambda = 4.0;  // weight of the virtual-edge term
  /// Virtual edges whose template gap closes take the template's change scaled by |target gap| /
  /// |template gap|, clamped to [1 / this, this], as far as it closes (docs/algorithms.md
  /// #gap-scaling); <= 1: the change as copied.
  double gap_scale_limit = 2.0;
  /// Gaps a shape closes (virtual edges wanted under half their length) are enforced in up to
  /// this many more solves (docs/algorithms.md#closing-gaps); 0: a soft term like the others.
  int closing_rounds = 3;
  ContactOptions contacts;
  EyeLookOptions eye_look;
  std::vector<int> fixed;         // extra target vertices that never move
  double still_tolerance = 1e-4;  // "does not move": |template delta| < this * bbox diagonal
  double rigid_tolerance = 0.01;  // a component is rigid if its rigid-fit RMS residual is below
                                  // this * the component's size in every shape
  SolverKind solver = SolverKind::kCholmod;
  // Another topology (see correspondence.hpp).
  std::vector<MarkerPair> markers;  // when the topologies differ (read_markers); empty: found
  /// Without markers on another topology: find them with automatic landmarks (landmarks.hpp);
  /// false: such a build is an error.
  bool auto_landmarks = true;
  LandmarkOptions landmarks;
  /// With markers: a correspondence computed before (load_correspondence) to use instead of
  /// computing it; BuildResult::correspondence holds the one used, to save.
  std::optional<Correspondence> correspondence;
  RegistrationOptions registration;
};

struct ComponentInfo {
  int vertices = 0;
  // "fixed" (never moves), "anchored" (held by its still vertices), "rigid" (the template part's
  // rigid motion), "floating" (transferred, one vertex follows the template part's rigid motion),
  // "attached" (another topology's part lying on the skin, carried by the skin triangles under it)
  std::string placement;
};

struct BuildTimings {
  double landmarks = 0;     // part of correspondence
  double registration = 0;  // part of correspondence (correspondence.hpp's step 2)
  double correspondence = 0, gradients = 0, detect = 0, factor = 0, solve = 0, contacts = 0,
         total = 0;
};

/// Per shape: how well the gaps that virtual edges span keep the template's behaviour. For each
/// virtual edge the gap is normalised so the neutral gap is 10 (docs/algorithms.md#virtual-edges);
/// the change is the mean |built gap - the gap the template shape asks for| over the edges.
struct ShapeQuality {
  std::string shape;
  double max_displacement = 0;
  double gap_change = 0;
  double min_gap = 0;           // smallest normalised gap (0 = the two sides meet or cross)
  int copy_crossings = 0;       // watched pairs where the copied motion crosses, not the template
  int copy_crossings_left = 0;  // ... and still crosses after smoothing it there
  int part_crossings = 0;  // pairs where the copy crosses a rigidly moved part, not the template
  int part_crossings_left = 0;      // ... and still crosses after moving the copy out of it
  int crossings = 0;                // watched triangle pairs that crossed after the transfer
  int crossings_left = 0;           // ... and still cross after the contact rounds
  int contacts = 0;                 // vertex-to-triangle contacts added to hold them apart
  int attached_crossings = 0;       // pairs where a carried attached part (lashes) crosses another
  int attached_crossings_left = 0;  // ... and still crosses after lifting it off
};

struct BuildResult {
  rig::Rig rig;  // the target with the template's shapes (same names and order)
  std::vector<VirtualEdge> virtual_edges;  // detected on the target (used unless mode is kOff)
  std::vector<ShapeQuality> quality;
  VirtualEdgeStats ve_stats;
  std::vector<ComponentInfo> components;
  Correspondence correspondence;         // its map: per target triangle, its template triangles
  std::optional<AutoMarkers> landmarks;  // the markers found when none were given
  int fixed_vertices = 0;
  std::size_t watched_pairs = 0;  // triangle pairs the contact guard watches
  long factor_nonzeros = 0;
  BuildTimings timings;
};

/// BuildOptions from configs/rigbuild/build.json; throws Error naming the field when invalid.
BuildOptions load_build_options();

/// Throws facecast::Error for unusable input (vertex counts, markers, zero-area triangles, NaN).
BuildResult build_rig(const rig::Rig& template_rig, const rig::Rig& target,
                      const BuildOptions& options, const ProgressFn& progress = {});

/// The build report (`rig build --report`, the server's rig jobs): virtual edges, timings,
/// components and per-shape quality.
nlohmann::json build_report_json(const BuildResult& result, const BuildOptions& options);

/// Virtual edges as JSON ({"d":..,"edges":[[a,b],...]}) and as OBJ line elements over the mesh.
/// Reading checks the indices against `vertex_count`.
void write_virtual_edges_json(const std::filesystem::path& path,
                              const std::vector<VirtualEdge>& edges, const VirtualEdgeStats& stats);
std::vector<VirtualEdge> read_virtual_edges_json(const std::filesystem::path& path,
                                                 int vertex_count);
void write_virtual_edges_obj(const std::filesystem::path& path, const rig::Positions& positions,
                             const std::vector<VirtualEdge>& edges);

}  // namespace facecast::rigbuild
