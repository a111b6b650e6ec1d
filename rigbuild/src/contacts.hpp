#pragma once
// Contacts: where the transfer makes the target's surface cross itself at a place where the
// template's shape does not cross (docs/algorithms.md#contacts). Private to rigbuild (the contact
// stages of build_rig, contact_stage.cpp, run it around the block solve).
//
// Virtual edges hold gaps that are long along the surface; at a mouth corner the two lips meet a
// few triangles from the corner, so those gaps fail the geodesic test, yet they are thinner
// (0.006 units on the ICT identity targets) than the transfer's error. The guard watches every
// pair of triangles of one connected part that are near each other in the target neutral (and
// do not cross there).
//
// The reference of a shape starts as the copy: the target neutral plus the template's
// displacement copied vertex by vertex (for a same-topology target, the ICT ground truth's
// construction). Where the copy crosses itself at a watched pair and the template does not --
// the MakeHuman lips and lids are fuller than the ICT's, so closing them as far as the template
// does presses them through each other, and its mouth corners are split between the lips by the
// correspondence -- untangle() smooths the copy's displacement there, a few sweeps at a time,
// until it no longer crosses. A watched pair that crosses in a built shape but not in the
// reference then gets contacts: each corner of one triangle with its closest point on the other,
// kept at the reference's offset. The shape is solved again around them
// (Transfer::solve_with_contacts), up to a few rounds.
//
// Parts the build moves rigidly (teeth, eyes) do not follow the copy: the guard also watches
// pairs of a placed triangle (all corners on such a part) and a free triangle of the skin (the
// largest part) -- lips against teeth, lids against eyes -- within a wider margin, and counts a
// crossing there as new where the template does not cross at the corresponding triangles. The copy
// crosses such parts where the target's skin sits closer to them than the template's (the MakeHuman
// lips lie on its teeth): clear_parts() moves the copy's crossing skin out first -- over a round
// part (an eyeball) radially, back to the distance from its centre it had in the neutral, so a lid
// still slides over it; with any other part (a row of teeth) as it sat on it in the neutral, turned
// as the part turns -- and smooths two rings around. Contacts at a part then keep the reference's
// offsets like the others, or the neutral's turned with the part where the reference still
// crosses there.
#include <cstdint>
#include <functional>
#include <unordered_map>
#include <utility>
#include <vector>

#include "facecast/rigbuild/quality.hpp"
#include "facecast/rigbuild/transfer.hpp"
#include "geometry.hpp"
#include "mesh_graph.hpp"

namespace facecast::rigbuild {

/// The contacts of one shape, with what their offsets follow.
struct GuardContacts {
  std::vector<Contact> contacts;
  /// Per contact: false, it keeps the reference's offset; true (a skin vertex on a placed
  /// triangle where the reference crosses), the neutral's, turned as the triangle turns.
  std::vector<char> turns;
};

class ContactGuard {
 public:
  /// Watches the pairs of triangles of one connected component that come within `margin` of each
  /// other in the neutral and do not cross there (margin <= 0: half the median edge length), and
  /// the pairs of a triangle with all corners in `held` and a triangle of the skin with none,
  /// within `part_margin` (<= 0: two median edges); the triangles with all corners in `floating`
  /// (a separate part the transfer moves: a tongue; not one on a sphere, an eyeball) are checked
  /// in each shape against all near them there (the teeth, the inner lips and palate, the part
  /// itself), those with all corners in `attached` (lashes) by lift_attached. Keeps a reference to
  /// the target mesh.
  ContactGuard(const TargetMesh& target, const std::vector<char>& held, double margin,
               double part_margin, const std::vector<char>& floating = {},
               const std::vector<char>& attached = {});

  /// Watched pairs with a vertex in `moved` that cross in `shape` (the target's positions): pairs
  /// of one part where `reference` does not cross, pairs of parts where the template does not
  /// (`template_crosses(a, b)`); and a floating part's pairs that cross in `shape`, not in the
  /// neutral, and not in the template.
  std::vector<std::pair<int, int>> new_crossings(
      const Points& shape, const Points& reference, const std::vector<char>& moved,
      const std::function<bool(int, int)>& template_crosses) const;

  /// Contacts that hold crossing triangles apart: each corner of one triangle with its closest
  /// point on the other in the neutral (of a placed and a free triangle, the free triangle's
  /// corners on the placed one). Appended unless already there.
  void add_contacts(const std::vector<std::pair<int, int>>& crossings, const Points& reference,
                    GuardContacts& out) const;

  /// What each contact keeps between its vertex and its point: the reference's offset, or the
  /// neutral's turned as the triangle turns in `shape`.
  Points targets(const GuardContacts& c, const Points& reference, const Points& shape) const;

  /// Where `reference` (the copied motion of one shape) crosses itself at watched pairs with a
  /// moved vertex and the template does not (`template_crosses(a, b)`), smooths the displacement
  /// of the crossing triangles' moved vertices towards their surroundings, as little as
  /// uncrosses them. Returns the number of such pairs before and after.
  std::pair<int, int> untangle(Points& reference, const std::vector<char>& moved,
                               const std::function<bool(int, int)>& template_crosses) const;

  /// Where `reference` crosses a placed part and the template does not (`template_crosses`),
  /// moves the free triangle's vertices out of the part (see above) and smooths two rings around
  /// them, at most 5 times; so too a floating part's triangle where it crosses another part's
  /// (its corners carried by that triangle). Returns the number of such pairs before and after.
  std::pair<int, int> clear_parts(Points& reference, const std::vector<char>& moved,
                                  const std::function<bool(int, int)>& template_crosses) const;

  /// Where a triangle of an attached part (lashes, carried by the skin after the contacts)
  /// crosses a skin triangle in `shape` and not in the neutral, moves its corners where the skin
  /// triangle carries them from the neutral, at most 3 times. Returns the number of such pairs
  /// before and after.
  std::pair<int, int> lift_attached(Points& shape) const;

  /// The watched pairs, and the triangles of floating and attached parts (checked against all
  /// near them).
  std::size_t watched() const {
    return watched_.size() + part_pairs_.size() + floating_.triangles.size() +
           attached_.triangles.size();
  }

 private:
  bool moves_at(const std::vector<char>& moved, int triangle) const;  // a corner in `moved`
  // Gauss-Seidel sweeps of the graph Laplacian of the displacement d over `region`: each vertex
  // takes its neighbours' mean, the rest of the mesh held.
  void smooth(Points& d, const std::vector<int>& region, int sweeps) const;
  // Triangles of some parts, grouped by part, each checked in a shape against every triangle
  // near it there.
  struct PartTriangles {
    std::vector<int> triangles;                // grouped by part
    std::vector<int> start;                    // where each part's begin, and the end
    std::vector<char> member;                  // per triangle of the mesh
    std::vector<std::pair<int, int>> neutral;  // theirs that cross in the neutral (a < b)
  };
  PartTriangles group(const std::function<bool(int)>& in) const;
  // Pairs (the group's triangle, any other triangle sharing no corner) that cross in `shape` and
  // not in the neutral. Whether the template shape moves their corners is not asked: another
  // topology's parts move as a whole (Placement::parts_move_whole).
  std::vector<std::pair<int, int>> crossings_of(const Points& shape, const PartTriangles& g) const;
  bool moving_cross(const Points& shape, const std::vector<char>& moved, int a, int b) const;
  int part_of(int triangle) const;
  int part_of_vertex(int v) const;
  // The distances of the part's vertices from its centre vary by less than 15 % of their mean
  // (one standard deviation): an eyeball.
  bool is_round(int part) const;
  // The part's vertices lie on a sphere (a ball or a cap of one: an eyeball, a cornea) within 5 %
  // of its radius (RMS).
  bool on_sphere(int part) const;
  // Is the contact's vertex on the other side of its triangle's plane in `reference` than in the
  // neutral, and within the triangle's size of it (the reference pushed one part through the
  // other: its offset is no target)?
  bool wrong_side(const Points& reference, const Contact& c) const;
  Eigen::RowVector3d centre_of(const Points& p, int part) const;
  const Points& rest_;
  const Triangles& faces_;
  const MeshParts& parts_;
  const MeshGraph& graph_;
  std::vector<std::pair<int, int>> watched_;     // of one part
  std::vector<std::pair<int, int>> part_pairs_;  // (placed triangle, free triangle)
  PartTriangles floating_, attached_;
  std::vector<char> placed_;                  // per triangle: all corners held
  std::vector<char> round_;                   // per component with placed triangles: is_round
  std::vector<int> pair_start_, pair_index_;  // per vertex, the watched pairs touching it
};

/// Does the template's shape k cross itself where built triangles a and b sit
/// (ReferenceCrossings)? Asked again and again for the same pairs while the reference is cleared
/// and the contacts are solved, so the answers are kept per shape; each shape must be asked from
/// one thread at a time.
class TemplateCrossings {
 public:
  /// `shapes`: the template's positions per shape. Keeps references to its arguments.
  TemplateCrossings(const rig::Rig& tmpl, const TriangleMap& map,
                    const std::vector<Points>& shapes);
  bool crosses(std::size_t k, int a, int b);
  /// crosses() for shape k, as ContactGuard asks it.
  std::function<bool(int, int)> of_shape(std::size_t k) {
    return [this, k](int a, int b) { return crosses(k, a, b); };
  }

 private:
  ReferenceCrossings sites_;
  const std::vector<Points>& shapes_;
  std::vector<std::unordered_map<std::uint64_t, bool>> answers_;  // per shape
};

}  // namespace facecast::rigbuild
