#pragma once
// The stages of build_rig (build.hpp), private to rigbuild. Each takes values and returns one:
//
//   correspond                 template <-> target (build.cpp)
//   template_shapes            the template's shapes and their gradients (motion.cpp)
//   classify_motion            which target vertices each shape moves (motion.cpp)
//   place_components           each target vertex's Role, the placed parts' rigid motions
//                              (placement.cpp; the template's rigid parts: parts.cpp)
//   virtual_edges              on the target neutral (virtual_edges.cpp)
//   factor                     the normal matrix, factored once (solve.cpp)
//   copy_motion, edge_vectors  the template's displacement copied vertex by vertex (motion.cpp)
//   ContactStage::reference    the copy uncrossed: what the contacts keep (contact_stage.cpp)
//   solve_shapes               every shape, as one block of right-hand sides (solve.cpp)
//   ContactStage::hold         contact rounds where a shape crosses and the reference does not
//   carry_attached             parts lying on the skin ride on it (placement.cpp)
//   with_shapes, measure_gaps  the deltas and the report's measures (solve.cpp)
#include <array>
#include <atomic>
#include <cstdint>
#include <future>
#include <optional>
#include <string>
#include <vector>

#include "contacts.hpp"
#include "facecast/rigbuild/build.hpp"
#include "geometry.hpp"

namespace facecast::rigbuild {

/// The template's side: rest positions and, per shape, positions and deformation gradients.
struct TemplateShapes {
  Points rest;
  Triangles faces;
  std::vector<Points> shapes;
  std::vector<Gradients> gradients;
  double seconds = 0;  // how long template_shapes took
  std::size_t size() const { return shapes.size(); }
};

/// Per shape, per target vertex: does the template move the point that the vertex maps to?
using Moved = std::vector<std::vector<char>>;

/// What becomes of a target vertex (docs/algorithms.md#rigid-parts).
enum class Role : std::uint8_t {
  kFree,      // solved by the transfer
  kFixed,     // stays where it is: moved by no shape, listed in BuildOptions::fixed, or in no
              // triangle
  kRigid,     // moves with its part's rigid motion (teeth, eyeballs)
  kAnchor,    // the one vertex of a floating part that follows the part's rigid fit
  kFloating,  // the other vertices of a floating part (lashes, a tongue): solved
};

/// A connected component that no still vertex holds: it is placed as a whole.
struct PlacedPart {
  enum class Kind { kRigid, kFloating, kAttached };
  Kind kind = Kind::kFloating;
  int component = 0;
  int anchor = 0;                           // the member nearest the pivot
  Eigen::RowVector3d pivot;                 // the members' mean in the target neutral
  Eigen::RowVector3d src_pivot;             // the mean of the template points they map to
  std::vector<Similarity> motion;           // per shape, the rigid motion in template coordinates
  std::vector<std::array<int, 3>> carrier;  // kAttached: per member, the skin triangle under it
};

/// Each target vertex's role, and the placed parts.
struct Placement {
  std::vector<Role> role;  // per target vertex
  std::vector<int> part;   // per target vertex: its index in `parts`, or -1
  std::vector<PlacedPart> parts;
  std::vector<ComponentInfo> components;  // per component, for the report
  /// Another topology maps the small parts less exactly: their vertices move with their part
  /// even where the template shape leaves still the point they map to.
  bool parts_move_whole = false;

  /// The vertices whose positions are given (fixed, rigid, anchors), ascending.
  std::vector<int> prescribed() const;
  /// Does a shape that moves `moved` (per vertex) leave vertex v exactly where it is?
  bool stays(const std::vector<char>& moved, int v) const {
    return !moved[static_cast<std::size_t>(v)] &&
           !(parts_move_whole && part[static_cast<std::size_t>(v)] >= 0);
  }
  int fixed_count() const;
};

/// The template's parts, computed once per build where the topologies differ (the
/// correspondence pairs them, the placement finds the rigid ones): its connected components and,
/// per triangle, its component's most common material, so that all 32 teeth of the ICT FaceKit
/// form one part.
struct TemplateParts {
  explicit TemplateParts(const rig::Rig& tmpl);
  MeshParts mesh;
  std::vector<int> of_triangle;  // empty with one material: the components are the parts
};

/// The template's rigid parts: connected components that every shape moves rigidly (teeth,
/// eyeballs), those of one template part that move together joined -- the ICT's 16 upper teeth
/// are one rigid part, its 16 lower teeth another.
struct RigidParts {
  std::vector<int> of_vertex;                   // per template vertex: its rigid part, or -1
  std::vector<std::vector<Similarity>> motion;  // per part, per shape
};
RigidParts rigid_parts(const rig::Rig& tmpl, const TemplateParts& parts,
                       const TemplateShapes& source, double tolerance);

/// A sphere fitted to the rows of `p` (algebraic least squares) and the RMS of |p - centre| -
/// radius.
struct Sphere {
  Eigen::RowVector3d centre = Eigen::RowVector3d::Zero();
  double radius = 0, rms = 0;
};
Sphere fit_sphere(const Points& p);

/// A ball (an eyeball): the sphere fitted to `p` when its RMS residual is at most
/// kSphereResidual of its radius and the points span at least the radius along every axis (not a
/// curved strip such as a teeth row); nullopt otherwise.
constexpr double kSphereResidual = 0.1;
std::optional<Sphere> ball(const Points& p);

/// The template's eyeballs (docs/algorithms.md#eyes): rigid parts that a shape named eyeLook*
/// turns by more than kEyeTurn (radians), with their fitted spheres and rigid motions; when none
/// does, its still rigid balls, each turned about its centre by `look` in its side's eyeLook
/// shapes.
constexpr double kEyeTurn = 0.0175;  // one degree
struct TemplateEye {
  int part = 0;  // into RigidParts
  Sphere sphere;
  std::vector<Similarity> motion;  // per shape, in template coordinates
};
std::vector<TemplateEye> template_eyes(const rig::Rig& tmpl, const TemplateShapes& source,
                                       const RigidParts& rigid, const EyeLookOptions& look);

/// Another topology without markers: `found` gets the automatic landmarks' markers
/// (BuildOptions::auto_landmarks). Another topology: `template_parts` gets the template's parts.
Correspondence correspond(const rig::Rig& tmpl, const rig::Rig& target,
                          const MeshParts& target_parts, const BuildOptions& options,
                          std::optional<AutoMarkers>& found,
                          std::optional<TemplateParts>& template_parts, const ProgressFn& progress);
/// `abandon` (optional): once set, the shapes not yet made are skipped and Error is thrown (the
/// caller will not read them: avatar_from_photos's photo had no face).
TemplateShapes template_shapes(const rig::Rig& tmpl, const std::atomic<bool>* abandon = nullptr);
/// build_rig with the template's shapes being made meanwhile (template_shapes(tmpl), started by
/// the caller: avatar_from_photos starts it while it fits the head that becomes `target`).
BuildResult build_rig(const rig::Rig& tmpl, std::future<TemplateShapes> source_ready,
                      const rig::Rig& target, const BuildOptions& options,
                      const ProgressFn& progress);
/// A vertex moves when the point it maps to moves at least still_tolerance * the template's
/// bounding-box diagonal.
Moved classify_motion(const Correspondence& c, const TemplateShapes& source,
                      double still_tolerance);
/// `template_parts`: the template's where the topologies differ; none: the same topology (the
/// correspondence is vertex to vertex).
Placement place_components(const rig::Rig& tmpl, const TargetMesh& mesh,
                           const std::optional<TemplateParts>& template_parts,
                           const Correspondence& c, const TemplateShapes& source,
                           const Moved& moved, const BuildOptions& options);
/// Detected (kAuto, and kOff for the report's measure) or given (kFile).
std::vector<VirtualEdge> virtual_edges(const TargetMesh& target, const BuildOptions& options,
                                       VirtualEdgeStats& stats);
/// The virtual edges are in the system unless options.virtual_edges is kOff.
Transfer factor(const Points& rest, const Triangles& faces, const TriangleMap& map,
                const std::vector<VirtualEdge>& edges, const Placement& placement,
                const BuildOptions& options);
/// Per shape: the target neutral plus the template's displacement copied vertex by vertex (in the
/// target's frame and units), the prescribed vertices at their places; another topology's floating
/// parts move as a whole (members left still follow their nearest moving member).
std::vector<Points> copy_motion(const Points& rest, const Correspondence& c,
                                const TemplateShapes& source, const Placement& placement,
                                const Moved& moved);
/// Per shape (none without edges): each edge's wanted vector x_a - x_b, #E by 3: the change of
/// the edge in `copied`, turned onto the edge and scaled towards |e| / |template gap| as far as
/// the template gap closes (docs/algorithms.md#gap-scaling; `gap_scale_limit` <= 1: the copy).
std::vector<Points> edge_vectors(const Points& rest, const Correspondence& c,
                                 const TemplateShapes& source, const std::vector<Points>& copied,
                                 const std::vector<VirtualEdge>& edges, double gap_scale_limit);
/// Every shape solved (the prescribed vertices where `copied` has them), the gaps it closes
/// enforced in up to `closing_rounds` more solves (docs/algorithms.md#closing-gaps); vertices a
/// shape leaves still (Placement::stays) are set exactly still.
std::vector<Points> solve_shapes(const Transfer& transfer, const Points& rest,
                                 const std::vector<Gradients>& gradients,
                                 const std::vector<Points>& copied,
                                 const std::vector<Points>& edge_targets,
                                 const Placement& placement, const Moved& moved, int closing_rounds,
                                 const ProgressFn& progress);
/// Attached parts ride on the skin triangles under them.
void carry_attached(const Placement& placement, const MeshParts& parts, const Points& rest,
                    std::vector<Points>& solved);
/// The target with the solved shapes as deltas (the template's names and order).
rig::Rig with_shapes(const rig::Rig& tmpl, const rig::Rig& target, const Points& rest,
                     const std::vector<Points>& solved);
/// Per shape: its name, largest displacement and the virtual edges' gap measure.
void measure_gaps(const rig::Rig& built, const Points& rest, const std::vector<Points>& solved,
                  const std::vector<VirtualEdge>& edges, const std::vector<Points>& edge_targets,
                  std::vector<ShapeQuality>& quality);

/// The contact stages' state: the guard over the target neutral and the template's own crossings.
class ContactStage {
 public:
  /// Keeps references to its arguments.
  ContactStage(const rig::Rig& tmpl, const TemplateShapes& source, const TriangleMap& map,
               const TargetMesh& target, const Placement& placement, const ContactOptions& options);
  /// Per shape, the reference: the copy moved out of the placed parts and smoothed where it
  /// crosses itself, where the template does not. Fills the quality's copy and part crossings.
  std::vector<Points> reference(const std::vector<Points>& copied, const Moved& moved,
                                std::vector<ShapeQuality>& quality);
  /// Contact rounds on every solved shape that crosses where its reference does not. Fills the
  /// quality's crossings and contacts.
  void hold(const Transfer& transfer, const std::vector<Points>& reference, const Moved& moved,
            std::vector<Points>& solved, std::vector<ShapeQuality>& quality);
  /// After the attached parts are carried: lifts them off the parts they run into. Fills the
  /// quality's attached crossings.
  void lift_attached(std::vector<Points>& solved, std::vector<ShapeQuality>& quality) const;
  std::size_t watched() const { return guard_.watched(); }

 private:
  ContactGuard guard_;
  TemplateCrossings template_;
  const Placement& placement_;
  const ContactOptions& options_;
};

}  // namespace facecast::rigbuild
