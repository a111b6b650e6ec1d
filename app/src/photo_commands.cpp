// facecast avatar from-photo
#include <future>
#include <iostream>
#include <nlohmann/json.hpp>

#include "facecast/app/commands.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/render/image.hpp"
#include "facecast/rig/rig_io.hpp"
#include "facecast/rigbuild/photo_avatar.hpp"
#include "progress.hpp"

namespace facecast::cli {
namespace {

struct PhotoArgs {
  std::string front, side, tmpl, out, report, landmarks_png;
};

// Everything is computed before anything is written; each file is written atomically.
void from_photo(const PhotoArgs& a) {
  rigbuild::PhotoOptions opt = rigbuild::load_photo_options();
  const std::filesystem::path tmpl_path = rigbuild::photo_template_path(opt, a.tmpl);
  const render::Image front = render::read_photo(a.front);
  std::optional<render::Image> side;
  if (!a.side.empty()) side = render::read_photo(a.side);
  const ProgressFn progress = terminal_progress();
  report(progress, "template", 0.0);
  // dlib's shape predictor (0.6 s) is read while the template is, and while the avatar's first
  // steps that need neither (the template's shapes, the face's box) run: the landmarks wait for it.
  auto detector = std::async(std::launch::async, [&] { rigbuild::load_photo_detector(opt); });
  const rigbuild::PhotoTemplate tmpl = rigbuild::load_photo_template(tmpl_path);
  const rigbuild::PhotoAvatar avatar = [&] {
    try {
      return rigbuild::avatar_from_photos(tmpl, front, side ? &*side : nullptr, opt, progress);
    } catch (const Error& e) {  // name the files: "front photo: no face found (face.jpg)"
      throw Error(std::string(e.what()) + " (" + a.front + (side ? ", " + a.side : "") + ")",
                  e.code());
    }
  }();
  for (const auto* m : {&avatar.front, &avatar.side})
    if (!m->note.empty()) std::cerr << "note: " << m->note << '\n';
  render::Image picture;
  if (!a.landmarks_png.empty()) {
    std::vector<render::Image> parts{rigbuild::photo_landmark_picture(front, avatar.front)};
    if (side)
      parts.push_back(
          rigbuild::photo_landmark_picture(*side, avatar.side, rigbuild::side_points(avatar.side)));
    picture = rigbuild::side_by_side(parts);
  }
  rig::write_glb(a.out, avatar.rig);
  if (!a.report.empty()) write_file_atomic(a.report, avatar.report.dump(2));
  if (!a.landmarks_png.empty()) render::write_image(a.landmarks_png, picture);
  std::cerr << "wrote " << a.out << ": " << avatar.rig.vertex_count() << " vertices, "
            << avatar.rig.shapes.size() << " shapes, texture coverage "
            << static_cast<int>(100 * avatar.texture_coverage) << " % ("
            << static_cast<int>(100 * avatar.texture_refused) << " % seen as background)\n";
}

}  // namespace

void add_avatar_photo_command(CLI::App& avatar) {
  auto args = std::make_shared<PhotoArgs>();
  auto* c = avatar.add_subcommand(
      "from-photo",
      "A textured, speaking avatar from a front photo (and optionally a side photo turned up to "
      "about 45 degrees): landmarks, shape fit, texture, expressions "
      "(docs/algorithms.md#photo-avatar)");
  c->add_option("--front", args->front, "Front photo (JPEG, PNG, ...)")->required();
  c->add_option("--side", args->side, "Side photo, the head turned 30-45 degrees");
  c->add_option("--template", args->tmpl,
                "Template: ICT FaceKit folder or rig file with identity* shapes (default: "
                "configs/rigbuild/photo.json's template, else the shipped ict_facekit.glb)");
  c->add_option("--out", args->out, "Output GLB")->required();
  c->add_option("--report", args->report, "JSON report: landmarks, cameras, fit, timings");
  c->add_option("--landmarks-png", args->landmarks_png, "The photos with their landmarks");
  c->callback([args] { from_photo(*args); });
}

}  // namespace facecast::cli
