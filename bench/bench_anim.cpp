// bench_anim: the animation chain's speed.
//  - weights for a 60 s utterance at 60 fps: Performance construction + bake (target <= 10 ms)
//  - one sample() (what a server does per frame and stream)
//  - 10 s of speech -> a 1280x720 30 fps MP4 with audio, default avatar or --rig (target <= 20 s)
// Usage: bench_anim [--rig rig.glb] [--no-video]
#include <chrono>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <string>

#include "facecast/anim/animation.hpp"
#include "facecast/anim/fap.hpp"
#include "facecast/avatar/avatar.hpp"
#include "facecast/render/video.hpp"
#include "facecast/rig/rig_io.hpp"
#include "facecast/rigbuild/landmarks.hpp"
#include "facecast/viseme/viseme.hpp"

using namespace facecast;
using Clock = std::chrono::steady_clock;

namespace {

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// Text of about `seconds` of speech at the duration model's rate.
viseme::Utterance speech(double seconds, viseme::Timing timing) {
  const char* clauses[] = {"(joy, 40, 0.5)大家好，",
                           "欢迎来到 Facecast 的发布会。",
                           "今天我们发布新的虚拟主播，",
                           "(surprise, 50, 0.3) it speaks Chinese ",
                           "and English. ",
                           "银行行长说，",
                           "这个产品非常好。"};
  viseme::Options o;
  o.timing = timing;
  std::string text;
  for (int i = 0;; ++i) {
    text += clauses[i % std::size(clauses)];
    auto u = viseme::analyze(text, o);
    if (u.duration >= seconds) return u;
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::string rig_path;
  bool video = true;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--rig" && i + 1 < argc)
      rig_path = argv[++i];
    else if (a == "--no-video")
      video = false;
    else {
      std::cerr << "usage: bench_anim [--rig rig.glb] [--no-video]\n";
      return 2;
    }
  }
  try {
    const rig::Rig rig = rig_path.empty() ? avatar::default_avatar() : rig::load_rig(rig_path);
    const anim::Mapping mapping = anim::Mapping::for_rig(rig.shape_names());
    const anim::AnimOptions options = anim::load_anim_options();
    std::cout << std::fixed << std::setprecision(3);

    const auto u60 = speech(60, viseme::Timing::kModel);
    std::cout << "utterance: " << u60.duration << " s, " << u60.visemes.size() << " visemes, "
              << u60.expressions.size() << " expression tags; rig " << rig.shapes.size()
              << " shapes (" << mapping.table() << ")\n";
    double best = 1e9;
    anim::WeightTrack track;
    for (int rep = 0; rep < 5; ++rep) {
      const auto t0 = Clock::now();
      const anim::Performance p(u60, mapping, options);
      track = anim::bake(p, 60);
      best = std::min(best, ms_since(t0));
    }
    std::cout << "weights for " << u60.duration << " s at 60 fps (" << track.frames
              << " frames): " << best << " ms (best of 5; target <= 10 ms)\n";
    {
      const anim::Performance p(u60, mapping, options);
      std::vector<float> w(rig.shapes.size());
      rig::BodyPose head;
      const int n = 100000;
      const auto t0 = Clock::now();
      for (int i = 0; i < n; ++i) p.sample((i % 3600) / 60.0, w, &head);
      std::cout << "one sample(): " << ms_since(t0) * 1000.0 / n << " us\n";
    }
    // MPEG-4 FAPs at 25 fps through the rig's feature points: written, parsed, solved back.
    if (const auto landmarks = rigbuild::known_landmarks(rig)) {
      const anim::FapRig measured(rig, *landmarks);
      const anim::Performance p(u60, mapping, options);
      auto t0 = Clock::now();
      const std::string text = anim::to_fap_text(anim::to_fap(p, measured, 25));
      const double write = ms_since(t0);
      t0 = Clock::now();
      const anim::FapSequence back = anim::parse_fap(text, "bench");
      const double parse = ms_since(t0);
      t0 = Clock::now();
      const anim::FapMotion motion(back, measured, mapping);
      const double solve = ms_since(t0);
      const double n = static_cast<double>(back.frames.size());
      std::cout << "FAP, " << back.frames.size() << " frames (" << text.size() / 1024
                << " KiB): write " << write * 1000 / n << " us, parse " << parse * 1000 / n
                << " us, read into weights " << solve * 1000 / n << " us a frame\n";
    }

    if (video) {
      const auto u10 = speech(10, viseme::Timing::kTts);
      const anim::Performance p(u10, mapping, options);
      render::RenderOptions ro = render::load_render_options();
      ro.width = 1280;
      ro.height = 720;
      const render::Renderer renderer(rig, ro);
      const auto out = std::filesystem::temp_directory_path() / "bench_anim.mp4";
      const auto t0 = Clock::now();
      const auto r = render::write_video(renderer, p, u10.pcm, u10.sample_rate, out,
                                         render::load_video_options());
      const double s = ms_since(t0) / 1000.0;
      std::cout << "video: " << u10.duration << " s of speech -> " << r.frames
                << " frames 1280x720 at 30 fps + AAC in " << s << " s wall (" << r.frames / s
                << " fps; target <= 20 s), " << renderer.backend() << "\n";
      std::filesystem::remove(out);
    }
  } catch (const std::exception& e) {
    std::cerr << "bench_anim: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
