// Renders the ICT FaceKit (packed from the extracted test data) and the built-in avatar at 640x480
// with random weights, JPEG-encodes each frame, and prints frames per second; also times the
// triangle self-intersection check on the ICT neutral.
// Usage: bench_render [frames] [msaa]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <random>

#include "facecast/anim/avatar.hpp"
#include "facecast/anim/intersections.hpp"
#include "facecast/anim/rig_io.hpp"
#include "facecast/render/renderer.hpp"

using namespace facecast;
using Clock = std::chrono::steady_clock;

namespace {
double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

void bench(const char* label, const anim::Rig& rig, int frames, int msaa) {
  render::RenderOptions o;
  o.msaa = msaa;
  o.contexts = 1;
  auto t0 = Clock::now();
  const render::Renderer r(rig, o);
  std::vector<float> w(rig.shapes.size(), 0.0f);
  (void)r.render(w);  // context creation and upload
  const double setup = ms_since(t0);
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  double render_ms = 0, jpeg_ms = 0;
  std::size_t bytes = 0;
  for (int f = 0; f < frames; ++f) {
    for (auto& x : w) x = 0.5f * u(rng);
    auto a = Clock::now();
    const render::Image img = r.render(w);
    auto b = Clock::now();
    bytes += render::encode_jpeg(img, 85).size();
    render_ms += std::chrono::duration<double, std::milli>(b - a).count();
    jpeg_ms += ms_since(b);
  }
  std::printf("%s: %d vertices, %d triangles, %zu shapes; setup %.0f ms (%s)\n", label,
              rig.vertex_count(), rig.triangle_count(), rig.shapes.size(), setup,
              r.backend().c_str());
  std::printf("  640x480 msaa %d: render %.2f ms + JPEG %.2f ms = %.1f fps (%zu KB/frame)\n", msaa,
              render_ms / frames, jpeg_ms / frames, 1000.0 * frames / (render_ms + jpeg_ms),
              bytes / frames / 1024);
}
}  // namespace

int main(int argc, char** argv) try {
  const int frames = argc > 1 ? std::atoi(argv[1]) : 100;
  const int msaa = argc > 2 ? std::atoi(argv[2]) : 0;
  auto t0 = Clock::now();
  const anim::Rig avatar = anim::make_avatar();
  const double generation = ms_since(t0);
  t0 = Clock::now();
  const std::size_t glb = anim::glb_bytes(avatar).size();
  std::printf("avatar generation: %.0f ms, GLB encoding %.0f ms (%zu KB)\n", generation, ms_since(t0),
              glb / 1024);
  bench("avatar", avatar, frames, msaa);
  const std::filesystem::path ict =
      std::filesystem::path(FACECAST_TEST_DATA_DIR) / "ict-facekit/FaceXModel";
  if (!std::filesystem::exists(ict / "generic_neutral_mesh.obj")) {
    std::printf("ICT FaceKit not extracted under %s: skipped\n", ict.c_str());
    return 0;
  }
  const anim::Rig rig = anim::read_obj_shapes(ict / "generic_neutral_mesh.obj", ict, {"identity*"});
  bench("ICT FaceKit", rig, frames, msaa);
  bench("ICT FaceKit", rig, frames / 2, 4);
  t0 = Clock::now();
  const auto rep = anim::find_intersections(rig.positions, rig.triangles);
  std::printf("intersection check, ICT neutral: %.1f ms (%zu pairs)\n", ms_since(t0), rep.count);
  t0 = Clock::now();
  const auto rep2 = anim::find_intersections(avatar.positions, avatar.triangles);
  std::printf("intersection check, avatar neutral: %.1f ms (%zu pairs incl. touching lips)\n",
              ms_since(t0), rep2.count);
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "bench_render: %s\n", e.what());
  return 1;
}
