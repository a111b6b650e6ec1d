// Rig building on the ICT FaceKit: template -> random identity (same topology), with and without
// virtual edges; prints timings per stage and the error against the ground truth per shape.
// Usage: bench_rigbuild [seed] [--solver eigen] [--lambda L] [--verbose]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>

#include "facecast/rigbuild/build.hpp"
#include "facecast/rigbuild/quality.hpp"
#include "ict_truth.hpp"

using namespace facecast;

int main(int argc, char** argv) try {
  unsigned seed = 7;
  rigbuild::BuildOptions opt;
  bool verbose = false;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--solver") && i + 1 < argc) {
      opt.solver = !std::strcmp(argv[++i], "eigen") ? rigbuild::SolverKind::kEigenLDLT
                                                    : rigbuild::SolverKind::kCholmod;
    } else if (!std::strcmp(argv[i], "--lambda") && i + 1 < argc) {
      opt.lambda = std::atof(argv[++i]);
    } else if (!std::strcmp(argv[i], "--verbose")) {
      verbose = true;
    } else {
      seed = static_cast<unsigned>(std::atoi(argv[i]));
    }
  }
  const auto dir = std::filesystem::path(FACECAST_TEST_DATA_DIR) / "ict-facekit/FaceXModel";
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
    std::printf("wall %.3f s: gradients %.3f, detect %.3f, factor %.3f (nnz %ld), solve %.3f\n",
                wall, r.timings.gradients, r.timings.detect, r.timings.factor, r.factor_nonzeros,
                r.timings.solve);
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
  }
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "bench_rigbuild: %s\n", e.what());
  return 1;
}
