#pragma once
// Measures of a built rig: error against ground-truth shapes, and self-intersections against a
// reference rig.
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "facecast/rig/rig.hpp"
#include "facecast/rigbuild/transfer.hpp"

namespace facecast::rigbuild {

struct ShapeError {
  std::string shape;
  double mean = 0, p99 = 0, max = 0;  // per-vertex Euclidean error, in mesh units
  double p99_percent = 0;             // p99 as % of the bounding-box diagonal
};

/// Per shape of `built`, the error of vertices [first, last) against `truth_neutral` + the truth
/// rig's delta of the same name (the ICT identity ground truth: the template's deltas).
std::vector<ShapeError> truth_errors(const rig::Rig& built, const rig::Positions& truth_neutral,
                                     const rig::Rig& truth_deltas, int first, int last);

/// Self-intersections a shape brings: intersecting triangle pairs of (neutral + delta) with at
/// least one triangle the shape moves (pairs of still triangles are the neutral's own, counted once
/// in `neutral`). With a reference (the template, or a ground truth), each pair is "in the
/// reference" when the reference's shape of the same name has an intersecting pair at the
/// corresponding triangles (through `map`, widened by `rings` vertex rings: the same fold seldom
/// crosses at exactly the same triangles), and "new" otherwise.
struct ShapeIntersections {
  std::string shape;
  std::size_t total = 0;
  std::size_t in_neutral = 0;                    // already intersecting in the built neutral
  std::size_t in_reference = 0;                  // the reference shape crosses there too
  std::size_t fresh = 0;                         // new
  std::vector<std::pair<int, int>> fresh_pairs;  // up to 20, triangle indices of the built rig
  /// New pairs by the parts they join ("body|body", "body|teeth"): the built rig's OBJ groups,
  /// else its materials; empty when it has neither.
  std::map<std::string, std::size_t> fresh_by_parts;
};
struct IntersectionSummary {
  std::size_t neutral = 0;            // the built neutral's own intersecting pairs
  std::size_t reference_neutral = 0;  // the reference neutral's
  std::vector<ShapeIntersections> shapes;
  double seconds = 0;
};

struct IntersectionCheck {
  /// Triangle groups allowed to touch (e.g. the default avatar's lip bands); skipped when present.
  std::vector<std::pair<std::string, std::string>> touching_groups;
  /// Per built triangle; when not empty, only pairs with both triangles in the region count.
  std::vector<char> region;
  /// Vertex rings around the corresponding reference triangles that count as "the same place".
  int rings = 3;
};

/// Where a reference rig's shapes cross themselves, seen from a built rig through a triangle map:
/// a built pair (a, b) is at a reference pair when the reference triangles of a and of b, widened
/// by `rings` vertex rings, touch one triangle of the pair each (the same fold seldom crosses at
/// exactly the same triangles). Keeps references to its arguments.
class ReferenceCrossings {
 public:
  ReferenceCrossings(const rig::Rig& reference, const TriangleMap& map, int rings);
  /// Intersecting pairs of the reference's shape `name` with a triangle the shape moves (none when
  /// the reference has no such shape).
  std::vector<std::pair<int, int>> pairs(const std::string& name,
                                         const std::function<bool(int, int)>& ignore = {}) const;
  /// True if built triangles a and b sit at one of `pairs` (from pairs()).
  bool at(const std::vector<std::pair<int, int>>& pairs, int a, int b) const;
  /// The same question for one pair without listing the whole shape's pairs: does the reference
  /// cross itself, with its vertices at `positions` (a shape), where built triangles a and b sit?
  bool crosses_at(const Points& positions, int a, int b) const;

 private:
  std::vector<int> around(int built_triangle) const;
  const std::vector<int>& touching(int built_triangle) const;
  const rig::Rig& reference_;
  const TriangleMap& map_;
  int rings_;
  std::vector<std::vector<int>> adjacency_;
  std::vector<std::vector<int>> triangles_at_;  // per reference vertex
  // Per built triangle, the reference triangles at around()'s vertices (sorted), made when first
  // asked (from any thread): the same for every shape, and asked for in every shape.
  mutable std::vector<std::vector<int>> touching_;
  mutable std::unique_ptr<std::once_flag[]> touching_made_;
};

/// `reference` may be null (no split: every pair counts as fresh). `map` gives, per built
/// triangle, the reference triangles (TriangleMap::identity for the same topology). Shapes run in
/// parallel; each tests only its moved triangles against their surroundings.
IntersectionSummary shape_intersections(const rig::Rig& built, const rig::Rig* reference,
                                        const TriangleMap& map,
                                        const IntersectionCheck& check = {});

/// Per shape, the error against a folder of ground-truth OBJs named like the shapes.
std::vector<ShapeError> truth_errors(const rig::Rig& built,
                                     const std::vector<rig::Positions>& truth);

}  // namespace facecast::rigbuild
