// facecast render --rig rig.glb --weights name=value,... --out face.png   (one pose)
#include <cstdio>
#include <iostream>
#include <regex>

#include "commands.hpp"
#include "facecast/anim/avatar.hpp"
#include "facecast/anim/rig_io.hpp"
#include "facecast/core/config.hpp"
#include "facecast/core/error.hpp"
#include "facecast/render/renderer.hpp"

namespace facecast::cli {
namespace {

struct RenderArgs {
  std::string rig, weights, expression, out, size = "640x480";
  std::string look_at;
  float zoom = 1.0f;
  int msaa = 4;
  int quality = 90;
};

// Blendshape weights of a named expression from configs/anim/expressions_arkit.json, scaled by
// `intensity`; on rigs with _L/_R names (ICT FaceKit) Left/Right suffixes are mapped.
std::vector<std::pair<std::string, float>> expression_weights(const anim::Rig& rig,
                                                              const std::string& spec) {
  std::string name = spec;
  float intensity = 1.0f;
  if (const auto eq = spec.find('='); eq != std::string::npos) {
    name = spec.substr(0, eq);
    intensity = std::stof(spec.substr(eq + 1));
  }
  const auto table = load_json(config_path("anim/expressions_arkit.json"));
  const auto& exprs = table.at("expressions");
  if (!exprs.contains(name))
    throw Error("expression '" + name + "' is not in anim/expressions_arkit.json",
                ErrorCode::kNotFound);
  std::vector<std::pair<std::string, float>> out;
  for (const auto& [shape, w] : exprs.at(name).items()) {
    std::string target = shape;
    if (rig.find_shape(target) < 0) {
      for (const auto& [suffix, short_suffix] :
           {std::pair{"Left", "_L"}, std::pair{"Right", "_R"}}) {
        const std::string s = suffix;
        if (target.size() > s.size() && target.ends_with(s))
          target = target.substr(0, target.size() - s.size()) + short_suffix;
      }
    }
    if (rig.find_shape(target) >= 0) out.emplace_back(target, intensity * w.get<float>());
  }
  return out;
}

}  // namespace

void add_render_commands(CLI::App& app) {
  auto a = std::make_shared<RenderArgs>();
  auto* r = app.add_subcommand("render", "Render one pose of a rig to an image (PNG, JPEG or EXR)");
  r->add_option("--rig", a->rig, "Rig (GLB or OBJ); default: the built-in avatar")
      ->check(CLI::ExistingFile);
  r->add_option("--weights", a->weights, "Blendshape weights: name=value,name=value,...");
  r->add_option(
      "--expression", a->expression,
      "An expression from configs/anim/expressions_arkit.json, optionally name=intensity");
  r->add_option("--out", a->out, "Output image (.png, .jpg or .exr)")->required();
  r->add_option("--size", a->size, "Image size WxH")->capture_default_str();
  r->add_option("--msaa", a->msaa, "Multisample count (0 = off)")->capture_default_str();
  r->add_option("--quality", a->quality, "JPEG quality")->capture_default_str();
  r->add_option("--look-at", a->look_at,
                "Aim the camera at x,y,z (rig units) instead of the face centre");
  r->add_option("--zoom", a->zoom, "Move the camera closer by this factor")->capture_default_str();
  r->callback([a] {
    std::smatch m;
    if (!std::regex_match(a->size, m, std::regex(R"((\d{1,5})x(\d{1,5}))")))
      throw Error("--size: '" + a->size + "' is not WxH");
    render::RenderOptions opt;
    opt.width = std::stoi(m[1]);
    opt.height = std::stoi(m[2]);
    opt.msaa = a->msaa;
    opt.contexts = 1;
    const anim::Rig rig = a->rig.empty() ? anim::default_avatar() : anim::load_rig(a->rig);
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
    render::write_image(a->out, renderer.render(weights), a->quality);
    std::cerr << "wrote " << a->out << " (" << opt.width << "x" << opt.height << ", "
              << renderer.backend() << ")\n";
  });
}

}  // namespace facecast::cli
