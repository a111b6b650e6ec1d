// Rig building on the ICT FaceKit: template -> random identity (same topology), with and without
// virtual edges; prints timings per stage and the error against the ground truth per shape.
// Usage: bench_rigbuild [seed] [--solver eigen] [--lambda L] [--ve-spacing S]
//                       [--intersections] [--verbose]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>

#include "build_paths.hpp"
#include "facecast/rigbuild/build.hpp"
#include "facecast/rigbuild/quality.hpp"
#include "ict_truth.hpp"

using namespace facecast;

namespace {
// Skin self-intersections (vertices 0-14061) of the built rig that the truth shape does not have.
void report_intersections(const rigbuild::BuildResult& r, const test::IctTruth& truth,
                          bool verbose) {
  rig::Rig truth_rig = truth.target;
  truth_rig.shapes = truth.template_rig.shapes;
  rigbuild::IntersectionCheck skin;
  for (int t = 0; t < r.rig.triangle_count(); ++t)
    skin.region.push_back(r.rig.triangles.row(t).maxCoeff() < 14062);
  const auto inter = rigbuild::shape_intersections(
      r.rig, &truth_rig, rigbuild::TriangleMap::identity(r.rig.triangle_count()), skin);
  std::size_t fresh = 0, shapes = 0;
  for (const auto& s : inter.shapes) {
    fresh += s.fresh;
    shapes += s.fresh > 0;
    if (!verbose || !s.fresh) continue;
    std::printf("  %-18s %zu new pairs:", s.shape.c_str(), s.fresh);
    for (auto [a, b] : s.fresh_pairs) {
      // The closest vertex pair across the two triangles in the neutral, and whether a virtual
      // edge holds either triangle.
      double gap = 1e30;
      int edges = 0;
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
          const int va = r.rig.triangles(a, i), vb = r.rig.triangles(b, j);
          gap = std::min<double>(gap, (r.rig.positions.row(va) - r.rig.positions.row(vb)).norm());
        }
      }
      for (const auto& e : r.virtual_edges) {
        for (int i = 0; i < 3; ++i) {
          edges += e.a == r.rig.triangles(a, i) || e.b == r.rig.triangles(a, i) ||
                   e.a == r.rig.triangles(b, i) || e.b == r.rig.triangles(b, i);
        }
      }
      std::printf(" (%d %d %d | %d %d %d: gap %.4f, %d edges)", r.rig.triangles(a, 0),
                  r.rig.triangles(a, 1), r.rig.triangles(a, 2), r.rig.triangles(b, 0),
                  r.rig.triangles(b, 1), r.rig.triangles(b, 2), gap, edges);
    }
    std::printf("\n");
  }
  std::printf("skin: %zu new intersecting pairs against the truth in %zu shapes (%.2f s)\n", fresh,
              shapes, inter.seconds);
}
}  // namespace

int main(int argc, char** argv) try {
  unsigned seed = 7;
  rigbuild::BuildOptions opt;
  bool verbose = false, intersections = false;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--solver") && i + 1 < argc) {
      opt.solver = !std::strcmp(argv[++i], "eigen") ? rigbuild::SolverKind::kEigenLDLT
                                                    : rigbuild::SolverKind::kCholmod;
    } else if (!std::strcmp(argv[i], "--lambda") && i + 1 < argc) {
      opt.lambda = std::atof(argv[++i]);
    } else if (!std::strcmp(argv[i], "--ve-spacing") && i + 1 < argc) {
      opt.ve.spacing = std::atof(argv[++i]);
    } else if (!std::strcmp(argv[i], "--contact-rounds") && i + 1 < argc) {
      opt.contacts.rounds = std::atoi(argv[++i]);
    } else if (!std::strcmp(argv[i], "--intersections")) {
      intersections = true;
    } else if (!std::strcmp(argv[i], "--verbose")) {
      verbose = true;
    } else {
      seed = static_cast<unsigned>(std::atoi(argv[i]));
    }
  }
  const auto dir = facecast::test::test_data_dir() / "ict-facekit/FaceXModel";
  const auto truth = test::make_ict_truth(dir, seed);
  for (auto mode : {rigbuild::VirtualEdgeMode::kAuto, rigbuild::VirtualEdgeMode::kOff}) {
    opt.virtual_edges = mode;
    const auto t0 = std::chrono::steady_clock::now();
    const auto r = rigbuild::build_rig(truth.template_rig, truth.target, opt);
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("\n== virtual edges %s: %zu edges (d=%.4f, %ld candidate pairs, %ld qualifying)\n",
                mode == rigbuild::VirtualEdgeMode::kAuto ? "on" : "off", r.virtual_edges.size(),
                r.ve_stats.d, r.ve_stats.candidate_pairs, r.ve_stats.qualifying_pairs);
    std::printf(
        "wall %.3f s: gradients %.3f, detect %.3f, factor %.3f (nnz %ld), solve %.3f, contacts "
        "%.3f\n",
        wall, r.timings.gradients, r.timings.detect, r.timings.factor, r.factor_nonzeros,
        r.timings.solve, r.timings.contacts);
    int crossings = 0, left = 0, pairs = 0;
    for (const auto& q : r.quality) {
      crossings += q.crossings;
      left += q.crossings_left;
      pairs += q.contacts;
    }
    std::printf(
        "contacts: %zu watched triangle pairs, %d crossings after the transfer, %d left, "
        "%d contacts\n",
        r.watched_pairs, crossings, left, pairs);
    const auto errors =
        rigbuild::truth_errors(r.rig, truth.target.positions, truth.template_rig, 0, 14062);
    double worst_mean = 0, worst_p99 = 0;
    for (const auto& e : errors) {
      worst_mean = std::max(worst_mean, e.mean);
      worst_p99 = std::max(worst_p99, e.p99_percent);
      if (verbose)
        std::printf("  %-18s mean %.4f p99 %.4f (%.3f%%) max %.4f\n", e.shape.c_str(), e.mean,
                    e.p99, e.p99_percent, e.max);
    }
    std::printf("skin error over %zu shapes: worst mean %.4f, worst p99 %.3f%% of the diagonal\n",
                errors.size(), worst_mean, worst_p99);
    if (intersections) report_intersections(r, truth, verbose);
  }
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "bench_rigbuild: %s\n", e.what());
  return 1;
}
