// Virtual-edge detection at scale: the ICT FaceKit neutral subdivided by edge midpoints (each
// triangle into four) until it passes a vertex count; prints the time and the edges found.
// Usage: bench_virtual_edges [min_vertices (default 1000000)]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>

#include "build_paths.hpp"
#include "facecast/rig/rig_io.hpp"
#include "facecast/rigbuild/virtual_edges.hpp"

using namespace facecast;
using namespace facecast::rigbuild;

namespace {
void subdivide(Points& p, Triangles& f) {
  std::map<std::pair<int, int>, int> mid;
  std::vector<Eigen::RowVector3d> extra;
  auto midpoint = [&](int a, int b) {
    const auto key = std::minmax(a, b);
    auto [it, fresh] =
        mid.try_emplace({key.first, key.second}, static_cast<int>(p.rows() + extra.size()));
    if (fresh) extra.push_back(0.5 * (p.row(a) + p.row(b)));
    return it->second;
  };
  Triangles out(4 * f.rows(), 3);
  for (Eigen::Index t = 0; t < f.rows(); ++t) {
    const int a = f(t, 0), b = f(t, 1), c = f(t, 2);
    const int ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
    out.row(4 * t) << a, ab, ca;
    out.row(4 * t + 1) << ab, b, bc;
    out.row(4 * t + 2) << ca, bc, c;
    out.row(4 * t + 3) << ab, bc, ca;
  }
  const Eigen::Index n = p.rows();
  p.conservativeResize(n + static_cast<Eigen::Index>(extra.size()), 3);
  for (std::size_t i = 0; i < extra.size(); ++i) p.row(n + static_cast<Eigen::Index>(i)) = extra[i];
  f = out;
}
}  // namespace

int main(int argc, char** argv) try {
  const long want = argc > 1 ? std::atol(argv[1]) : 1000000;
  const auto dir = facecast::test::test_data_dir() / "ict-facekit/FaceXModel";
  const rig::Rig rig = rig::read_obj(dir / "generic_neutral_mesh.obj");
  Points p = rig.positions.cast<double>();
  Triangles f = rig.triangles;
  VirtualEdgeStats base;
  const auto e0 = detect_virtual_edges(p, f, {}, &base);
  std::printf("%ld vertices: %zu virtual edges in %.3f s (d=%.4f)\n", static_cast<long>(p.rows()),
              e0.size(), base.seconds, base.d);
  while (p.rows() < want) subdivide(p, f);
  VirtualEdgeStats stats;
  const auto e = detect_virtual_edges(p, f, {}, &stats);
  std::printf("%ld vertices: %zu virtual edges in %.3f s (d=%.4f, %ld candidate pairs)\n",
              static_cast<long>(p.rows()), e.size(), stats.seconds, stats.d, stats.candidate_pairs);
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "bench_virtual_edges: %s\n", e.what());
  return 1;
}
