// Rig building without markers (automatic landmarks, docs/algorithms.md#landmarks): the ICT
// FaceKit template onto the MakeHuman head and the MediaPipe canonical face. Prints the time of
// every stage (from the build's progress reports and its timings) and the process's CPU time,
// so a wall time stretched by a busy machine can be told apart.
// Usage: bench_landmarks [--runs N]
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <utility>

#include "build_paths.hpp"
#include "facecast/core/config.hpp"
#include "facecast/rig/rig_io.hpp"
#include "facecast/rigbuild/build.hpp"

using namespace facecast;

namespace {

using Clock = std::chrono::steady_clock;

double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

void print_landmarks(const char* side, const rigbuild::LandmarkTimings& t) {
  std::printf("  %-9s landmarks: render %.2f, detect %.2f, predict %.2f, lift %.2f, fuse %.2f s\n",
              side, t.render, t.detect, t.predict, t.lift, t.fuse);
}

// How far a blink closes the lids: 1 - (lid gap with the shape) / (lid gap at rest), the gap
// being the mean distance of the landmark pairs 37-41 and 38-40 (the subject's right eye) or
// 43-47 and 44-46 (left), at the vertices `v` (the template's or the target's landmarks).
double closure(const rig::Rig& rig, const std::array<int, rigbuild::kLandmarkCount>& v,
               const std::string& shape, bool left) {
  const int k = rig.find_shape(shape);
  if (k < 0) return 0;
  const rig::Positions posed =
      rig.positions + rig.shapes[static_cast<std::size_t>(k)].dense(rig.vertex_count());
  const int o = left ? 6 : 0;
  double rest = 0, closed = 0;
  for (auto [a, b] : {std::pair{37, 41}, std::pair{38, 40}}) {
    const int va = v[static_cast<std::size_t>(a + o)], vb = v[static_cast<std::size_t>(b + o)];
    if (va < 0 || vb < 0) return 0;
    rest += (rig.positions.row(va) - rig.positions.row(vb)).norm();
    closed += (posed.row(va) - posed.row(vb)).norm();
  }
  return 1 - closed / rest;
}

void bench(const char* name, const rig::Rig& tmpl, const std::filesystem::path& head) {
  const rig::Rig target = rig::load_rig(head);
  const rigbuild::BuildOptions options = rigbuild::load_build_options();
  // Each stage's wall time, from one progress report to the next.
  std::string stage;
  Clock::time_point since = Clock::now();
  double cpu_since = cpu_seconds();
  std::printf("%s (%d vertices):\n", name, target.vertex_count());
  const auto progress = [&](std::string_view s, double) {
    if (s == stage) return;
    const auto now = Clock::now();
    const double cpu_now = cpu_seconds();
    if (!stage.empty())
      std::printf("  stage %-24s %.2f s wall, %.2f s CPU\n", stage.c_str(),
                  std::chrono::duration<double>(now - since).count(), cpu_now - cpu_since);
    stage = s;
    since = now;
    cpu_since = cpu_now;
  };
  const double cpu0 = cpu_seconds();
  const auto t0 = Clock::now();
  const rigbuild::BuildResult r = rigbuild::build_rig(tmpl, target, options, progress);
  const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
  const double cpu = cpu_seconds() - cpu0;
  if (r.landmarks) {
    print_landmarks("template", r.landmarks->template_timings);
    print_landmarks("target", r.landmarks->target.timings);
    std::printf("  %zu marker pairs from %d views\n", r.landmarks->markers.size(),
                r.landmarks->target.views_found);
    for (const char* shape : {"eyeBlink_L", "eyeBlink_R"})
      for (bool left : {false, true})
        std::printf(
            "  %s closes the %s lids at their landmark vertices by %.0f %% (template %.0f %%)\n",
            shape, left ? "left (42-47)" : "right (36-41)",
            100 * closure(r.rig, r.landmarks->target.vertex, shape, left),
            100 * closure(tmpl, r.landmarks->template_vertices, shape, left));
  }
  const auto& t = r.timings;
  std::printf(
      "  build %.2f s wall, %.2f s CPU: landmarks %.2f, registration %.2f, correspondence %.2f "
      "(all), gradients %.2f, virtual edges %.2f, factor %.2f, solve %.2f, contacts %.2f\n",
      wall, cpu, t.landmarks, t.registration, t.correspondence, t.gradients, t.detect, t.factor,
      t.solve, t.contacts);
}

}  // namespace

int main(int argc, char** argv) try {
  int runs = 1;
  for (int i = 1; i < argc; ++i)
    if (!std::strcmp(argv[i], "--runs") && i + 1 < argc) runs = std::atoi(argv[++i]);
  const auto dir = facecast::test::test_data_dir() / "ict-facekit/FaceXModel";
  const rig::Rig tmpl = rig::read_obj_shapes(dir / "generic_neutral_mesh.obj", dir, {"identity*"});
  for (int run = 0; run < runs; ++run) {
    bench("MakeHuman head", tmpl, shared_data_dir() / "makehuman/head.obj");
    bench("MediaPipe canonical face", tmpl,
          shared_data_dir() / "mediapipe/canonical_face_model.obj");
  }
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "bench_landmarks: %s\n", e.what());
  return 1;
}
