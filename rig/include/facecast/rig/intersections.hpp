#pragma once
// Self-intersections of a (deformed) triangle mesh: which pairs of triangles cross each other.
//
// A bounding-volume hierarchy over the triangles' boxes finds candidate pairs; each candidate is
// decided by Moller's interval-overlap triangle-triangle test in double precision (with the
// coplanar case handled by 2-D edge and containment tests). Pairs of triangles that share a vertex
// index are neighbours, never intersections. Cost: O(F log F) to build plus the candidates; the ICT
// FaceKit (52k triangles) takes a few tens of milliseconds.
// See docs/algorithms.md#intersections.
#include <cstddef>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "facecast/rig/rig.hpp"

namespace facecast::rig {

struct IntersectionOptions {
  /// Signed distances to the other triangle's plane with |d| <= epsilon (mesh units) count as
  /// zero: such contacts are reported as intersections ("touching within a tolerance"). 0 reports
  /// proper crossings and exact contacts only.
  double epsilon = 0.0;
  /// Pairs (a, b) with a < b for which this returns true are skipped (e.g. lips allowed to touch).
  std::function<bool(int a, int b)> ignore;
  /// When not empty (one flag per triangle), only pairs with at least one active triangle are
  /// tested: e.g. the triangles a blendshape moves (pairs of still triangles are the neutral's).
  std::vector<char> active;
  /// At most this many pairs are listed; all are counted.
  std::size_t max_listed = 1000;
};

struct IntersectionReport {
  std::size_t count = 0;                   // intersecting pairs
  std::vector<std::pair<int, int>> pairs;  // the first max_listed, a < b, in ascending order
};

/// Intersecting triangle pairs of `positions` (#V by 3) with `triangles` (#F by 3). Degenerate
/// (zero-area) triangles are skipped.
IntersectionReport find_intersections(const Positions& positions, const Triangles& triangles,
                                      const IntersectionOptions& options = {});

/// Pairs (a, b), a < b, of triangles that share no vertex and whose bounding boxes come within
/// `margin` of each other: the places where a deformation could make the surface cross itself.
/// With `from` (one flag per triangle), only the pairs with a flagged triangle; with `wanted`,
/// only the pairs it accepts (asked as each pair is found, before the list is sorted).
std::vector<std::pair<int, int>> near_triangle_pairs(
    const Positions& positions, const Triangles& triangles, double margin,
    const std::vector<char>& from = {}, const std::function<bool(int, int)>& wanted = {});

/// An `ignore` predicate for the rig's triangle groups: skips pairs with one triangle in group
/// `first` and the other in group `second` of each entry (names from rig.groups; a missing name
/// throws facecast::Error). The predicate refers to copies, not to `rig`.
std::function<bool(int, int)> ignore_between_groups(
    const Rig& rig, const std::vector<std::pair<std::string, std::string>>& group_pairs);

/// True if the two triangles (given by their corners) intersect; exposed for tests.
bool triangles_intersect(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                         const Eigen::Vector3d& p2, const Eigen::Vector3d& q0,
                         const Eigen::Vector3d& q1, const Eigen::Vector3d& q2,
                         double epsilon = 0.0);

}  // namespace facecast::rig
