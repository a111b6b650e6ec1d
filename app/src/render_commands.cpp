// facecast render --text T | --timestamps FILE | --fap FILE [--rig rig.glb] --out out.mp4 |
//   frames/%05d.png
// facecast render --rig rig.glb --weights name=value,... --out face.png   (one pose)
#include <cstdio>
#include <iostream>
#include <regex>

#include "facecast/app/commands.hpp"
#include "facecast/avatar/avatar.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/render/renderer.hpp"
#include "facecast/render/video.hpp"
#include "facecast/rig/rig_io.hpp"
#include "facecast/viseme/align.hpp"
#include "facecast/viseme/lipsync.hpp"
#include "progress.hpp"
#include "speech_input.hpp"

namespace facecast::cli {
namespace {

struct RenderArgs {
  SpeechArgs speech;
  std::string rig, weights, expression, out, size, audio;
  std::string look_at, framing, background_image, head, pose = "rest";
  float zoom = 1.0f;
  int msaa = -1;
  int quality = 90;
  double fps = 0;
};

// Blendshape weights of a named expression (configs/anim/expressions_arkit.json through the rig's
// mapping, so _L/_R rigs work), scaled by `intensity` ("joy" or "joy=0.5").
std::vector<std::pair<std::string, float>> expression_weights(const rig::Rig& rig,
                                                              const std::string& spec) {
  std::string name = spec;
  float intensity = 1.0f;
  if (const auto eq = spec.find('='); eq != std::string::npos) {
    name = spec.substr(0, eq);
    intensity = std::stof(spec.substr(eq + 1));
  }
  const anim::Mapping mapping = anim::Mapping::for_rig(rig.shape_names());
  const auto* row = mapping.expression(name);
  if (!row)
    throw Error("expression '" + name + "' is not in anim/expressions_arkit.json",
                ErrorCode::kNotFound);
  std::vector<std::pair<std::string, float>> out;
  for (const auto& e : *row) out.emplace_back(rig.shapes[e.shape].name, intensity * e.weight);
  return out;
}

// "WxH" -> width, height.
std::pair<int, int> parse_size(const std::string& size) {
  std::smatch m;
  if (!std::regex_match(size, m, std::regex(R"((\d{1,5})x(\d{1,5}))")))
    throw Error("--size: '" + size + "' is not WxH");
  return {std::stoi(m[1]), std::stoi(m[2])};
}

// Any motion of the rig -> MP4 (ffmpeg) or a frame sequence + WAV.
void write_motion(const RenderArgs& a, const rig::Rig& rig, render::RenderOptions opt,
                  const rig::Motion& motion, const std::vector<int16_t>& pcm, int rate) {
  render::VideoOptions vo = render::load_video_options();
  if (a.fps > 0) vo.fps = a.fps;
  opt.contexts = 2;
  render::Renderer renderer(rig, opt);
  const auto result =
      render::write_video(renderer, motion, pcm, rate, a.out, vo, terminal_progress());
  std::cerr << "wrote " << a.out << ": " << result.frames << " frames at " << vo.fps << " fps ("
            << result.duration << " s" << (pcm.empty() ? "" : ", with audio") << ") in "
            << result.render_seconds << " s (" << renderer.backend()
            << (result.encoder.empty() ? "" : ", " + result.encoder) << ")\n";
}

// Text or timestamps -> MP4 (ffmpeg) or a frame sequence + WAV.
void render_speech(const RenderArgs& a, const rig::Rig& rig, render::RenderOptions opt) {
  // Text with an audio file: the text is aligned to that speech (and the video carries it).
  const Speech s = speech_with_audio(a.speech, !a.audio.empty()         ? a.audio
                                               : !a.speech.text.empty() ? "tts"
                                                                        : "none");
  const anim::Mapping mapping = anim::Mapping::for_rig(rig.shape_names());
  write_motion(a, rig, opt, anim::Performance(s.utterance, mapping, speech_anim_options(a.speech)),
               s.pcm, s.sample_rate);
}

// An MPEG-4 FAP file -> video, with the sound of --audio FILE when given.
void render_fap(const RenderArgs& a, const rig::Rig& rig, const render::RenderOptions& opt) {
  if (a.speech.given()) throw Error("--fap plays a FAP file; leave --text and --timestamps out");
  std::vector<int16_t> pcm;
  int rate = 0;
  if (!a.audio.empty() && a.audio != "none") {
    if (a.audio == "tts") throw Error("--audio tts needs --text; give an audio file or none");
    const auto in = viseme::read_audio(a.audio, viseme::load_audio_options());
    pcm = viseme::to_pcm16(in.samples);
    rate = in.sample_rate;
  }
  // FAPs are measured on the face view (its landmarks index its vertices); the scene drawn has
  // the same shapes.
  const rig::Rig face = a.rig.empty() ? rig : rig::load_rig(a.rig);
  write_motion(a, rig, opt, read_fap_motion(a.speech.fap, fap_rig(face)), pcm, rate);
}

}  // namespace

void add_render_commands(CLI::App& app) {
  auto a = std::make_shared<RenderArgs>();
  auto* r = app.add_subcommand(
      "render",
      "Render speech (--text/--timestamps) or an MPEG-4 FAP file (--fap) to a video or frames, "
      "or one pose to an image");
  add_speech_options(r, a->speech);
  r->add_option("--audio", a->audio,
                "Speech audio for the video: tts (espeak-ng; default with --text), none (default "
                "with --timestamps), or an audio file (any format ffmpeg/libsndfile reads; with "
                "--text the text is aligned to it; alone, audio-only lip-sync)");
  r->add_option("--fps", a->fps, "Video frame rate (default from configs/render/render.json)")
      ->check(CLI::Range(1.0, 240.0));
  r->add_option("--rig", a->rig, "Rig (GLB or OBJ); default: the built-in avatar")
      ->check(CLI::ExistingFile);
  r->add_option("--weights", a->weights, "Blendshape weights: name=value,name=value,...");
  r->add_option(
      "--expression", a->expression,
      "An expression from configs/anim/expressions_arkit.json, optionally name=intensity");
  r->add_option("--out", a->out,
                "Speech: out.mp4 or frames/%05d.png (+ audio.wav); a pose: .png, .jpg or .exr")
      ->required();
  r->add_option("--size", a->size, "Image size WxH (default 1280x720 for speech, 640x480 a pose)");
  r->add_option("--msaa", a->msaa,
                "Multisample count, 0 = off (default: 4 for a pose, render.json for video)");
  r->add_option("--quality", a->quality, "JPEG quality")->capture_default_str();
  r->add_option("--look-at", a->look_at,
                "Aim the camera at x,y,z (rig units) instead of the face centre");
  r->add_option("--zoom", a->zoom, "Move the camera closer by this factor")->capture_default_str();
  r->add_option("--pose", a->pose,
                "How the figure stands: rest (default: an avatar saved in T- or A-pose stands with "
                "its arms down), bind (as the file holds it) or a pose file, FILE.json (bones and "
                "their turns, docs/cli.md#pose-files)");
  r->add_option("--framing", a->framing, "face, bust or full (default from render.json)")
      ->check(CLI::IsMember({"face", "bust", "full"}));
  r->add_option("--background-image", a->background_image, "An image behind the avatar")
      ->check(CLI::ExistingFile);
  r->add_option("--head", a->head, "A pose's head turn: yaw,pitch,roll in degrees");
  r->callback([a] {
    render::RenderOptions opt = render::load_render_options();
    // An audio file alone: audio-only lip-sync (docs/algorithms.md#audio-lipsync).
    const bool audio_only = !a->speech.given() && a->speech.fap.empty() && !a->audio.empty() &&
                            a->audio != "tts" && a->audio != "none";
    const bool speech = a->speech.given() || audio_only || !a->speech.fap.empty();
    std::tie(opt.width, opt.height) = parse_size(!a->size.empty() ? a->size
                                                 : speech         ? "1280x720"
                                                                  : "640x480");
    opt.msaa = a->msaa >= 0 ? a->msaa : speech ? opt.msaa : 4;
    opt.contexts = 1;
    if (!a->framing.empty())
      opt.framing = a->framing == "bust"   ? render::Framing::kBust
                    : a->framing == "full" ? render::Framing::kFull
                                           : render::Framing::kFace;
    if (!a->background_image.empty()) opt.background_image = a->background_image;
    const rig::Rig rig = a->rig.empty()
                             ? avatar::default_avatar()
                             : rig::load_scene(a->rig, rig::parse_pose(a->pose, "--pose"));
    if (speech) {
      if (!a->weights.empty() || !a->expression.empty())
        throw Error("--weights/--expression render one pose; they do not combine with --text");
      return a->speech.fap.empty() ? render_speech(*a, rig, opt) : render_fap(*a, rig, opt);
    }
    if (!a->audio.empty() || a->fps > 0)
      throw Error("--audio and --fps need --text or --timestamps");
    rig::BodyPose head;
    if (!a->head.empty()) {
      float yaw = 0, pitch = 0, roll = 0;
      if (std::sscanf(a->head.c_str(), "%f,%f,%f", &yaw, &pitch, &roll) != 3)
        throw Error("--head: '" + a->head + "' is not yaw,pitch,roll");
      constexpr float kRad = 3.14159265f / 180.0f;
      head = {yaw * kRad, pitch * kRad, roll * kRad};
    }
    auto named = a->expression.empty() ? std::vector<std::pair<std::string, float>>{}
                                       : expression_weights(rig, a->expression);
    for (auto& w : render::parse_weight_list(a->weights)) named.push_back(w);
    render::Renderer renderer(rig, opt);
    if (!a->look_at.empty() || a->zoom != 1.0f) {
      render::Camera cam = renderer.camera();
      if (!a->look_at.empty()) {
        float x = 0, y = 0, z = 0;
        if (std::sscanf(a->look_at.c_str(), "%f,%f,%f", &x, &y, &z) != 3)
          throw Error("--look-at: '" + a->look_at + "' is not x,y,z");
        cam.eye += Eigen::Vector3f(x, y, z) - cam.target;
        cam.target = Eigen::Vector3f(x, y, z);
      }
      if (!(a->zoom > 0)) throw Error("--zoom must be positive");
      cam.eye = cam.target + (cam.eye - cam.target) / a->zoom;
      renderer.set_camera(cam);
    }
    const std::vector<float> weights = render::weights_for(rig, named);
    render::write_image(a->out, renderer.render(weights, head), a->quality);
    std::cerr << "wrote " << a->out << " (" << opt.width << "x" << opt.height << ", "
              << renderer.backend() << ")\n";
  });
}

}  // namespace facecast::cli
