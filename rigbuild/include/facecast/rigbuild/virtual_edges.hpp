#pragma once
// Automatic virtual edges (docs/algorithms.md#virtual-edges): vertex pairs that are close in space
// but far apart along the surface (lips, eyelids over eyeballs, nostrils, the mouth cavity behind
// the cheeks), where a deformation on one side would otherwise pass through the other side.
//
// A pair (i, j) qualifies when |p_i - p_j| < d and geodesic(i, j) / |p_i - p_j| > f, the geodesic
// being the shortest edge path (Dijkstra, stopped once every candidate is settled or the frontier
// passes f times the largest candidate distance, so it stays local); vertices in different
// connected components are infinitely far apart along the surface. Candidates come from a k-d tree
// radius search (nanoflann), so the cost is linear in the vertex count. Each vertex keeps its
// `per_vertex` shortest pairs on its own surface and as many into other parts; density control,
// once for each kind, then walks the sources shortest-first and, after placing a source's edges,
// skips every vertex within `spacing` of the edges' ends. The default
// spacing is half a median edge, so nearly every vertex at a gap keeps its edges: a spacing as
// wide as d leaves an eye a few edges, all to its nearest part (the lashes), and none joining
// the two lids.
#include <vector>

#include "facecast/rigbuild/transfer.hpp"

namespace facecast::rigbuild {

struct VirtualEdgeOptions {
  double d = 0.0;        // Euclidean threshold; <= 0: estimate_ve_distance()
  double f = 3.0;        // geodesic / Euclidean ratio threshold, >= 2
  int per_vertex = 4;    // edges kept per source vertex, own surface and other parts each (3 to 5)
  double spacing = 0.0;  // density-control radius; <= 0: half the median edge length
};

struct VirtualEdgeStats {
  double d = 0, spacing = 0;
  long candidate_pairs = 0;   // pairs within d
  long qualifying_pairs = 0;  // of those, pairs with geodesic / Euclidean > f
  double seconds = 0;
};

/// d from the mesh: a multiple of the median edge length, bounded by a fraction of the bounding box
/// diagonal, so the threshold spans the thin gaps of a face at any resolution.
double estimate_ve_distance(const Points& points, const Triangles& faces);

std::vector<VirtualEdge> detect_virtual_edges(const Points& points, const Triangles& faces,
                                              const VirtualEdgeOptions& options,
                                              VirtualEdgeStats* stats = nullptr);

/// d from one vertex pair across a region (an interactive choice): their distance * 1.05.
double ve_distance_from_pair(const Points& points, int i, int j);

}  // namespace facecast::rigbuild
