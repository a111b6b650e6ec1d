#pragma once
// Contacts: where the transfer makes the target's surface cross itself at a place where the
// template's shape does not cross. Private to rigbuild (build.cpp runs it around the block solve).
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
#include <functional>
#include <utility>
#include <vector>

#include "facecast/rigbuild/transfer.hpp"
#include "mesh_graph.hpp"

namespace facecast::rigbuild {

class ContactGuard {
 public:
  /// Watches the pairs of triangles of one connected component (`component`: per target vertex)
  /// that come within `margin` of each other in the neutral and do not cross there (margin <= 0:
  /// half the median edge length).
  ContactGuard(const Points& target_rest, const Faces& target_faces,
               const std::vector<int>& component, double margin);

  /// Watched pairs with a vertex in `moved` that cross in `shape` (the target's positions) and
  /// not in `reference`.
  std::vector<std::pair<int, int>> new_crossings(const Points& shape, const Points& reference,
                                                 const std::vector<char>& moved) const;

  /// Contacts that hold crossing triangles apart: each corner of one triangle with its closest
  /// point on the other in the neutral. Appended to `contacts` unless already there.
  void add_contacts(const std::vector<std::pair<int, int>>& crossings,
                    std::vector<Contact>& contacts) const;

  /// Where `reference` (the copied motion of one shape) crosses itself at watched pairs with a
  /// moved vertex and the template does not (`template_crosses(a, b)`), smooths the displacement
  /// of the crossing triangles' moved vertices towards their surroundings, as little as
  /// uncrosses them. Returns the number of such pairs before and after.
  std::pair<int, int> untangle(Points& reference, const std::vector<char>& moved,
                               const std::function<bool(int, int)>& template_crosses) const;

  std::size_t watched() const { return watched_.size(); }

 private:
  bool moves_at(const std::vector<char>& moved, int triangle) const;  // a corner in `moved`
  const Points& rest_;
  const Faces& faces_;
  MeshGraph graph_;
  std::vector<std::pair<int, int>> watched_;
  std::vector<int> pair_start_, pair_index_;  // per vertex, the watched pairs touching it
};

}  // namespace facecast::rigbuild
