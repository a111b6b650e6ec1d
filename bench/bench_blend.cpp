// Loads a packed rig (default: the ICT FaceKit packed on the fly from the extracted test data) and
// applies random weights to every shape; prints the time per frame for positions and normals.
// Usage: bench_blend [rig.glb] [frames]
#include <chrono>
#include <cstdio>
#include <random>

#include "build_paths.hpp"
#include "facecast/core/error.hpp"
#include "facecast/rig/blend.hpp"
#include "facecast/rig/rig_io.hpp"

using namespace facecast::rig;
using Clock = std::chrono::steady_clock;

int main(int argc, char** argv) try {
  const std::filesystem::path ict = facecast::test::test_data_dir() / "ict-facekit/FaceXModel";
  const auto t0 = Clock::now();
  Rig rig = argc > 1 ? load_rig(argv[1])
                     : parse_glb(glb_bytes(read_obj_shapes(ict / "generic_neutral_mesh.obj", ict,
                                                           {"identity*"})),
                                 "ict.glb");
  const double load_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  const int frames = argc > 2 ? std::atoi(argv[2]) : 500;
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  Blender blender(rig);
  Positions p, n;
  std::vector<float> w(rig.shapes.size());
  double pos_ms = 0, all_ms = 0;
  for (int f = 0; f < frames; ++f) {
    for (auto& x : w) x = u(rng);
    auto a = Clock::now();
    blender.apply_positions(w, p);
    auto b = Clock::now();
    blender.apply(w, p, n);
    auto c = Clock::now();
    pos_ms += std::chrono::duration<double, std::milli>(b - a).count();
    all_ms += std::chrono::duration<double, std::milli>(c - b).count();
  }
  std::printf("rig: %d vertices, %d triangles, %zu shapes (load %.1f ms)\n", rig.vertex_count(),
              rig.triangle_count(), rig.shapes.size(), load_ms);
  std::printf("blend positions:           %.3f ms/frame\n", pos_ms / frames);
  std::printf("blend positions + normals: %.3f ms/frame (%d frames, all weights random)\n",
              all_ms / frames, frames);
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "bench_blend: %s\n", e.what());
  return 1;
}
