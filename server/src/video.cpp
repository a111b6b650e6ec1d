#include "video.hpp"

#include <chrono>

#include "facecast/core/error.hpp"
#include "facecast/render/renderer.hpp"
#include "facecast/render/video.hpp"
#include "facecast/viseme/analyze.hpp"

namespace facecast::server {

nlohmann::json render_video(const StreamServices& services, const VideoRequest& r,
                            JobContext& ctx) {
  namespace fs = std::filesystem;
  const auto t0 = std::chrono::steady_clock::now();
  ctx.progress("analysis", 0.0);
  const auto rig = services.rigs.load(r.rig);
  const viseme::Utterance u = viseme::analyze(
      r.text,
      services.speech.options(r.lang, r.audio ? viseme::Timing::kTts : viseme::Timing::kModel,
                              r.voice, r.rate));
  anim::AnimOptions ao = services.speech.anim_options();
  ao.idle = r.idle;
  const anim::Performance perf(u, rig->mapping, ao);
  if (perf.duration() > services.options.max_render_seconds) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "text: the video would last %.1f s, the limit is %g s",
                  perf.duration(), services.options.max_render_seconds);
    throw Error(buf, ErrorCode::kLimit);
  }
  const fs::path dir =
      (services.options.shared_dir.empty() ? services.options.data : services.options.shared_dir) /
      "renders";
  fs::create_directories(dir);
  const fs::path out = dir / (ctx.id() + ".mp4");

  ctx.progress("render", 0.0);
  render::RenderOptions ro = services.rendering.options;
  ro.width = r.width;
  ro.height = r.height;
  ro.contexts = 2;
  const render::Renderer renderer(*rig->rig, ro);
  render::VideoOptions vo = services.rendering.video;
  vo.fps = r.fps;
  const bool with_audio = r.audio && !u.pcm.empty() && u.sample_rate > 0;
  const std::vector<std::int16_t> no_audio;
  const render::VideoResult result = render::write_video(
      renderer, perf, with_audio ? u.pcm : no_audio, u.sample_rate, out, vo, ctx.progress_fn());
  ctx.add_file("video.mp4", out);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  services.metrics.video_render_seconds.observe(secs);
  return {{"url", "/api/jobs/" + ctx.id() + "/video.mp4"},
          {"frames", result.frames},
          {"fps", r.fps},
          {"duration", result.duration},
          {"size", {r.width, r.height}},
          {"audio", with_audio},
          {"seconds", secs},
          {"renderer", renderer.backend()},
          {"encoder", result.encoder}};
}

}  // namespace facecast::server
