#pragma once
// Ground truth for rig building from the ICT FaceKit identity modes (header-only, for tests and
// benchmarks): target = neutral + sum_k c_k (identity_k - neutral), c_k ~ N(0, sigma^2), and the
// true expression e on it = target + (expr_e - neutral).
#include <filesystem>
#include <random>
#include <string>

#include "facecast/rig/rig_io.hpp"

namespace facecast::test {

struct IctTruth {
  rig::Rig template_rig;  // neutral + 57 expressions
  rig::Rig target;        // the random identity, no shapes
  // The true shapes of the target are target.positions + template_rig.shapes[k] deltas.
};

inline IctTruth make_ict_truth(const std::filesystem::path& dir, unsigned seed,
                               double sigma = 1.0) {
  IctTruth t;
  t.template_rig = rig::read_obj_shapes(dir / "generic_neutral_mesh.obj", dir, {"identity*"});
  t.target = t.template_rig;
  t.target.shapes.clear();
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, sigma);
  for (int k = 0; k < 10; ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "identity%03d.obj", k);
    const rig::Positions mode = rig::read_obj_positions(dir / name) - t.template_rig.positions;
    t.target.positions += static_cast<float>(n(rng)) * mode;
  }
  t.target.normals = rig::vertex_normals(t.target.positions, t.target.triangles);
  return t;
}

}  // namespace facecast::test
