// Renders the ICT FaceKit (packed from the extracted test data) and the built-in avatar at 640x480
// with random weights, JPEG-encodes each frame, and prints frames per second: one stream, and two
// streams at once on two threads (what two viewers of frames mode cost); also a heavier textured
// avatar (every material with its own 1024x1024 base-colour texture, the skin with a normal and an
// occlusion map: 12 textures); and times the triangle self-intersection check.
// Also the spring bones' simulation per frame.
// Usage: bench_render [frames] [msaa] [avatar|textured|ict|springs] [lod_pixels]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <random>
#include <string>
#include <thread>

#include "build_paths.hpp"
#include "facecast/avatar/avatar.hpp"
#include "facecast/render/renderer.hpp"
#include "facecast/rig/intersections.hpp"
#include "facecast/rig/rig_io.hpp"

using namespace facecast;
using Clock = std::chrono::steady_clock;

namespace {
double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

// CPU time of the whole process (every thread, llvmpipe's rasterizer threads too), in ms: the
// figure that does not depend on what else runs on the machine.
double process_cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return 1e3 * static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_nsec);
}

struct Figures {
  double render_ms = 0, jpeg_ms = 0, cpu_ms = 0;
  std::size_t bytes = 0;
};

// `frames` frames of random weights on one renderer, each JPEG-encoded.
Figures stream(const render::Renderer& r, std::size_t shapes, int frames, unsigned seed) {
  std::vector<float> w(shapes, 0.0f);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  Figures f;
  const double cpu0 = process_cpu_ms();
  for (int i = 0; i < frames; ++i) {
    for (auto& x : w) x = 0.5f * u(rng);
    auto a = Clock::now();
    const render::Image img = r.render(w);
    auto b = Clock::now();
    f.bytes += render::encode_jpeg(img, 85).size();
    f.render_ms += std::chrono::duration<double, std::milli>(b - a).count();
    f.jpeg_ms += ms_since(b);
  }
  f.cpu_ms = process_cpu_ms() - cpu0;
  return f;
}

void bench(const char* label, const rig::Rig& rig, int frames, int msaa, float lod_pixels) {
  render::RenderOptions o;
  o.msaa = msaa;
  o.lod_pixels = lod_pixels;
  o.contexts = 2;
  auto t0 = Clock::now();
  const render::Renderer r(rig, o);
  r.create_contexts();  // both contexts and their uploads, outside the timed streams
  const double setup = ms_since(t0);
  const Figures one = stream(r, rig.shapes.size(), frames, 1);
  std::printf(
      "%s: %d vertices, %d triangles (%zu drawn: lod_pixels %.2f), %zu shapes, %zu textures; "
      "setup %.0f ms (%s)\n",
      label, rig.vertex_count(), rig.triangle_count(), r.triangle_counts().second, o.lod_pixels,
      rig.shapes.size(), rig.textures.size(), setup, r.backend().c_str());
  std::printf("  640x480 msaa %d: render %.2f ms + JPEG %.2f ms = %.1f fps (%zu KB/frame)\n", msaa,
              one.render_ms / frames, one.jpeg_ms / frames,
              1000.0 * frames / (one.render_ms + one.jpeg_ms), one.bytes / frames / 1024);
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  std::printf("  CPU per frame (all threads) %.2f ms: at most %.1f fps on %u cores\n",
              one.cpu_ms / frames, 1000.0 * cores * frames / one.cpu_ms, cores);
  // Two streams at once: each thread renders and encodes its own frames.
  Figures two[2];
  t0 = Clock::now();
  const double cpu0 = process_cpu_ms();
  std::thread other([&] { two[1] = stream(r, rig.shapes.size(), frames, 2); });
  two[0] = stream(r, rig.shapes.size(), frames, 3);
  other.join();
  const double wall = ms_since(t0), cpu = process_cpu_ms() - cpu0;
  std::printf(
      "  two streams at once: %.1f fps each (%d frames each in %.0f ms); CPU per frame "
      "%.2f ms\n",
      1000.0 * frames / wall, frames, wall, cpu / (2.0 * frames));
}

// The avatar with a 1024x1024 base-colour texture of its own per material (value noise in the
// material's colour), and a normal and an occlusion map on the skin.
rig::Rig heavily_textured(rig::Rig rig) {
  const int n = 1024;
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> grain(-12, 12);
  const auto texture = [&](const std::string& name, auto colour) {
    render::Image img{n, n, 3, {}};
    img.pixels.resize(static_cast<std::size_t>(n) * n * 3);
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        for (int c = 0; c < 3; ++c)
          img.pixels[(static_cast<std::size_t>(y) * n + x) * 3 + c] =
              static_cast<std::uint8_t>(std::clamp(colour(x, y, c) + grain(rng), 0, 255));
    rig.textures.push_back({name, "image/png", render::encode_png(img)});
    return static_cast<int>(rig.textures.size()) - 1;
  };
  for (auto& m : rig.materials) {
    const Eigen::Vector4f c = m.base_color;
    m.base_color_texture.texture = texture(m.name, [&](int, int, int k) {
      return static_cast<int>(255.0f * std::pow(c[k], 1.0f / 2.2f));
    });
    m.base_color = Eigen::Vector4f::Ones();
    if (m.name == "M_Skin") {
      m.normal_texture.texture = texture("skin_normal", [](int x, int y, int k) {
        return k == 2 ? 255 : 128 + static_cast<int>(20 * std::sin((k ? y : x) * 0.2));
      });
      m.occlusion_texture.texture = texture("skin_occlusion", [](int, int, int) { return 230; });
    }
  }
  return rig;
}

// The spring bones' cost per frame at the size of a VRoid export's (about 180 joints): 30 chains
// of six joints hanging from a head, each spring against 12 sphere colliders, stepped at 60 Hz for
// 30 frames a second while the head turns back and forth.
void bench_springs() {
  rig::Skeleton s;
  s.joint_names = {"Hips", "Neck", "Head"};
  s.parent = {-1, 0, 1};
  s.rest_origin = {{0, 1, 0}, {0, 1.5f, 0}, {0, 1.6f, 0}};
  s.head = 2;
  s.neck = 1;
  for (int c = 0; c < 12; ++c) {
    const float a = static_cast<float>(c) * 0.52f;
    rig::SpringCollider col;
    col.joint = 2;
    col.offset = col.tail = {0.08f * std::cos(a), 1.65f, 0.08f * std::sin(a)};
    col.radius = 0.05f;
    s.springs.colliders.push_back(col);
  }
  for (int chain = 0; chain < 30; ++chain) {
    const float a = static_cast<float>(chain) * 0.21f;
    rig::SpringBones::Spring spring;
    for (int k = 0; k < 6; ++k) {
      const int j = static_cast<int>(s.parent.size());
      s.joint_names.push_back("Hair" + std::to_string(j));
      s.parent.push_back(k == 0 ? 2 : j - 1);
      const float down = 0.05f * static_cast<float>(k);
      s.rest_origin.push_back({0.1f * std::cos(a), 1.7f - down, 0.1f * std::sin(a)});
      rig::SpringJoint sj;
      sj.joint = j;
      sj.tail = {0.1f * std::cos(a), 1.65f - down, 0.1f * std::sin(a)};
      sj.gravity_power = 0.2f;
      spring.joints.push_back(sj);
    }
    for (int c = 0; c < 12; ++c) spring.colliders.push_back(c);
    s.springs.springs.push_back(spring);
  }
  rig::SpringSim sim(s);
  const int frames = 300;
  const auto t0 = Clock::now();
  for (int f = 0; f < frames; ++f) {
    rig::BodyPose pose;
    pose.yaw = 0.5f * std::sin(static_cast<float>(f) * 0.1f);
    (void)sim.advance(pose, f / 30.0);
  }
  std::printf("spring bones, 180 joints x 12 colliders: %.3f ms per 30 fps frame (two steps)\n",
              ms_since(t0) / frames);
}

}  // namespace

int main(int argc, char** argv) try {
  const int frames = argc > 1 ? std::atoi(argv[1]) : 100;
  const int msaa = argc > 2 ? std::atoi(argv[2]) : 0;
  // Optional third argument: run only one case (avatar, textured or ict).
  const std::string only = argc > 3 ? argv[3] : "";
  const float lod = argc > 4 ? std::strtof(argv[4], nullptr) : render::RenderOptions{}.lod_pixels;
  const auto wanted = [&](const char* name) { return only.empty() || only == name; };
  auto t0 = Clock::now();
  const rig::Rig avatar = avatar::make_avatar();
  const double generation = ms_since(t0);
  t0 = Clock::now();
  const std::size_t glb = rig::glb_bytes(avatar).size();
  std::printf("avatar generation: %.0f ms, GLB encoding %.0f ms (%zu KB)\n", generation,
              ms_since(t0), glb / 1024);
  if (wanted("springs") || only.empty()) bench_springs();
  if (wanted("avatar")) bench("avatar", avatar, frames, msaa, lod);
  if (wanted("textured"))
    bench("avatar, 12 textures of 1024x1024", heavily_textured(avatar), frames, msaa, lod);
  if (!wanted("ict")) return 0;
  const std::filesystem::path ict = facecast::test::test_data_dir() / "ict-facekit/FaceXModel";
  if (!std::filesystem::exists(ict / "generic_neutral_mesh.obj")) {
    std::printf("ICT FaceKit not extracted under %s: skipped\n", ict.c_str());
    return 0;
  }
  const rig::Rig rig = rig::read_obj_shapes(ict / "generic_neutral_mesh.obj", ict, {"identity*"});
  bench("ICT FaceKit", rig, frames, msaa, lod);
  bench("ICT FaceKit", rig, frames / 2, 4, lod);
  t0 = Clock::now();
  const auto rep = rig::find_intersections(rig.positions, rig.triangles);
  std::printf("intersection check, ICT neutral: %.1f ms (%zu pairs)\n", ms_since(t0), rep.count);
  t0 = Clock::now();
  const auto rep2 = rig::find_intersections(avatar.positions, avatar.triangles);
  std::printf("intersection check, avatar neutral: %.1f ms (%zu pairs incl. touching lips)\n",
              ms_since(t0), rep2.count);
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "bench_render: %s\n", e.what());
  return 1;
}
