#pragma once
// The edge graph of a triangle mesh in compressed rows: neighbours of every vertex with the edge
// lengths. Private to rigbuild. Compressed rows rather than a half-edge mesh (OpenMesh): the
// geodesic searches of the virtual edges walk contiguous rows, and any triangle soup, manifold or
// not, is a graph.
#include <algorithm>
#include <span>
#include <utility>
#include <vector>

#include "facecast/rigbuild/transfer.hpp"

namespace facecast::rigbuild {

class MeshGraph {
 public:
  MeshGraph(const Points& points, const Triangles& faces) {
    const int n = static_cast<int>(points.rows());
    std::vector<std::pair<int, int>> e;
    e.reserve(static_cast<std::size_t>(faces.rows()) * 6);
    for (Eigen::Index t = 0; t < faces.rows(); ++t) {
      for (int c = 0; c < 3; ++c) {
        const int a = faces(t, c), b = faces(t, (c + 1) % 3);
        e.emplace_back(a, b);
        e.emplace_back(b, a);
      }
    }
    std::sort(e.begin(), e.end());
    e.erase(std::unique(e.begin(), e.end()), e.end());
    start_.assign(static_cast<std::size_t>(n) + 1, 0);
    for (const auto& [a, b] : e) ++start_[static_cast<std::size_t>(a) + 1];
    for (int v = 0; v < n; ++v) start_[v + 1] += start_[v];
    adj_.resize(e.size());
    for (std::size_t k = 0; k < e.size(); ++k) {
      adj_[k] = {e[k].second, (points.row(e[k].first) - points.row(e[k].second)).norm()};
    }
  }

  int vertex_count() const { return static_cast<int>(start_.size()) - 1; }
  int degree(int v) const { return start_[v + 1] - start_[v]; }
  std::span<const std::pair<int, double>> neighbours(int v) const {
    return {adj_.data() + start_[v], static_cast<std::size_t>(degree(v))};
  }
  double median_edge_length() const {
    std::vector<double> len;
    len.reserve(adj_.size());
    for (const auto& [u, w] : adj_) len.push_back(w);
    if (len.empty()) return 0;
    std::nth_element(len.begin(), len.begin() + static_cast<long>(len.size() / 2), len.end());
    return len[len.size() / 2];
  }

 private:
  std::vector<int> start_;
  std::vector<std::pair<int, double>> adj_;
};

}  // namespace facecast::rigbuild
