#include "facecast/rigbuild/virtual_edges.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <queue>

#include "facecast/core/error.hpp"
#include "facecast/rig/rig.hpp"
#include "geometry.hpp"
#include "mesh_graph.hpp"
#include "parallel.hpp"
#include "stages.hpp"

namespace facecast::rigbuild {

namespace {
double estimate_from(const MeshGraph& g, const Points& points) {
  const double diag = (points.colwise().maxCoeff() - points.colwise().minCoeff()).norm();
  return std::min(3.0 * g.median_edge_length(), 0.03 * diag);
}
}  // namespace

double estimate_ve_distance(const Points& points, const Triangles& faces) {
  return estimate_from(MeshGraph(points, faces), points);
}

double ve_distance_from_pair(const Points& points, int i, int j) {
  if (i < 0 || j < 0 || i >= points.rows() || j >= points.rows()) {
    throw Error("--ve-pair: vertex index out of range (" + std::to_string(points.rows()) +
                " vertices)");
  }
  return 1.05 * (points.row(i) - points.row(j)).norm();
}

namespace {

struct Candidate {
  int j;
  double dist;
};

// Bounded Dijkstra from one source; reusable buffers per thread.
class LocalGeodesic {
 public:
  explicit LocalGeodesic(const MeshGraph& g)
      : g_(g),
        dist_(static_cast<std::size_t>(g.vertex_count()), kInf),
        slot_(static_cast<std::size_t>(g.vertex_count()), -1) {}

  // Keeps the candidates whose geodesic distance exceeds f times their Euclidean distance.
  // `cands` must be sorted by Euclidean distance, ascending.
  void qualify(int src, const std::vector<Candidate>& cands, double f,
               std::vector<Candidate>& out) {
    out.clear();
    settled_.assign(cands.size(), 0);
    for (std::size_t k = 0; k < cands.size(); ++k) slot_[cands[k].j] = static_cast<int>(k);
    std::size_t remaining = cands.size();
    std::size_t largest = cands.size();  // one past the largest unsettled candidate
    using Item = std::pair<double, int>;
    std::priority_queue<Item, std::vector<Item>, std::greater<>> heap;
    dist_[src] = 0;
    touched_.push_back(src);
    heap.emplace(0.0, src);
    while (!heap.empty() && remaining > 0) {
      const auto [d, v] = heap.top();
      heap.pop();
      if (d > dist_[v]) continue;
      if (d > f * cands[largest - 1].dist) break;  // nothing unsettled can fail the test any more
      if (const int s = slot_[v]; s >= 0 && !settled_[s]) {
        settled_[s] = 1;
        --remaining;
        while (largest > 0 && settled_[largest - 1]) --largest;
        if (d > f * cands[s].dist) out.push_back(cands[s]);
        if (remaining == 0) break;
      }
      for (auto [u, w] : g_.neighbours(v)) {
        const double nd = d + w;
        if (nd < dist_[u]) {
          if (dist_[u] == kInf) touched_.push_back(u);
          dist_[u] = nd;
          heap.emplace(nd, u);
        }
      }
    }
    for (std::size_t k = 0; k < cands.size(); ++k) {
      if (!settled_[k]) out.push_back(cands[k]);  // beyond reach: geodesic > f * Euclidean
      slot_[cands[k].j] = -1;
    }
    for (int v : touched_) dist_[v] = kInf;
    touched_.clear();
    std::sort(out.begin(), out.end(),
              [](const Candidate& a, const Candidate& b) { return a.dist < b.dist; });
  }

 private:
  static constexpr double kInf = std::numeric_limits<double>::infinity();
  const MeshGraph& g_;
  std::vector<double> dist_;
  std::vector<int> slot_;
  std::vector<char> settled_;
  std::vector<int> touched_;
};

// detect_virtual_edges on a mesh whose edge graph and connected components are known;
// stats->seconds count from t0.
std::vector<VirtualEdge> detect(const Points& points, const MeshGraph& graph,
                                const rig::Components& comps, const VirtualEdgeOptions& options,
                                VirtualEdgeStats* stats, std::chrono::steady_clock::time_point t0) {
  if (options.f < 2.0)
    throw Error("--ve-f must be at least 2 (got " + std::to_string(options.f) + ")");
  if (options.per_vertex < 1) throw Error("--ve-per-vertex must be at least 1");
  const int n = static_cast<int>(points.rows());
  const double d = options.d > 0 ? options.d : estimate_from(graph, points);
  const double spacing = options.spacing > 0 ? options.spacing : 0.5 * graph.median_edge_length();

  const PointIndex tree(points);

  // Per vertex: its `per_vertex` shortest qualifying partners on its own surface, and as many in
  // other parts. The two kinds of gap are kept apart through the density control too: a lid
  // margin has the eyeball and the lashes nearer than the other lid, and with one quota and one
  // density control for both the lids got no edge between them (the eyeball's edges took the
  // quota, or blocked the margin as a source).
  std::vector<std::vector<Candidate>> own(static_cast<std::size_t>(n)),
      apart(static_cast<std::size_t>(n));
  const WorkerLease lease(static_cast<std::size_t>(n));
  const unsigned workers = lease.workers();
  std::vector<long> cand_count(workers, 0), qual_count(workers, 0);
  const std::size_t k = static_cast<std::size_t>(options.per_vertex);
  parallel_workers(workers, [&](unsigned w) {
    LocalGeodesic geo(graph);
    std::vector<std::pair<std::uint32_t, double>> hits;
    std::vector<Candidate> cands, other, good;
    for (int i = static_cast<int>(w); i < n; i += static_cast<int>(workers)) {
      if (graph.degree(i) == 0) continue;  // a vertex in no triangle
      tree.within(points.row(i).data(), d, hits, true);
      cands.clear();
      other.clear();
      for (const auto& h : hits) {
        const int j = static_cast<int>(h.first);
        if (j == i || graph.degree(j) == 0) continue;
        // Another component is unreachable along the surface: it qualifies without a search.
        (comps.label[j] == comps.label[i] ? cands : other).push_back({j, std::sqrt(h.second)});
      }
      cand_count[w] += static_cast<long>(cands.size() + other.size());
      good.clear();
      if (!cands.empty()) geo.qualify(i, cands, options.f, good);
      qual_count[w] += static_cast<long>(good.size() + other.size());
      if (good.size() > k) good.resize(k);
      if (other.size() > k) other.resize(k);  // sorted by distance: the radius search sorts
      own[static_cast<std::size_t>(i)] = good;
      apart[static_cast<std::size_t>(i)] = other;
    }
  });

  // Density control: shortest sources first; a placed source blocks its surroundings and its
  // partners' surroundings as future sources.
  std::vector<VirtualEdge> edges;
  std::vector<std::pair<std::uint32_t, double>> hits;
  std::vector<char> blocked(static_cast<std::size_t>(n));
  for (const auto* best : {&own, &apart}) {
    const auto partners = [&](int i) -> const std::vector<Candidate>& {
      return (*best)[static_cast<std::size_t>(i)];
    };
    std::vector<int> order;
    for (int i = 0; i < n; ++i)
      if (!partners(i).empty()) order.push_back(i);
    std::sort(order.begin(), order.end(),
              [&](int a, int b) { return partners(a)[0].dist < partners(b)[0].dist; });
    std::fill(blocked.begin(), blocked.end(), 0);
    auto block_around = [&](int v) {
      tree.within(points.row(v).data(), spacing, hits, false);
      for (const auto& h : hits) blocked[h.first] = 1;
    };
    for (int i : order) {
      if (blocked[static_cast<std::size_t>(i)]) continue;
      for (const auto& c : partners(i)) edges.push_back({std::min(i, c.j), std::max(i, c.j)});
      block_around(i);
      for (const auto& c : partners(i)) block_around(c.j);
    }
  }
  std::sort(edges.begin(), edges.end(), [](const VirtualEdge& a, const VirtualEdge& b) {
    return a.a != b.a ? a.a < b.a : a.b < b.b;
  });
  edges.erase(std::unique(edges.begin(), edges.end(),
                          [](const VirtualEdge& a, const VirtualEdge& b) {
                            return a.a == b.a && a.b == b.b;
                          }),
              edges.end());
  if (stats) {
    stats->d = d;
    stats->spacing = spacing;
    stats->candidate_pairs = 0;
    stats->qualifying_pairs = 0;
    for (unsigned w = 0; w < workers; ++w) {
      stats->candidate_pairs += cand_count[w];
      stats->qualifying_pairs += qual_count[w];
    }
    stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  return edges;
}

}  // namespace

std::vector<VirtualEdge> detect_virtual_edges(const Points& points, const Triangles& faces,
                                              const VirtualEdgeOptions& options,
                                              VirtualEdgeStats* stats) {
  const auto t0 = std::chrono::steady_clock::now();
  return detect(points, MeshGraph(points, faces),
                rig::connected_components(static_cast<int>(points.rows()), faces), options, stats,
                t0);
}

std::vector<VirtualEdge> virtual_edges(const TargetMesh& target, const BuildOptions& options,
                                       VirtualEdgeStats& stats) {
  if (options.virtual_edges == VirtualEdgeMode::kFile) return options.given_edges;
  return detect(target.rest, target.graph, target.parts.components, options.ve, &stats,
                std::chrono::steady_clock::now());
}

}  // namespace facecast::rigbuild
