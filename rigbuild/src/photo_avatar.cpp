// An avatar from photos: the template, the options and the pipeline (landmarks, fit, texture,
// expressions). See docs/algorithms.md#photo-avatar.
#include "facecast/rigbuild/photo_avatar.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cctype>
#include <chrono>
#include <cmath>
#include <optional>

#include "facecast/core/config.hpp"
#include "facecast/core/config_reader.hpp"
#include "facecast/core/error.hpp"
#include "facecast/render/renderer.hpp"
#include "facecast/rig/avatar_view.hpp"
#include "facecast/rig/rig_io.hpp"
#include "facecast/rigbuild/template.hpp"
#include "geometry.hpp"
#include "parallel.hpp"
#include "photo_detail.hpp"
#include "stages.hpp"

namespace facecast::rigbuild {
namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

bool has(const std::string& s, const char* part) {
  return s.find(part) != std::string::npos;
}

// Per vertex: skin (the face and back-of-head materials, textured from the photos) and rigid
// groups (each eye, the mouth interior), from the materials' names.
void classify_vertices(PhotoTemplate& t) {
  const rig::Rig& rig = t.rig;
  std::vector<char> skin_material(rig.materials.size(), 0);
  std::vector<int> group_material(rig.materials.size(), 0);
  bool any_skin = false;
  for (std::size_t m = 0; m < rig.materials.size(); ++m) {
    const std::string n = lower(rig.materials[m].name);
    const bool eye =
        has(n, "eye") || has(n, "sclera") || has(n, "iris") || has(n, "pupil") || has(n, "cornea");
    skin_material[m] = !eye && (has(n, "face") || has(n, "skin") || has(n, "head"));
    any_skin = any_skin || skin_material[m];
    if (has(n, "sclera") || has(n, "iris") || has(n, "pupil") || has(n, "eyeball"))
      group_material[m] = has(n, "right") ? 2 : 1;
    else if (has(n, "teeth") || has(n, "gum") || has(n, "tongue"))
      group_material[m] = 3;
  }
  if (!any_skin && !skin_material.empty()) skin_material[0] = 1;
  t.skin.assign(static_cast<std::size_t>(rig.vertex_count()), 0);
  t.rigid.assign(static_cast<std::size_t>(rig.vertex_count()), 0);
  for (int f = 0; f < rig.triangle_count(); ++f) {
    const auto m = static_cast<std::size_t>(
        rig.triangle_material.empty() ? 0 : rig.triangle_material[static_cast<std::size_t>(f)]);
    for (int k = 0; k < 3; ++k) {
      const auto v = static_cast<std::size_t>(rig.triangles(f, k));
      if (skin_material[m]) t.skin[v] = 1;
      if (group_material[m]) t.rigid[v] = group_material[m];
    }
  }
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

nlohmann::json points_json(const PhotoLandmarks& m) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& p : m.points) a.push_back({p.x(), p.y()});
  return a;
}

// The expressions' weights the fit kept, by name ({} for a neutral face).
nlohmann::json expression_json(const PhotoTemplate& tmpl, const PhotoFit& fit) {
  nlohmann::json out = nlohmann::json::object();
  for (Eigen::Index e = 0; e < fit.expression.size(); ++e)
    out[tmpl.expression_names[static_cast<std::size_t>(e)]] = fit.expression(e);
  return out;
}

nlohmann::json camera_json(const PhotoCamera& c) {
  nlohmann::json R = nlohmann::json::array();
  for (int i = 0; i < 3; ++i) R.push_back({c.R(i, 0), c.R(i, 1), c.R(i, 2)});
  nlohmann::json out = {{"model", c.perspective() ? "perspective" : "scale-orthographic"},
                        {"R", R},
                        {"s", c.s},
                        {"t", {c.t.x(), c.t.y()}}};
  if (c.perspective()) {
    out["kappa"] = c.kappa;
    out["focal_pixels"] = c.focal();
    out["principal_point"] = {c.centre.x(), c.centre.y()};
  }
  return out;
}

}  // namespace

rig::Rig textured_head(const PhotoTemplate& tmpl, const rig::Positions& positions,
                       const render::Image& texture) {
  rig::Rig rig = tmpl.rig;
  rig.shapes.clear();
  rig.positions = positions;
  rig.normals = rig::vertex_normals(rig.positions, rig.triangles);
  rig::Texture tex;
  tex.name = "photo_skin";
  tex.mime_type = "image/jpeg";
  tex.bytes = render::encode_jpeg(texture, 92);
  tex.repeat_s = tex.repeat_t = false;
  rig.textures.push_back(std::move(tex));
  const int index = static_cast<int>(rig.textures.size()) - 1;
  const float tiles = static_cast<float>(texture.width) / static_cast<float>(texture.height);
  std::vector<char> skin_material(rig.materials.size(), 0);
  for (int f = 0; f < rig.triangle_count(); ++f) {
    const auto m = static_cast<std::size_t>(
        rig.triangle_material.empty() ? 0 : rig.triangle_material[static_cast<std::size_t>(f)]);
    bool all = true;
    for (int k = 0; k < 3; ++k)
      all = all && tmpl.skin[static_cast<std::size_t>(rig.triangles(f, k))];
    if (all) skin_material[m] = 1;
  }
  for (std::size_t m = 0; m < rig.materials.size(); ++m) {
    if (!skin_material[m]) continue;
    auto& mat = rig.materials[m];
    mat.base_color = Eigen::Vector4f(1, 1, 1, 1);
    mat.base_color_texture = rig::TextureRef{};
    mat.base_color_texture.texture = index;
    mat.base_color_texture.scale = Eigen::Vector2f(1.0f / tiles, 1.0f);
  }
  return rig;
}

nlohmann::json paint_eyes(rig::Rig& rig, const PhotoTemplate& tmpl, const PhotoFit& fit,
                          const render::Image& front) {
  std::vector<char> shell_material(rig.materials.size());  // an eyeball's outer shell
  for (std::size_t m = 0; m < rig.materials.size(); ++m) {
    const std::string n = lower(rig.materials[m].name);
    shell_material[m] = !has(n, "iris") && (has(n, "sclera") || has(n, "eyeball"));
  }
  const rig::Positions posed = posed_positions(tmpl, fit);  // as the photo shows the head
  const auto at = [&](int v) -> Eigen::Vector3d { return posed.row(v).cast<double>().transpose(); };
  nlohmann::json out = nlohmann::json::array();
  for (int eye = 1; eye <= 2; ++eye) {
    std::vector<int> sclera;  // the shell's triangles (the cornea's bulge included)
    for (int f = 0; f < rig.triangle_count(); ++f) {
      const auto m = static_cast<std::size_t>(
          rig.triangle_material.empty() ? 0 : rig.triangle_material[static_cast<std::size_t>(f)]);
      if (m < shell_material.size() && shell_material[m] &&
          tmpl.rigid[static_cast<std::size_t>(rig.triangles(f, 0))] == eye)
        sclera.push_back(f);
    }
    if (sclera.size() < 8) continue;
    // The eyeball: a sphere fitted to the shell's vertices; it looks along +Z (heads face +Z): its
    // axis runs through the shell's foremost vertex. The iris covers 29 degrees about the axis,
    // the pupil 9 (an adult eye: a 24 mm ball, an 11.7 mm iris, a 4 mm pupil), whatever the
    // template's own iris mesh looks like.
    std::vector<int> shell;
    for (int f : sclera)
      for (int k = 0; k < 3; ++k) shell.push_back(rig.triangles(f, k));
    std::sort(shell.begin(), shell.end());
    shell.erase(std::unique(shell.begin(), shell.end()), shell.end());
    Points points(static_cast<Eigen::Index>(shell.size()), 3);
    int apex = shell.front();
    for (std::size_t k = 0; k < shell.size(); ++k) {
      points.row(static_cast<Eigen::Index>(k)) = at(shell[k]).transpose();
      if (at(shell[k]).z() > at(apex).z()) apex = shell[k];
    }
    const Eigen::Vector3d ball = fit_sphere(points).centre.transpose();
    const Eigen::Vector3d axis = (at(apex) - ball).normalized();
    if (!axis.allFinite()) continue;
    const auto angle = [&](const Eigen::Vector3d& x) {
      return std::acos(std::clamp((x - ball).normalized().dot(axis), -1.0, 1.0));
    };
    const double rim = 29 * M_PI / 180, pupil = 9 * M_PI / 180;
    // The iris's colour where the front photo sees it: its ring's pixels (the pupil and the rim
    // left out), the darkest quarter's (highlights, the sclera and the lids' skin left out).
    std::vector<Eigen::Vector3d> seen;
    if (axis.dot(fit.front.towards()) > 0.5)
      for (int v : shell) {
        const Eigen::Vector3d x = at(v);
        const double a = angle(x);
        if (a < 1.5 * pupil || a > 0.85 * rim) continue;
        const Eigen::Vector2d px = fit.front.project(x);
        const long u = std::lround(px.x()), w = std::lround(px.y());
        if (u < 0 || w < 0 || u >= front.width || w >= front.height) continue;
        Eigen::Vector3d rgb;
        for (int c = 0; c < 3; ++c)
          rgb(c) =
              front.at(static_cast<int>(u), static_cast<int>(w), std::min(c, front.channels - 1));
        seen.push_back(rgb / 255.0);
      }
    Eigen::Vector3d colour(0.35, 0.24, 0.16);  // sRGB: a mid brown where the photo shows none
    const bool from_photo = seen.size() >= 8;
    if (from_photo) {
      std::sort(seen.begin(), seen.end(), [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
        return a.sum() < b.sum();
      });
      colour = seen[seen.size() / 4];
    }
    const std::string side = eye == 1 ? "left" : "right";
    const auto add = [&](const std::string& name, const Eigen::Vector3d& srgb) {
      rig::Material m = rig::Material::solid(
          name, Eigen::Vector4f(rig::srgb_to_linear(static_cast<float>(srgb(0))),
                                rig::srgb_to_linear(static_cast<float>(srgb(1))),
                                rig::srgb_to_linear(static_cast<float>(srgb(2))), 1.0f));
      m.roughness = 0.3f;
      rig.materials.push_back(std::move(m));
      return static_cast<int>(rig.materials.size()) - 1;
    };
    const int iris_material = add("photo_iris_" + side, colour),
              pupil_material = add("photo_pupil_" + side, Eigen::Vector3d::Constant(0.02));
    if (rig.triangle_material.empty())
      rig.triangle_material.assign(static_cast<std::size_t>(rig.triangle_count()), 0);
    int painted = 0;
    for (int f : sclera) {
      const double a = angle(
          (at(rig.triangles(f, 0)) + at(rig.triangles(f, 1)) + at(rig.triangles(f, 2))) / 3.0);
      if (a >= rim) continue;
      rig.triangle_material[static_cast<std::size_t>(f)] =
          a < pupil ? pupil_material : iris_material;
      ++painted;
    }
    out.push_back({{"eye", side},
                   {"iris_srgb", {colour(0), colour(1), colour(2)}},
                   {"from_photo", from_photo},
                   {"cornea_triangles", painted}});
  }
  return out;
}

PhotoOptions load_photo_options() {
  ConfigReader c = ConfigReader::open(config_path("rigbuild/photo.json"));
  PhotoOptions o;
  c.read("predictor", o.predictor)
      .read("template", o.template_path)
      .read("min_face", o.min_face)
      .read("max_side", o.max_side)
      .read("weak_face_score", o.weak_face_score)
      .read("max_roll", o.max_roll)
      .read("roll_step", o.roll_step)
      .read("level_eyes", o.level_eyes)
      .read("max_photo_side", o.max_photo_side)
      .read("box_jitter", o.box_jitter)
      .read("box_steps", o.box_steps)
      .read("iterations", o.iterations)
      .read("landmark_noise", o.landmark_noise)
      .read("estimate_noise", o.estimate_noise)
      .read("estimate_group_noise", o.estimate_group_noise)
      .read("self_calibrate", o.self_calibrate)
      .read("calibration_texture", o.calibration_texture)
      .read("painted_distance", o.painted_distance)
      .read("calibration_light", o.calibration_light)
      .read("calibration_background", o.calibration_background)
      .read("appearance_weight", o.appearance_weight)
      .read("appearance_blur", o.appearance_blur)
      .read("appearance_side", o.appearance_side)
      .read("stereo_weight", o.stereo_weight)
      .read("stereo_blur", o.stereo_blur)
      .read("side_noise", o.side_noise)
      .read("estimate_side_noise", o.estimate_side_noise)
      .read("side_turn", o.side_turn)
      .read("camera", o.camera)
      .read("exif_focal_sd", o.exif_focal_sd)
      .read("exif_distance", o.exif_distance)
      .read("near_landmark_noise", o.near_landmark_noise)
      .read("expressions", o.expressions)
      .read("expression_sd", o.expression_sd)
      .read("side_calibration", o.side_calibration)
      .read("front_outline", o.front_outline)
      .read("side_outline", o.side_outline)
      .read("outline_noise", o.outline_noise)
      .read("outline_window", o.outline_window)
      .read("outline_start", o.outline_start)
      .read("rbf_smoothing", o.rbf_smoothing)
      .read("rbf_radius", o.rbf_radius)
      .read("rbf_after_synthesis", o.rbf_after_synthesis)
      .read("posterior_scale", o.posterior_scale)
      .read("max_prior_precision", o.max_prior_precision)
      .read("texture_size", o.texture_size)
      .read("side_gamma", o.side_gamma)
      .read("mask_background", o.mask_background)
      .read("shapes", o.shapes);
  if (o.min_face < 16) c.fail("min_face", "must be at least 16");
  if (o.max_side < 128) c.fail("max_side", "must be at least 128");
  if (!(o.weak_face_score >= -2 && o.weak_face_score <= 0))
    c.fail("weak_face_score", "must be in [-2, 0]");
  if (!(o.max_roll >= 0 && o.max_roll <= 90)) c.fail("max_roll", "must be in [0, 90]");
  if (!(o.roll_step >= 5 && o.roll_step <= 90)) c.fail("roll_step", "must be in [5, 90]");
  if (!(o.level_eyes >= 0 && o.level_eyes <= 90)) c.fail("level_eyes", "must be in [0, 90]");
  if (o.max_photo_side < 256 || o.max_photo_side > 16384)
    c.fail("max_photo_side", "must be in 256..16384");
  if (!(o.box_jitter >= 0 && o.box_jitter < 0.3)) c.fail("box_jitter", "must be in [0, 0.3)");
  if (o.box_steps < 1 || o.box_steps > 4) c.fail("box_steps", "must be in 1..4");
  if (!(o.appearance_weight >= 0 && o.appearance_weight <= 10))
    c.fail("appearance_weight", "must be in [0, 10]");
  if (!(o.appearance_blur >= 0.005 && o.appearance_blur <= 0.2))
    c.fail("appearance_blur", "must be in [0.005, 0.2]");
  if (!(o.stereo_weight >= 0 && o.stereo_weight <= 10))
    c.fail("stereo_weight", "must be in [0, 10]");
  if (!(o.stereo_blur >= 0.005 && o.stereo_blur <= 0.2))
    c.fail("stereo_blur", "must be in [0.005, 0.2]");
  if (!(o.posterior_scale >= 1 && o.posterior_scale <= 10))
    c.fail("posterior_scale", "must be in [1, 10]");
  if (!(o.max_prior_precision >= 1 && o.max_prior_precision <= 1e6))
    c.fail("max_prior_precision", "must be in [1, 1e6]");
  if (o.iterations < 1 || o.iterations > 100) c.fail("iterations", "must be in 1..100");
  if (o.self_calibrate < 0 || o.self_calibrate > 3) c.fail("self_calibrate", "must be in 0..3");
  if (!(o.painted_distance >= 0)) c.fail("painted_distance", "must be at least 0");
  if (o.calibration_texture != "painted" && o.calibration_texture != "photo")
    c.fail("calibration_texture", "must be \"painted\" or \"photo\"");
  if (o.camera != "auto" && o.camera != "orthographic" && o.camera != "perspective")
    c.fail("camera", "must be \"auto\", \"orthographic\" or \"perspective\"");
  if (!(o.exif_focal_sd > 0 && o.exif_focal_sd <= 1)) c.fail("exif_focal_sd", "must be in (0, 1]");
  if (!(o.exif_distance >= 0)) c.fail("exif_distance", "must be at least 0");
  if (o.expressions.size() > 16) c.fail("expressions", "at most 16 shapes");
  if (!(o.expression_sd > 0 && o.expression_sd <= 10))
    c.fail("expression_sd", "must be in (0, 10]");
  if (!(o.landmark_noise > 0)) c.fail("landmark_noise", "must be positive");
  if (!(o.near_landmark_noise > 0)) c.fail("near_landmark_noise", "must be positive");
  if (!(o.side_noise > 0)) c.fail("side_noise", "must be positive");
  if (!(o.outline_noise > 0)) c.fail("outline_noise", "must be positive");
  if (!(o.outline_window > 0 && o.outline_window < 0.5))
    c.fail("outline_window", "must be in (0, 0.5)");
  if (!(o.outline_start >= 1 && o.outline_start * o.outline_window < 0.5))
    c.fail("outline_start", "must be at least 1, and times outline_window below 0.5");
  if (!(o.rbf_smoothing >= 0)) c.fail("rbf_smoothing", "must be at least 0");
  if (!(o.rbf_radius > 0)) c.fail("rbf_radius", "must be positive");
  if (o.texture_size < 64 || o.texture_size > 4096) c.fail("texture_size", "must be in 64..4096");
  if (!(o.side_gamma > 0)) c.fail("side_gamma", "must be positive");
  c.reject_unknown();
  o.build = load_build_options();
  return o;
}

std::filesystem::path photo_template_path(const PhotoOptions& options, const std::string& given) {
  if (!given.empty()) return given;
  if (!options.template_path.empty()) return options.template_path;
  return shipped_template_path();
}

PhotoTemplate load_photo_template(const std::filesystem::path& path) {
  PhotoTemplate t;
  if (std::filesystem::is_directory(path)) {
    // The ICT FaceKit layout: the neutral, its expressions and identityNNN.obj modes.
    const auto neutral = path / "generic_neutral_mesh.obj";
    if (!std::filesystem::exists(neutral))
      throw Error(path.string() + ": no generic_neutral_mesh.obj (not an ICT FaceKit folder)",
                  ErrorCode::kNotFound);
    t.rig = rig::read_obj_shapes(neutral, path, {"identity*"});
    std::vector<std::filesystem::path> files;
    for (const auto& e : std::filesystem::directory_iterator(path))
      if (e.path().stem().string().rfind("identity", 0) == 0 && e.path().extension() == ".obj")
        files.push_back(e.path());
    std::sort(files.begin(), files.end());
    t.modes.resize(files.size());  // parsed on the cores, as the expressions are
    parallel_for(files.size(), [&](std::size_t i) {
      rig::Positions p = rig::read_obj_positions(files[i]);
      if (p.rows() != t.rig.positions.rows())
        throw Error(files[i].string() + ": " + std::to_string(p.rows()) +
                    " vertices, but the neutral has " + std::to_string(t.rig.positions.rows()));
      t.modes[i] = p - t.rig.positions;
    });
  } else {
    // A glTF template is read once: its rig and, when it is a compact one, the modes in its extras.
    const std::string ext = path.extension().string();
    std::optional<rig::AvatarDocument> doc;
    if (ext == ".glb" || ext == ".gltf" || ext == ".vrm") doc = rig::AvatarDocument::read(path);
    t.rig = doc ? rig::make_view(*doc).rig : rig::load_rig(path);
    std::vector<rig::Blendshape> keep;
    for (auto& s : t.rig.shapes) {
      if (s.name.rfind("identity", 0) == 0)
        t.modes.push_back(s.dense(t.rig.vertex_count()));
      else
        keep.push_back(std::move(s));
    }
    t.rig.shapes = std::move(keep);
    if (t.modes.empty() && doc) t.modes = read_template_identity(*doc);
  }
  if (t.modes.empty())
    throw Error(path.string() +
                ": the template has no identity modes (identity* shapes or mesh.extras.facecast."
                "identity)");
  const auto marks = known_landmarks(t.rig);
  if (!marks) throw Error(path.string() + ": the template's 68 landmark vertices are unknown");
  t.landmarks = *marks;
  for (int v : t.landmarks)
    if (v < 0) throw Error(path.string() + ": the template lacks some of the 68 landmarks");
  classify_vertices(t);
  return t;
}

PhotoTemplate with_photo_expressions(PhotoTemplate tmpl, const PhotoOptions& options) {
  tmpl.expressions.clear();
  tmpl.expression_names.clear();
  for (const std::string& name : options.expressions) {
    // An ICT FaceKit names the sides name_L / name_R where ARKit says nameLeft / nameRight.
    std::string ict = name;
    for (const auto& [side, suffix] :
         {std::pair<std::string_view, std::string_view>{"Left", "_L"}, {"Right", "_R"}})
      if (ict.size() > side.size() && ict.ends_with(side))
        ict = ict.substr(0, ict.size() - side.size()) + std::string(suffix);
    for (const auto& s : tmpl.rig.shapes)
      if (s.name == name || s.name == ict) {
        tmpl.expressions.push_back(s.dense(tmpl.rig.vertex_count()));
        tmpl.expression_names.push_back(s.name);
        break;
      }
  }
  return tmpl;
}

namespace {

PhotoTemplate without_expressions(PhotoTemplate tmpl) {
  tmpl.expressions.clear();
  tmpl.expression_names.clear();
  return tmpl;
}

// The colour behind the head in a photo (sRGB 0..1): per channel, the median of its top row and
// the upper halves of its outer columns (the bottom edge often shows clothes).
Eigen::Vector3f photo_background(const render::Image& photo) {
  std::array<std::vector<double>, 3> v;
  const auto add = [&](int x, int y) {
    for (int k = 0; k < 3; ++k) v[static_cast<std::size_t>(k)].push_back(photo.at(x, y, k));
  };
  for (int x = 0; x < photo.width; ++x) add(x, 0);
  for (int y = 1; y < photo.height / 2; ++y) {
    add(0, y);
    add(photo.width - 1, y);
  }
  return Eigen::Vector3f(static_cast<float>(median(v[0]) / 255),
                         static_cast<float>(median(v[1]) / 255),
                         static_cast<float>(median(v[2]) / 255));
}

// The fitted head, dressed in the photo's texture, photographed as the fitted cameras saw the
// photos: one renderer whose morph targets are the identity modes, so a head the detector
// response asks for (the head moved along a mode) is a weight, not a new upload.
class HeadCamera {
 public:
  // The cameras are `photo`'s (its field of view spans its height); the renders are of its size
  // when `photo_size`, else the renderer's default 640 x 480 (the same vertical field of view: the
  // head smaller or larger by 480 / the photo's height, centred). Behind the head: `background`
  // (sRGB 0..1), else the renderer's.
  HeadCamera(rig::Rig head, const std::vector<rig::Positions>& modes, const render::Image& photo,
             bool photo_size, const std::optional<Eigen::Vector3f>& background)
      : head_(with_modes(std::move(head), modes)),
        base_(head_.positions),
        width_(photo.width),
        height_(photo.height),
        renderer_(head_, options(photo, photo_size, background)) {
    const auto n = static_cast<Eigen::Index>(modes.size());
    Eigen::MatrixXd m(head_.positions.size(), n);
    for (Eigen::Index k = 0; k < n; ++k)
      m.col(k) = Eigen::Map<const Eigen::VectorXf>(modes[static_cast<std::size_t>(k)].data(),
                                                   modes[static_cast<std::size_t>(k)].size())
                     .cast<double>();
    gram_ = (m.transpose() * m).ldlt();
    modes_ = std::move(m);
  }
  const rig::Rig& head() const { return head_; }
  // The head at `positions` (the fitted head moved along its modes) seen by `camera`.
  render::Image shoot(const rig::Positions& positions, const PhotoCamera& camera) {
    const Eigen::VectorXd delta =
        Eigen::Map<const Eigen::VectorXf>(positions.data(), positions.size()).cast<double>() -
        Eigen::Map<const Eigen::VectorXf>(base_.data(), base_.size()).cast<double>();
    const Eigen::VectorXd w = gram_.solve(modes_.transpose() * delta);
    std::vector<float> weights(static_cast<std::size_t>(w.size()));
    for (Eigen::Index k = 0; k < w.size(); ++k)
      weights[static_cast<std::size_t>(k)] = static_cast<float>(w(k));
    renderer_.set_camera(render_camera(camera, head_.positions, width_, height_));
    return renderer_.render(weights);
  }

 private:
  static rig::Rig with_modes(rig::Rig head, const std::vector<rig::Positions>& modes) {
    head.shapes.clear();
    for (std::size_t k = 0; k < modes.size(); ++k)
      head.shapes.push_back(rig::Blendshape::from_dense("identity" + std::to_string(k), modes[k]));
    return head;
  }
  static render::RenderOptions options(const render::Image& photo, bool photo_size,
                                       const std::optional<Eigen::Vector3f>& background) {
    render::RenderOptions ro;
    if (photo_size) {
      ro.width = photo.width;
      ro.height = photo.height;
    }
    if (background) ro.background = *background;
    ro.contexts = 1;
    ro.trilinear = true;
    ro.lod_pixels = 0;
    return ro;
  }
  rig::Rig head_;
  rig::Positions base_;
  int width_, height_;
  render::Renderer renderer_;
  Eigen::MatrixXd modes_;
  Eigen::LDLT<Eigen::MatrixXd> gram_;
};

render::Image crop(const render::Image& image, int x0, int y0, int width, int height) {
  const auto channels = static_cast<std::size_t>(image.channels);
  render::Image out{width, height, image.channels,
                    std::vector<std::uint8_t>(static_cast<std::size_t>(width * height) * channels)};
  const std::size_t row = static_cast<std::size_t>(width) * channels;
  for (int y = 0; y < height; ++y)
    std::copy_n(
        image.pixels.begin() +
            static_cast<std::ptrdiff_t>(
                (static_cast<std::size_t>(y0 + y) * static_cast<std::size_t>(image.width) +
                 static_cast<std::size_t>(x0)) *
                channels),
        row, out.pixels.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(y) * row));
  return out;
}

bool has_detector_response(const PhotoTemplate& t) {
  for (const auto& b : t.bias)
    if (b.squaredNorm() > 0) return true;
  return false;
}

// Analysis by synthesis: the detector's convention and its change per identity mode, measured on
// a head in the photo's colours seen by the photo's fitted front camera (so in the photo's style),
// are taken as the template's response for a second fit. On the template's own landmark vertices
// dlib's points lie about 4 % of the inter-ocular distance away, a constant the first fit would
// otherwise explain with identity (docs/algorithms.md#photo-avatar). The side photo's response is
// not measured: fitted alone, a render of a turned head gives a camera turned by up to 15 degrees
// less, and offsets measured against it pulled the second fit's turn as far (against the known
// side camera: window mixtures 1.11 -> 1.32, turns off by up to 10 degrees). `report` gets the
// texture the head wore (calibration_texture: "painted" or "photo") and the light it was given
// (calibration_light).
PhotoFit self_calibrated_fit(const PhotoTemplate& tmpl, const PhotoAvatar& first,
                             const render::Image& front, const render::Image* side,
                             const PhotoOptions& options, nlohmann::json& report) {
  // The painted template (calibration_texture): a texture baked from the photo through the first
  // fit puts the photo's features where that fit's landmark vertices are, so the detector finds on
  // the render about the points the first fit already explained, and the fit's own error comes
  // back as the "offset" (the template's own photo 0.19 cm off). The template painted with the
  // photo's colours where its own landmark vertices put the features shows how the detector reads
  // the template in the photo's camera and colours, and the model (bias + mode_bias c about the
  // template, c = 0) is then measured where it is used.
  //
  // It is photographed through the perspective camera fitted to the photo (the first fit's, or
  // fitted for the purpose when the evidence kept the orthographic one): the first fit, explaining
  // the detector's offsets with identity, often keeps a selfie's camera orthographic, and the
  // painted renders then show a distant face (development selfies' fitted/template 1.95; 1.01
  // through the perspective camera). A long lens's perspective camera is nearly orthographic.
  PhotoCamera shot_camera = first.fit.front;
  bool painted = options.calibration_texture == "painted";
  if (painted && !first.fit.front.perspective() && first.front.width > 0 &&
      (!side || first.side.width > 0)) {
    PhotoOptions p = options;
    p.camera = "perspective";
    shot_camera = fit_photo_shape(without_expressions(tmpl), first.front,
                                  side ? &first.side : nullptr, p, &front, side)
                      .front;
  }
  // Nearer than painted_distance (a selfie at arm's length) the painted renders' offsets moved the
  // fitted focal length 2x too long (1175 px for 554 on the template's own selfie, 0.28 cm off
  // against 0.10 with the baked texture): there the first fit's head in the baked texture stays,
  // unless the photo's EXIF holds the focal length (held-out selfies' mixtures 1.00 -> 0.66).
  const bool exif_lens = first.fit.exif_focal;
  if (painted && !exif_lens && shot_camera.perspective() &&
      1 / shot_camera.kappa < options.painted_distance)
    painted = false;
  if (!painted) shot_camera = first.fit.front;
  report["calibration_texture"] = painted ? "painted" : "photo";
  // The head photographed wears the photo's expression (a smile moves dlib's points as it moves
  // the mouth): the template, or the first fit's head, posed with the first fit's weights. The
  // first round's first fit leaves the expressions out (avatar_from_photos), so this poses the
  // head from a second round on (self_calibrate 2).
  PhotoFit posed = first.fit;
  if (painted) posed.positions = tmpl.rig.positions;
  const rig::Positions base = posed_positions(tmpl, posed);
  const render::Image texture = painted ? paint_face_texture(tmpl, front, first.front, 512)
                                        : bake_photo_texture(tmpl, first.fit, front, side, options);
  rig::Rig head = textured_head(tmpl, base, texture);
  PhotoFit eyes = first.fit;  // the eyes painted where the rendered head has them
  eyes.positions = base;
  eyes.expression.resize(0);
  paint_eyes(head, tmpl, eyes, front);
  PhotoTemplate calibrated = tmpl;
  calibrated.rig.positions = base;
  // dlib traces the jaw line against what lies behind the face: the renders show the photo's
  // background colour, not the renderer's dark grey (calibration_background; selfies with their
  // lens, a dark face before a light room: held-out mixtures 0.72 -> 0.57, warped heads 0.76 ->
  // 0.71 and none above the template, the template's own selfie 0.139 -> 0.042 cm).
  std::optional<Eigen::Vector3f> background;
  if (options.calibration_background) background = photo_background(front);
  if (painted && options.calibration_light) {
    // The photo's light (a lamp at one side, a light from above) that the renderer's lights do
    // not give the flat painted template: the ratio of the photo to a render of it, as a
    // function of the normal, painted into its colours.
    const render::Image flat =
        HeadCamera(head, tmpl.modes, front, true, background).shoot(base, shot_camera);
    const FaceLight light =
        fit_face_light(calibrated, front, first.fit, first.fit.front, flat, shot_camera);
    if (light.samples > 0) {
      head = textured_head(tmpl, base, paint_face_texture(tmpl, front, first.front, 512, &light));
      paint_eyes(head, tmpl, eyes, front);
    }
    // The ratio facing the camera and turned 45 degrees towards the head's left, right, top and
    // bottom (its own frame).
    nlohmann::json& r = report["calibration_light"];
    r["samples"] = light.samples;
    const double h = std::sqrt(0.5);
    for (const auto& [name, n] : {std::pair{"front", Eigen::Vector3d(0, 0, 1)},
                                  {"left", Eigen::Vector3d(h, 0, h)},
                                  {"right", Eigen::Vector3d(-h, 0, h)},
                                  {"top", Eigen::Vector3d(0, h, h)},
                                  {"bottom", Eigen::Vector3d(0, -h, h)}}) {
      const Eigen::Vector3d v = light(n);
      r[name] = {v(0), v(1), v(2)};
    }
  }
  PhotoOptions quick = options;
  // The painted template's points are found as the photo's were (the whole render, the grid of
  // boxes): the detector's points move with its face box by a pixel or two, and a box found on a
  // crop or a single box lost (studio mixtures 0.53 -> 0.72 with one box on the whole render,
  // 0.93 on the crop). The baked photo's renders keep one box on the crop (the grid did not help
  // there: 1.01 against 1.03).
  // The offsets are measured against a scale-orthographic camera fitted to each render (against a
  // perspective one: studio mixtures 0.69 -> 0.89; against the render's own camera: selfies'
  // turn off by 7 degrees).
  // The grid's 27 boxes (box_steps 1) read the renders as well as the photo's 125 and in less
  // time (studio mixtures 0.49 against 0.53, window 0.76 against 0.84, the template's own studio
  // photo 0.13 against 0.155 cm).
  quick.box_steps = painted ? std::min(options.box_steps, 1) : 0;
  quick.min_face = std::min(options.min_face, 32);  // a head moved along a mode may look smaller
  // The painted template is photographed at the photo's size (its pixels are compared with the
  // photo's for the light, and dlib reads it at the photo's scale: development heads' window
  // mixtures 0.68 -> 0.63, the template's own photo 0.17 -> 0.13 cm, with calibration_light). The
  // first fit's head in the baked photo texture keeps the renderer's 640 x 480: at a portrait
  // selfie's 480 x 640 the template's own selfie came back 0.25 cm off against 0.10.
  HeadCamera camera(std::move(head), tmpl.modes, front, painted, background);
  measure_detector_response(
      calibrated,
      [&](const rig::Positions& p) {
        return std::make_pair(camera.shoot(p, shot_camera), render::Image{});
      },
      quick, 2.0,
      [&](const render::Image& shot, bool) {
        // A lens the photo's EXIF gave that the fit kept (fit_photo_shape): the renders' is the
        // camera they are shot through.
        const double focal = exif_lens ? shot_camera.focal() : 0.0;
        // Read as the photo was: its face found in the view turned by its roll.
        if (painted) {
          PhotoLandmarks found = detect_photo_landmarks(shot, "render", quick, first.front.roll);
          found.focal = focal;
          return found;
        }
        // The face is found within twice the photo's face box around it (a quarter of a
        // portrait's pixels for the face detector).
        const PhotoLandmarks& seen = first.front;
        const double cx = (seen.rect[0] + seen.rect[2]) / 2, cy = (seen.rect[1] + seen.rect[3]) / 2;
        const int half = static_cast<int>(std::lround(seen.rect[2] - seen.rect[0]));
        const int x0 = std::clamp(static_cast<int>(cx) - half, 0, shot.width - 1);
        const int y0 = std::clamp(static_cast<int>(cy) - half, 0, shot.height - 1);
        const render::Image part = crop(shot, x0, y0, std::min(2 * half, shot.width - x0),
                                        std::min(2 * half, shot.height - y0));
        PhotoLandmarks found = detect_photo_landmarks(part, "render", quick, seen.roll);
        for (auto& p : found.points) p += Eigen::Vector2d(x0, y0);
        found.width = shot.width;
        found.height = shot.height;
        found.focal = focal;
        return found;
      });
  calibrated.rig.positions = tmpl.rig.positions;
  PhotoFit fit = fit_photo_shape(calibrated, first.front, side ? &first.side : nullptr, options,
                                 &front, side, &first.fit);
  rig::Positions at = base;  // the head at the fit's identity, as photographed
  for (std::size_t m = 0; m < tmpl.modes.size(); ++m)
    at += static_cast<float>(fit.coefficients(static_cast<Eigen::Index>(m))) * tmpl.modes[m];
  std::optional<IdentityEvidence> evidence;
  const auto join = [&](IdentityEvidence e) {
    e.pull += e.information * fit.coefficients;
    if (evidence) {
      evidence->information += e.information;
      evidence->pull += e.pull;
    } else {
      evidence = std::move(e);
    }
  };
  if (painted && options.appearance_weight > 0) {
    // The photos' pixels (appearance_weight): the painted head at the fit's identity, and moved
    // by +-1 along each mode, photographed through the fit's cameras and blurred at a grid over
    // the face's skin, against each photo. What the picture's change per mode explains of the
    // photo's difference from the first render is evidence on the identity about the fit's; the
    // shape is fitted again with the front's and the side's (appearance_side) together. The
    // renders' background is the photo's own room (AppearanceGrid::set_backdrop): before one
    // colour, a selfie's door and window at the face's outline pulled the photo's move 8-20 % in
    // scale and the evidence was left out on every held-out selfie (with the backdrop: moves of
    // 1-3 %, held-out selfies' mixtures 0.57 -> 0.48). The head is photographed neutral (HeadCamera
    // shows the modes only): a smile's lips are left out with the features, its cheeks are misfit
    // the robust weights take down.
    const auto measure = [&](HeadCamera& cam, const render::Image& photo,
                             const PhotoLandmarks& marks, const PhotoCamera& pc,
                             nlohmann::json& a) -> std::optional<IdentityEvidence> {
      AppearanceGrid grid(marks, options.appearance_blur);
      const double step = 1.0;
      const render::Image shot = cam.shoot(at, pc);
      grid.set_backdrop(photo, shot);
      std::vector<AppearanceShot> reads{grid.read(shot)};
      for (const auto& mode : tmpl.modes)
        for (const float sign : {1.0f, -1.0f})
          reads.push_back(grid.read(cam.shoot(at + sign * static_cast<float>(step) * mode, pc)));
      IdentityEvidence e = appearance_evidence(grid, photo, reads, step, options.appearance_weight);
      if (e.information.rows() != fit.coefficients.size()) return std::nullopt;
      a["samples"] = e.samples;
      a["noise"] = e.noise;
      a["move"] = {e.warp(0), e.warp(1), e.warp(2), e.warp(3)};
      // The photo moved by more than a few percent of the face against renders through its fitted
      // camera: something other than the identity drove the match (astronaut.png's hair and suit
      // pulled the scale 14 %), and the evidence is not used.
      const bool used = e.warp.head<2>().norm() < 0.05 * marks.box && std::abs(e.warp(2)) < 0.05 &&
                        std::abs(e.warp(3)) < 0.05;
      a["used"] = used;
      if (!used) return std::nullopt;
      return e;
    };
    std::optional<HeadCamera> side_camera;
    if (side && fit.side && options.appearance_side) {
      std::optional<Eigen::Vector3f> side_background;
      if (options.calibration_background) side_background = photo_background(*side);
      side_camera.emplace(camera.head(), tmpl.modes, *side, true, side_background);
    }
    if (auto e = measure(camera, front, first.front, fit.front, report["appearance"])) join(*e);
    if (side_camera)
      if (auto e = measure(*side_camera, *side, first.side, *fit.side, report["appearance_side"]))
        join(*e);
  }
  if (side && fit.side && options.stereo_weight > 0) {
    // The two photos against each other through the fitted head (stereo_weight): evidence on
    // its depth that passes through neither the detector nor a painted head. Measured once more
    // about the fit it gave, for a fourth fit, it did not help (development mixtures studio 0.34,
    // window 0.46 against 0.35, 0.43).
    IdentityEvidence e = stereo_evidence(tmpl, at, first.front, front, fit.front, *side, *fit.side,
                                         options.stereo_blur, options.stereo_weight);
    nlohmann::json& a = report["stereo"];
    a["samples"] = e.samples;
    a["noise"] = e.noise;
    a["move"] = {e.warp(0), e.warp(1), e.warp(2), e.warp(3)};
    const double box = first.front.rect[2] - first.front.rect[0];
    const bool used = e.information.rows() == fit.coefficients.size() &&
                      e.warp.head<2>().norm() < 0.05 * box && std::abs(e.warp(2)) < 0.05 &&
                      std::abs(e.warp(3)) < 0.05;
    a["used"] = used;
    if (used) join(std::move(e));
  }
  if (evidence) {
    calibrated.appearance = *evidence;
    fit = fit_photo_shape(calibrated, first.front, side ? &first.side : nullptr, options, &front,
                          side, &fit);
  }
  // With the detector's response modelled, the residuals left are mostly its scatter: moved into
  // the shape they cost more than they carry (rbf_after_synthesis;
  // docs/benchmarks.md#photo-avatar).
  if (!options.rbf_after_synthesis) {
    fit.positions = fit.model_positions;
    fit.moved_rms = 0;
  }
  return fit;
}

// Landmarks read on a copy of `photo` scaled by `scale` (render::scale_down: the copy's pixel i
// covers the photo's [i, i + 1) / scale), in the photo's own pixels.
PhotoLandmarks scaled_landmarks(PhotoLandmarks marks, const render::Image& photo, double scale) {
  const auto back = [&](double x) { return (x + 0.5) / scale - 0.5; };
  for (auto& p : marks.points) p = Eigen::Vector2d(back(p.x()), back(p.y()));
  for (auto& r : marks.rect) r = back(r);
  marks.box /= scale;
  marks.focal /= scale;
  marks.width = photo.width;
  marks.height = photo.height;
  return marks;
}

}  // namespace

PhotoAvatar avatar_from_photos(const PhotoTemplate& given, const render::Image& front_photo,
                               const render::Image* side_photo, const PhotoOptions& options,
                               const ProgressFn& progress) {
  const PhotoTemplate tmpl = with_photo_expressions(given, options);
  const OpenMpWithinBudget omp_threads;  // Eigen's and CHOLMOD's regions, within the budget
  const auto t0 = std::chrono::steady_clock::now();
  PhotoAvatar out;
  // Photos are worked on at most max_photo_side pixels on their longer side, both scaled alike
  // (they share the perspective camera's focal length): the analysis by synthesis photographs
  // the head at the photo's size some twenty times, and its cost grows faster than the pixels
  // (astronaut.png's fit: 2.7 s at 512 pixels, 4.4 s at 2048, 21.6 s at 4096).
  int longest = std::max(front_photo.width, front_photo.height);
  if (side_photo) longest = std::max({longest, side_photo->width, side_photo->height});
  out.photo_scale = std::min(1.0, options.max_photo_side / static_cast<double>(longest));
  const render::Image front_small =
      out.photo_scale < 1 ? render::scale_down(front_photo, out.photo_scale) : render::Image{};
  const render::Image side_small = out.photo_scale < 1 && side_photo
                                       ? render::scale_down(*side_photo, out.photo_scale)
                                       : render::Image{};
  const render::Image& front = out.photo_scale < 1 ? front_small : front_photo;
  const render::Image* side = out.photo_scale < 1 && side_photo ? &side_small : side_photo;
  nlohmann::json timing;
  // Analysis by synthesis renders the head: the GL driver is loaded meanwhile.
  const bool calibrates = !has_detector_response(tmpl) && options.self_calibrate > 0;
  std::future<void> gl;
  if (calibrates) gl = async_within_budget([] { render::open_displays(); });
  // The template's shapes and their gradients, which the expressions' transfer needs and the
  // landmarks and the fit do not, are made on another thread meanwhile (a core is idle while
  // dlib's shape predictor is still being read, and in the fit's serial parts). Abandoned when
  // something throws before the build takes them over: a photo without a face fails at once.
  const bool builds = options.shapes && !tmpl.rig.shapes.empty();
  std::atomic<bool> abandon = false;
  std::future<TemplateShapes> source;
  if (builds)
    source = async_within_budget([&tmpl, &abandon] { return template_shapes(tmpl.rig, &abandon); });
  struct AbandonOnThrow {  // destroyed before `source` waits for the thread
    std::atomic<bool>& flag;
    const std::future<TemplateShapes>& shapes;
    ~AbandonOnThrow() {
      if (shapes.valid()) flag = true;
    }
  } abandon_on_throw{abandon, source};
  report(progress, "landmarks", 0.0);
  out.front = detect_photo_landmarks(front, "front photo", options);
  if (side) {
    out.side = detect_photo_landmarks(*side, "side photo", options);
    out.has_side = true;
  }
  timing["landmarks"] = seconds_since(t0);
  report(progress, "fit", 0.15);
  auto t = std::chrono::steady_clock::now();
  // With analysis by synthesis to follow, the expressions are left to its fit: before the
  // detector's offsets are modelled, they pass for a smile or an open jaw.
  out.fit = fit_photo_shape(calibrates ? without_expressions(tmpl) : tmpl, out.front,
                            side ? &out.side : nullptr, options, &front, side);
  double unused_focal = 0;
  if (out.front.focal > 0 && !out.fit.exif_focal) {
    // A lens the first fit could not use (its perspective camera came out degenerate): not
    // used after it either (fit_photo_shape).
    unused_focal = out.front.focal;
    out.front.focal = out.side.focal = 0;
  }
  std::string calibration_note;
  nlohmann::json calibration = {{"calibration_texture", ""}};
  if (calibrates) {
    try {
      if (gl.valid()) gl.get();
      for (int round = 0; round < options.self_calibrate; ++round)
        out.fit = self_calibrated_fit(tmpl, out, front, side, options, calibration);
      // On development heads of known shape this fit's coefficients were off by 1.56 times their
      // posterior deviations with a side photo (RMS over three photo styles), 1.33 from a front
      // photo alone: with a side photo the evidence is counted as much as that says it is worth
      // (posterior_scale; docs/algorithms.md#photo-avatar). Alone, counted so, the front
      // photo's mixtures came out further off. Then, with a photo or two, the prior's precision
      // by the evidence, at most max_prior_precision: a head near the template, where the
      // evidence is mostly the detector's and the off-span shape's pull, stays nearer it.
      calibrate_posterior(tmpl, out.fit, side ? options.posterior_scale : 1.0,
                          options.max_prior_precision);
    } catch (const Error& e) {
      // A render the detector cannot read (a head moved far along a mode): the fit stays as it was.
      calibration_note = std::string("self-calibration skipped: ") + e.what();
    }
  }
  timing["fit"] = seconds_since(t);
  report(progress, "texture", 0.25);
  // The expressions need only the head's geometry: they are built on another thread while the
  // texture is baked (which changes only materials and textures), then moved onto the textured
  // head. Only the build reports progress from here on.
  std::future<std::vector<rig::Blendshape>> expressions;
  double expression_seconds = 0;
  if (builds) {
    expressions = async_within_budget([&, source = std::move(source)]() mutable {
      const auto start = std::chrono::steady_clock::now();
      rig::Rig geometry = tmpl.rig;
      geometry.shapes.clear();
      geometry.positions = out.fit.positions;
      geometry.normals = rig::vertex_normals(geometry.positions, geometry.triangles);
      const ProgressFn inner = [&](std::string_view stage, double f) {
        report(progress, stage, 0.35 + 0.6 * f);
      };
      auto shapes =
          build_rig(tmpl.rig, std::move(source), geometry, options.build, inner).rig.shapes;
      expression_seconds = seconds_since(start);
      return shapes;
    });
  }
  t = std::chrono::steady_clock::now();
  const render::Image texture = bake_photo_texture(tmpl, out.fit, front, side, options,
                                                   &out.texture_coverage, &out.texture_refused);
  out.rig = textured_head(tmpl, out.fit.positions, texture);
  const nlohmann::json eyes = paint_eyes(out.rig, tmpl, out.fit, front);
  timing["texture"] = seconds_since(t);
  if (builds) out.rig.shapes = expressions.get();
  timing["expressions"] = expression_seconds;
  timing["total"] = seconds_since(t0);
  if (out.photo_scale < 1) {  // the landmarks in the caller's photos' pixels
    out.front = scaled_landmarks(out.front, front_photo, out.photo_scale);
    if (side_photo) out.side = scaled_landmarks(out.side, *side_photo, out.photo_scale);
  }
  nlohmann::json notes = nlohmann::json::array();
  for (const auto* m : {&out.front, &out.side})
    if (!m->note.empty()) notes.push_back(m->note);
  if (!calibration_note.empty()) notes.push_back(calibration_note);
  out.report = {{"front",
                 {{"landmarks", points_json(out.front)},
                  {"faces", out.front.faces},
                  {"roll", out.front.roll},
                  {"exif_focal_pixels",
                   out.front.focal > 0 ? out.front.focal : unused_focal / out.photo_scale},
                  {"exif_focal_used", out.fit.exif_focal},
                  {"camera", camera_json(out.fit.front)},
                  {"rms_pixels", out.fit.front_rms}}},
                {"coefficients",
                 std::vector<double>(out.fit.coefficients.data(),
                                     out.fit.coefficients.data() + out.fit.coefficients.size())},
                {"coefficient_sd", std::vector<double>(out.fit.coefficient_sd.data(),
                                                       out.fit.coefficient_sd.data() +
                                                           out.fit.coefficient_sd.size())},
                {"prior_precision", out.fit.prior_precision},
                {"landmark_noise", out.fit.noise},
                {"landmark_group_noise",
                 {{"jaw", out.fit.group_noise[0]},
                  {"brows", out.fit.group_noise[1]},
                  {"nose", out.fit.group_noise[2]},
                  {"eyes", out.fit.group_noise[3]},
                  {"mouth", out.fit.group_noise[4]}}},
                {"expression", expression_json(tmpl, out.fit)},
                {"expression_evidence", out.fit.expression_evidence},
                {"camera_model", out.fit.camera_model},
                {"camera_evidence", out.fit.camera_evidence},
                {"rbf_rms_move", out.fit.moved_rms},
                {"eyes", eyes},
                {"texture",
                 {{"width", texture.width},
                  {"height", texture.height},
                  {"coverage", out.texture_coverage},
                  {"background_refused", out.texture_refused}}},
                {"shapes", out.rig.shapes.size()},
                {"notes", notes},
                {"photo_scale", out.photo_scale},
                {"seconds", timing}};
  out.report.update(calibration);
  if (out.fit.side)
    out.report["side"] = {{"landmarks", points_json(out.side)},
                          {"faces", out.side.faces},
                          {"roll", out.side.roll},
                          {"used", side_points(out.side)},
                          {"camera", camera_json(*out.fit.side)},
                          {"rms_pixels", out.fit.side_rms},
                          {"noise", out.fit.side_noise}};
  report(progress, "done", 1.0);
  return out;
}

}  // namespace facecast::rigbuild
