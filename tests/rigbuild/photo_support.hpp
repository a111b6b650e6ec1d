#pragma once
// Photos with a known truth for the photo avatar's tests and benchmark (header-only): an ICT
// head given a skin-like texture (skin tone with a soft mottle, dark brows along the template's
// brow landmarks, red lips inside its lip landmarks) rendered from the front and turned.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>

#include "facecast/render/renderer.hpp"
#include "facecast/rigbuild/photo_avatar.hpp"
#include "photo_detail.hpp"

namespace facecast::test {

// Distance from p to the segment a-b.
inline double segment_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                               const Eigen::Vector3d& b) {
  const Eigen::Vector3d d = b - a;
  const double t = std::clamp((p - a).dot(d) / std::max(1e-12, d.squaredNorm()), 0.0, 1.0);
  return (a + t * d - p).norm();
}

/// The skin texture of the template (2 N x N over its two UV tiles), painted by position on the
/// template's neutral.
inline render::Image skin_texture(const rigbuild::PhotoTemplate& t, int n = 512) {
  render::Image img{2 * n, n, 3,
                    std::vector<std::uint8_t>(static_cast<std::size_t>(2 * n) * n * 3)};
  const auto lm = [&](int k) {
    return Eigen::Vector3d(
        t.rig.positions.row(t.landmarks[static_cast<std::size_t>(k)]).cast<double>().transpose());
  };
  const double iod = (lm(36) - lm(45)).norm();
  const auto near_chain = [&](const Eigen::Vector3d& p, int from, int to, bool closed) {
    double d = 1e9;
    for (int k = from; k < to; ++k) d = std::min(d, segment_distance(p, lm(k), lm(k + 1)));
    if (closed) d = std::min(d, segment_distance(p, lm(to), lm(from)));
    return d;
  };
  for (std::size_t i = 0; i < img.pixels.size(); i += 3) {  // background of unpainted texels
    img.pixels[i] = 200, img.pixels[i + 1] = 150, img.pixels[i + 2] = 125;
  }
  rigbuild::for_each_skin_texel(
      t, t.rig.positions, 2 * n, n, 2,
      [&](std::size_t i, const Eigen::Vector3d& p, const Eigen::Vector3d&) {
        const double mottle = 0.06 * std::sin(p.x() * 1.7) * std::sin(p.y() * 2.3 + p.z());
        Eigen::Vector3d c = Eigen::Vector3d(205, 155, 128) * (1 + mottle);
        const double brow = std::min(near_chain(p, 17, 21, false), near_chain(p, 22, 26, false));
        if (brow < 0.05 * iod && p.z() > lm(27).z() - 0.5 * iod) c = {80, 55, 42};
        // Lips: the band between the outer and inner lip contours.
        const double lip = near_chain(p, 48, 59, true);
        const Eigen::Vector3d mouth = 0.5 * (lm(48) + lm(54));
        if (lip < 0.05 * iod || ((p - mouth).norm() < (lm(54) - mouth).norm() &&
                                 std::abs(p.y() - mouth.y()) < 0.12 * iod))
          c = {175, 85, 85};
        for (int k = 0; k < 3; ++k)
          img.pixels[i * 3 + static_cast<std::size_t>(k)] =
              static_cast<std::uint8_t>(std::clamp(c(k), 0.0, 255.0));
      });
  return img;
}

/// scikit-image's astronaut.png (public domain): from an installed python3-skimage, or the copy
/// scripts/install-deps.sh unpacks; "" when neither exists.
inline std::filesystem::path astronaut_path() {
  for (const char* p :
       {"/usr/lib/python3/dist-packages/skimage/data/astronaut.png",
        "/opt/facecast-testdata/python3-skimage/usr/lib/python3/dist-packages/skimage/data/"
        "astronaut.png"})
    if (std::filesystem::exists(p)) return p;
  return {};
}

struct PhotoShoot {
  render::Image front, side;
};

/// The template at `positions`, textured, rendered 512 x 512 from the front and turned by `yaw`
/// degrees (the subject's right towards the camera), on the renderer's background or `background`
/// (sRGB 0..1).
inline PhotoShoot photograph(const rigbuild::PhotoTemplate& t, const rig::Positions& positions,
                             double yaw, int size = 512,
                             const std::optional<Eigen::Vector3f>& background = {}) {
  static const render::Image texture = skin_texture(t);
  const rig::Rig rig = rigbuild::textured_head(t, positions, texture);
  render::RenderOptions ro;
  if (background) ro.background = *background;
  ro.width = ro.height = size;
  ro.fov_y_deg = 3;  // a long lens: the fit's camera is scale-orthographic
  ro.contexts = 1;
  ro.trilinear = true;  // photo-like (the figures were tuned on these renders)
  ro.lod_pixels = 0;    // the truth's own mesh
  render::Renderer r(rig, ro);
  PhotoShoot out;
  const std::vector<float> w(rig.shapes.size(), 0.0f);
  out.front = r.render(w);
  render::Camera cam = r.camera();
  const Eigen::AngleAxisf turn(static_cast<float>(-yaw * M_PI / 180.0), Eigen::Vector3f::UnitY());
  cam.eye = cam.target + turn * (cam.eye - cam.target);
  r.set_camera(cam);
  out.side = r.render(w);
  return out;
}

/// `rig` rendered as the photo's camera saw it (the photo's size), with the given weights.
inline render::Image render_as_photo(const rig::Rig& rig, const rigbuild::OrthoCamera& camera,
                                     const render::Image& photo,
                                     const std::vector<std::pair<std::string, float>>& named = {}) {
  render::RenderOptions ro;
  ro.width = photo.width;
  ro.height = photo.height;
  ro.contexts = 1;
  ro.trilinear = true;
  ro.lod_pixels = 0;  // measured: the mesh itself
  render::Renderer r(rig, ro);
  r.set_camera(rigbuild::render_camera(camera, rig.positions, photo.width, photo.height));
  return r.render(render::weights_for(rig, named));
}

/// Mean distance between the photo's landmarks and those dlib finds on the result rendered with
/// the estimated camera, in the photo's inter-ocular distances.
inline double reprojection_error(const rigbuild::PhotoAvatar& a, const render::Image& photo,
                                 const rigbuild::PhotoOptions& opt) {
  const render::Image seen = render_as_photo(a.rig, a.fit.front, photo);
  const rigbuild::PhotoLandmarks got = rigbuild::detect_photo_landmarks(seen, "render", opt);
  double sum = 0;
  for (std::size_t k = 0; k < got.points.size(); ++k)
    sum += (got.points[k] - a.front.points[k]).norm();
  return sum / static_cast<double>(got.points.size()) /
         (a.front.points[36] - a.front.points[45]).norm();
}

}  // namespace facecast::test
