#pragma once
// Photos with a known truth for the photo avatar's tests and benchmark (header-only): an ICT
// head given a skin-like texture (skin tone with a soft mottle, dark brows along the template's
// brow landmarks, red lips inside its lip landmarks) rendered from the front and turned.
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <optional>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "facecast/render/image.hpp"
#include "facecast/render/renderer.hpp"
#include "facecast/rigbuild/geometry.hpp"
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

/// How a test photo is taken (a photo style): the skin's colours, a light baked into the skin
/// (fixed to the head, as a lamp in the room: the photos turn the camera, not the head), the
/// background, the lens and the camera's distance, the photo's size. The default is the style the
/// photo fit's options were tuned on: light skin, the renderer's own lights only, its dark
/// blue-grey background, a 3-degree field of view (a long lens: nearly orthographic), 512 x 512.
struct PhotoStyle {
  std::string name = "studio";
  Eigen::Vector3d skin{205, 155, 128}, brow{80, 55, 42}, lips{175, 85, 85};  // sRGB 0..255
  double mottle = 0.06;  // the skin's soft variation (a fraction of its colour)
  // The baked light: the direction towards it (the head's frame: +X its left, +Y up, +Z its
  // front), and the share of the light that comes from everywhere (1: no baked light).
  Eigen::Vector3d light{0, 0, 1};
  double ambient = 1;
  Eigen::Vector3d light_tint{1, 1, 1};        // the baked light's colour
  std::optional<Eigen::Vector3f> background;  // sRGB 0..1 (none: the renderer's)
  std::string background_image;               // an image file behind the head, or ""
  float fov_y_deg = 3;                        // the lens: vertical field of view
  double distance = 0;  // the camera's distance from the face's centre (model units, cm); 0: framed
  int width = 512, height = 512;
  // The skin's unpainted texels along its UV seams take their painted neighbours' colours (off:
  // they keep a fixed light skin colour, as in the renders the options were tuned on).
  bool fill_seams = false;
  bool irises = false;  // the eyes get brown irises and pupils (off: the template's white eyes)
};

/// The skin texture of the template (2 N x N over its two UV tiles), painted by position on the
/// template's neutral in `style`'s colours and baked light.
inline render::Image skin_texture(const rigbuild::PhotoTemplate& t, int n = 512,
                                  const PhotoStyle& style = {}) {
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
  const Eigen::Vector3d towards = style.light.normalized();
  std::vector<char> painted(img.pixels.size() / 3, 0);
  rigbuild::for_each_skin_texel(
      t, t.rig.positions, 2 * n, n, 2,
      [&](std::size_t i, const Eigen::Vector3d& p, const Eigen::Vector3d& normal) {
        painted[i] = 1;
        const double mottle = style.mottle * std::sin(p.x() * 1.7) * std::sin(p.y() * 2.3 + p.z());
        Eigen::Vector3d c = style.skin * (1 + mottle);
        const double brow = std::min(near_chain(p, 17, 21, false), near_chain(p, 22, 26, false));
        if (brow < 0.05 * iod && p.z() > lm(27).z() - 0.5 * iod) c = style.brow;
        // Lips: the band between the outer and inner lip contours.
        const double lip = near_chain(p, 48, 59, true);
        const Eigen::Vector3d mouth = 0.5 * (lm(48) + lm(54));
        if (lip < 0.05 * iod || ((p - mouth).norm() < (lm(54) - mouth).norm() &&
                                 std::abs(p.y() - mouth.y()) < 0.12 * iod))
          c = style.lips;
        if (style.ambient < 1) {  // a lamp: ambient + diffuse (Lambert), in its tint
          const double lit = (1 - style.ambient) * 2 * std::max(0.0, normal.dot(towards));
          c = c.cwiseProduct(style.ambient * Eigen::Vector3d::Ones() + lit * style.light_tint);
        }
        for (int k = 0; k < 3; ++k)
          img.pixels[i * 3 + static_cast<std::size_t>(k)] =
              static_cast<std::uint8_t>(std::clamp(c(k), 0.0, 255.0));
      });
  // Seams: unpainted texels take the mean of their painted 4-neighbours, ring by ring.
  for (int pass = 0; style.fill_seams && pass < 8; ++pass) {
    std::vector<char> next = painted;
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < 2 * n; ++x) {
        const auto i = static_cast<std::size_t>(y) * static_cast<std::size_t>(2 * n) +
                       static_cast<std::size_t>(x);
        if (painted[i]) continue;
        int sum[3] = {0, 0, 0}, count = 0;
        for (const auto& [dx, dy] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
          const int u = x + dx, v = y + dy;
          if (u < 0 || v < 0 || u >= 2 * n || v >= n) continue;
          const auto j = static_cast<std::size_t>(v) * static_cast<std::size_t>(2 * n) +
                         static_cast<std::size_t>(u);
          if (!painted[j]) continue;
          for (int k = 0; k < 3; ++k) sum[k] += img.pixels[j * 3 + static_cast<std::size_t>(k)];
          ++count;
        }
        if (count == 0) continue;
        for (int k = 0; k < 3; ++k)
          img.pixels[i * 3 + static_cast<std::size_t>(k)] =
              static_cast<std::uint8_t>(sum[k] / count);
        next[i] = 1;
      }
    painted = std::move(next);
  }
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

/// A photo turned by `degrees` (clockwise as shown: a head tilted to its left shoulder) about its
/// centre onto a canvas that holds it whole, the corners grey, bilinear; `to_turned` maps a point
/// of the photo into it.
struct TurnedPhoto {
  render::Image image;
  Eigen::Vector2d centre, turned_centre;
  double angle = 0;  // radians
  Eigen::Vector2d to_turned(const Eigen::Vector2d& p) const {
    return Eigen::Rotation2Dd(angle) * (p - centre) + turned_centre;
  }
};

inline TurnedPhoto turned_photo(const render::Image& photo, double degrees) {
  TurnedPhoto t;
  t.angle = degrees * 3.14159265358979323846 / 180;
  const double c = std::abs(std::cos(t.angle)), s = std::abs(std::sin(t.angle));
  const int w = static_cast<int>(std::ceil(photo.width * c + photo.height * s));
  const int h = static_cast<int>(std::ceil(photo.width * s + photo.height * c));
  t.centre = Eigen::Vector2d(photo.width / 2.0, photo.height / 2.0);
  t.turned_centre = Eigen::Vector2d(w / 2.0, h / 2.0);
  t.image = {w, h, 3, std::vector<std::uint8_t>(static_cast<std::size_t>(w) * h * 3, 128)};
  const Eigen::Rotation2Dd back(-t.angle);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const Eigen::Vector2d p = back * (Eigen::Vector2d(x, y) - t.turned_centre) + t.centre;
      const int x0 = static_cast<int>(std::floor(p.x())), y0 = static_cast<int>(std::floor(p.y()));
      if (x0 < 0 || y0 < 0 || x0 + 1 >= photo.width || y0 + 1 >= photo.height) continue;
      const double ax = p.x() - x0, ay = p.y() - y0;
      for (int k = 0; k < 3; ++k) {
        const double v =
            (1 - ay) * ((1 - ax) * photo.at(x0, y0, k) + ax * photo.at(x0 + 1, y0, k)) +
            ay * ((1 - ax) * photo.at(x0, y0 + 1, k) + ax * photo.at(x0 + 1, y0 + 1, k));
        t.image.pixels[(static_cast<std::size_t>(y) * w + x) * 3 + static_cast<std::size_t>(k)] =
            static_cast<std::uint8_t>(std::lround(v));
      }
    }
  return t;
}

struct PhotoShoot {
  render::Image front, side;
  render::Camera front_camera, side_camera;  // the renderer's, as shot
};

/// The photo fit's camera (a perspective PhotoCamera, the principal point at the photo's centre)
/// that projects as the renderer's `camera` does onto a width x height photo.
inline rigbuild::PhotoCamera photo_camera(const render::Camera& camera, int width, int height) {
  const Eigen::Vector3d eye = camera.eye.cast<double>();
  const Eigen::Vector3d ahead = (camera.target.cast<double>() - eye).normalized();
  const Eigen::Vector3d right = ahead.cross(camera.up.cast<double>()).normalized();
  const Eigen::Vector3d up = right.cross(ahead);
  rigbuild::PhotoCamera out;
  out.R.row(0) = right.transpose();
  out.R.row(1) = up.transpose();
  out.R.row(2) = -ahead.transpose();
  const double focal = 0.5 * height / std::tan(0.5 * camera.fov_y_deg * M_PI / 180.0);
  out.kappa = 1 / -ahead.dot(eye);  // the eye at depth 1 / kappa
  out.s = out.kappa * focal;
  out.centre = {0.5 * (width - 1), 0.5 * (height - 1)};
  out.t = {out.centre.x() - out.s * right.dot(eye), out.centre.y() + out.s * up.dot(eye)};
  return out;
}

/// The template at `positions`, textured (`texture`: skin_texture's in the style), photographed in
/// `style` from the front and turned by `yaw` degrees (the subject's right towards the camera):
/// the camera orbits the face's centre.
inline PhotoShoot photograph(const rigbuild::PhotoTemplate& t, const rig::Positions& positions,
                             double yaw, const PhotoStyle& style, const render::Image& texture) {
  rig::Rig rig = rigbuild::textured_head(t, positions, texture);
  if (style.irises) {  // the photo fit's eye painting, its iris in its default brown
    rigbuild::PhotoFit head;
    head.positions = positions;
    rigbuild::paint_eyes(rig, t, head, render::Image{1, 1, 3, {0, 0, 0}});
  }
  render::RenderOptions ro;
  if (style.background) ro.background = *style.background;
  ro.background_image = style.background_image;
  ro.width = style.width;
  ro.height = style.height;
  ro.fov_y_deg = style.fov_y_deg;
  ro.contexts = 1;
  ro.trilinear = true;  // photo-like (the figures were tuned on these renders)
  ro.lod_pixels = 0;    // the truth's own mesh
  render::Renderer r(rig, ro);
  render::Camera cam = r.camera();
  if (style.distance > 0) {  // e.g. a selfie at arm's length
    cam.eye = cam.target + (cam.eye - cam.target).normalized() * static_cast<float>(style.distance);
    cam.near_plane = static_cast<float>(0.2 * style.distance);
    cam.far_plane = static_cast<float>(3 * style.distance);
    r.set_camera(cam);
  }
  PhotoShoot out;
  const std::vector<float> w(rig.shapes.size(), 0.0f);
  out.front = r.render(w);
  out.front_camera = cam;
  const Eigen::AngleAxisf turn(static_cast<float>(-yaw * M_PI / 180.0), Eigen::Vector3f::UnitY());
  cam.eye = cam.target + turn * (cam.eye - cam.target);
  r.set_camera(cam);
  out.side = r.render(w);
  out.side_camera = cam;
  return out;
}

/// The template at `positions`, textured, rendered 512 x 512 from the front and turned by `yaw`
/// degrees (the subject's right towards the camera), on the renderer's background or `background`
/// (sRGB 0..1): the default PhotoStyle.
inline PhotoShoot photograph(const rigbuild::PhotoTemplate& t, const rig::Positions& positions,
                             double yaw, int size = 512,
                             const std::optional<Eigen::Vector3f>& background = {}) {
  static const render::Image texture = skin_texture(t);
  PhotoStyle style;
  style.width = style.height = size;
  style.background = background;
  return photograph(t, positions, yaw, style, texture);
}

/// A room behind the head, written to `path` (PNG): a wall in two tones, a window's bright
/// frame, a dark door, a shelf: edges and colours of a background that is not one colour.
inline void write_room_background(const std::filesystem::path& path, int width, int height) {
  render::Image img{width, height, 3,
                    std::vector<std::uint8_t>(static_cast<std::size_t>(width) * height * 3)};
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const double u = static_cast<double>(x) / width, v = static_cast<double>(y) / height;
      Eigen::Vector3d c = v < 0.7 ? Eigen::Vector3d(196, 186, 160) : Eigen::Vector3d(120, 92, 70);
      if (u > 0.62 && u < 0.95 && v > 0.08 && v < 0.5) c = {235, 240, 248};  // the window
      if ((u > 0.6 && u < 0.62) || (u > 0.95 && u < 0.97)) c = {250, 250, 250};
      if (u < 0.2 && v > 0.15) c = {70, 52, 45};                                // the door
      if (u > 0.25 && u < 0.55 && std::abs(v - 0.35) < 0.01) c = {90, 70, 50};  // the shelf
      c *= 1 + 0.04 * std::sin(0.11 * x) * std::sin(0.07 * y);
      for (int k = 0; k < 3; ++k)
        img.pixels[(static_cast<std::size_t>(y) * width + x) * 3 + static_cast<std::size_t>(k)] =
            static_cast<std::uint8_t>(std::clamp(c(k), 0.0, 255.0));
    }
  render::write_image(path, img);
}

/// The benchmark's and the tests' photo styles, each with its side photo's turn (degrees):
/// studio (the tuning style), window (side photo 35 degrees; darker skin, a warm lamp at the
/// subject's left baked in, a light background, a 12-degree lens), selfie (dark skin, a light from
/// above, a room behind, a phone's 60-degree lens at 35 cm, 480 x 640, side photo 30 degrees).
/// `room`: where the selfie's background image is written (write_room_background).
inline std::vector<std::pair<PhotoStyle, double>> photo_styles(const std::filesystem::path& room) {
  std::vector<std::pair<PhotoStyle, double>> out;
  out.emplace_back(PhotoStyle{}, 40.0);
  PhotoStyle window;
  window.name = "window";
  window.skin = {150, 100, 75};
  window.brow = {55, 38, 30};
  window.lips = {130, 70, 65};
  window.light = {0.7, 0.35, 0.6};
  window.ambient = 0.4;
  window.light_tint = {1.0, 0.92, 0.8};
  window.background = Eigen::Vector3f(0.78f, 0.74f, 0.68f);
  window.fov_y_deg = 12;
  window.fill_seams = window.irises = true;
  out.emplace_back(window, 35.0);
  PhotoStyle selfie;
  selfie.name = "selfie";
  selfie.skin = {110, 72, 52};
  selfie.brow = {40, 28, 22};
  selfie.lips = {105, 55, 50};
  selfie.light = {0, 0.8, 0.6};
  selfie.ambient = 0.55;
  selfie.light_tint = {0.95, 0.97, 1.0};
  selfie.fov_y_deg = 60;
  selfie.distance = 35;
  selfie.fill_seams = selfie.irises = true;
  selfie.width = 480;
  selfie.height = 640;
  if (!std::filesystem::exists(room)) write_room_background(room, 480, 640);
  selfie.background_image = room.string();
  out.emplace_back(selfie, 30.0);
  return out;
}

/// Styles the fixed-table route measures the detector's response in (`bench_photo_styles
/// --response pale,lamp,phone,deep`), none of them a benchmark style: skin tones from pale to very
/// dark, lamps from several sides, plain and room backgrounds, lenses from 5 to 50 degrees (framed,
/// or 45-70 cm from the face).
inline std::vector<std::pair<PhotoStyle, double>> training_photo_styles(
    const std::filesystem::path& room) {
  std::vector<std::pair<PhotoStyle, double>> out;
  PhotoStyle pale;
  pale.name = "pale";
  pale.skin = {228, 185, 165};
  pale.brow = {110, 80, 60};
  pale.lips = {190, 105, 105};
  pale.light = {-0.3, 0.4, 0.85};
  pale.ambient = 0.7;
  pale.background = Eigen::Vector3f(0.45f, 0.47f, 0.5f);
  pale.fov_y_deg = 5;
  out.emplace_back(pale, 40.0);
  PhotoStyle lamp;
  lamp.name = "lamp";
  lamp.skin = {135, 92, 68};
  lamp.brow = {45, 32, 26};
  lamp.lips = {120, 62, 58};
  lamp.light = {-0.7, 0.2, 0.6};
  lamp.ambient = 0.45;
  lamp.light_tint = {1.0, 0.9, 0.75};
  lamp.background = Eigen::Vector3f(0.15f, 0.15f, 0.18f);
  lamp.fov_y_deg = 20;
  lamp.fill_seams = lamp.irises = true;
  out.emplace_back(lamp, 35.0);
  PhotoStyle phone;
  phone.name = "phone";
  phone.skin = {175, 128, 96};
  phone.brow = {60, 42, 32};
  phone.lips = {150, 80, 75};
  phone.light = {0.3, 0.9, 0.4};
  phone.ambient = 0.5;
  phone.fov_y_deg = 50;
  phone.distance = 45;
  phone.fill_seams = phone.irises = true;
  phone.width = 480;
  phone.height = 640;
  if (!std::filesystem::exists(room)) write_room_background(room, 480, 640);
  phone.background_image = room.string();
  out.emplace_back(phone, 30.0);
  PhotoStyle deep;
  deep.name = "deep";
  deep.skin = {88, 60, 44};
  deep.brow = {30, 22, 18};
  deep.lips = {85, 48, 44};
  deep.light = {0.2, 0.3, 0.9};
  deep.ambient = 0.6;
  deep.background = Eigen::Vector3f(0.86f, 0.86f, 0.9f);
  deep.fov_y_deg = 30;
  deep.distance = 70;
  deep.fill_seams = deep.irises = true;
  out.emplace_back(deep, 35.0);
  return out;
}

/// The focal length of a style's camera, pixels.
inline double focal_pixels(const PhotoStyle& style) {
  return 0.5 * style.height / std::tan(0.5 * style.fov_y_deg * M_PI / 180.0);
}

/// ... as EXIF's FocalLengthIn35mmFilm has it: on a 36 x 24 mm frame with the photo's angle of view
/// across its diagonal, mm.
inline double focal_35mm(const PhotoStyle& style) {
  return focal_pixels(style) * std::hypot(36.0, 24.0) / std::hypot(style.width, style.height);
}

/// The identity coefficients of identity_mixture's head: drawn from N(0, sigma^2) (seeded).
inline Eigen::VectorXd identity_coefficients(const rigbuild::PhotoTemplate& t, unsigned seed,
                                             double sigma = 1.0) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, sigma);
  Eigen::VectorXd c(static_cast<Eigen::Index>(t.modes.size()));
  for (Eigen::Index k = 0; k < c.size(); ++k) c(k) = n(rng);
  return c;
}

/// A head of known shape: the template moved by its identity modes with coefficients drawn from
/// N(0, sigma^2) (seeded).
inline rig::Positions identity_mixture(const rigbuild::PhotoTemplate& t, unsigned seed,
                                       double sigma = 1.0) {
  const Eigen::VectorXd c = identity_coefficients(t, seed, sigma);
  rig::Positions p = t.rig.positions;
  for (std::size_t k = 0; k < t.modes.size(); ++k)
    p += static_cast<float>(c(static_cast<Eigen::Index>(k))) * t.modes[k];
  return p;
}

/// A head no identity mode spans: identity_mixture's plus a smooth warp, three Gaussian bumps
/// (0.6 inter-ocular distances wide) at random places on the face moving it in random directions,
/// with the part the modes span removed (least squares over all vertices) and scaled to `rms`
/// (model units) over the face skin.
inline rig::Positions warped_head(const rigbuild::PhotoTemplate& t, unsigned seed,
                                  double rms = 0.35, double sigma = 1.0) {
  const rig::Positions base = identity_mixture(t, seed, sigma);
  std::mt19937 rng(seed * 7919u + 17u);
  std::uniform_int_distribution<int> pick(0, 67);
  std::normal_distribution<double> n(0.0, 1.0);
  const auto& X = t.rig.positions;
  const auto lm = [&](int k) -> Eigen::Vector3d {
    return X.row(t.landmarks[static_cast<std::size_t>(k)]).cast<double>().transpose();
  };
  const double iod = (lm(36) - lm(45)).norm(), width = 0.6 * iod;
  Eigen::MatrixXd warp = Eigen::MatrixXd::Zero(X.rows(), 3);
  for (int b = 0; b < 3; ++b) {
    const Eigen::Vector3d centre = lm(pick(rng));
    const Eigen::Vector3d dir = Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
    for (Eigen::Index v = 0; v < X.rows(); ++v) {
      const double d2 = (X.row(v).cast<double>().transpose() - centre).squaredNorm();
      warp.row(v) += std::exp(-0.5 * d2 / (width * width)) * dir.transpose();
    }
  }
  // Off the modes' span.
  const auto K = static_cast<Eigen::Index>(t.modes.size());
  Eigen::MatrixXd M(X.size(), K);
  for (Eigen::Index m = 0; m < K; ++m)
    for (Eigen::Index v = 0; v < X.rows(); ++v)
      for (int c = 0; c < 3; ++c) M(3 * v + c, m) = t.modes[static_cast<std::size_t>(m)](v, c);
  Eigen::VectorXd w(X.size());
  for (Eigen::Index v = 0; v < X.rows(); ++v)
    for (int c = 0; c < 3; ++c) w(3 * v + c) = warp(v, c);
  w -= M * M.colPivHouseholderQr().solve(w);
  double sum = 0;
  int count = 0;
  for (Eigen::Index v = 0; v < X.rows(); ++v)
    if (t.skin[static_cast<std::size_t>(v)] && t.rig.uvs(v, 0) < 1.0f) {
      sum += w.segment<3>(3 * v).squaredNorm();
      ++count;
    }
  w *= rms / std::sqrt(sum / std::max(1, count));
  rig::Positions out = base;
  for (Eigen::Index v = 0; v < X.rows(); ++v)
    for (int c = 0; c < 3; ++c) out(v, c) += static_cast<float>(w(3 * v + c));
  return out;
}

/// `photo` as a camera softens and stores it: a Gaussian blur of `sigma` pixels (0: none), then
/// JPEG at `quality` (0: not encoded), decoded as a reader would.
inline render::Image as_camera_stores(render::Image photo, double sigma, int quality) {
  if (sigma > 0) {
    const int r = static_cast<int>(std::ceil(3 * sigma));
    std::vector<double> k(static_cast<std::size_t>(2 * r + 1));
    double sum = 0;
    for (int i = -r; i <= r; ++i)
      sum += k[static_cast<std::size_t>(i + r)] = std::exp(-0.5 * i * i / (sigma * sigma));
    for (double& x : k) x /= sum;
    const int w = photo.width, h = photo.height, c = photo.channels;
    for (const bool across : {true, false}) {
      std::vector<std::uint8_t> out(photo.pixels.size());
      std::size_t at = 0;  // row by row, pixel by pixel, channel by channel: the pixels' order
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          for (int ch = 0; ch < c; ++ch) {
            double v = 0;
            for (int i = -r; i <= r; ++i) {
              const int u = std::clamp(across ? x + i : x, 0, w - 1);
              const int t = std::clamp(across ? y : y + i, 0, h - 1);
              v += k[static_cast<std::size_t>(i + r)] * photo.at(u, t, ch);
            }
            out[at++] = static_cast<std::uint8_t>(std::clamp(std::lround(v), 0L, 255L));
          }
      photo.pixels = std::move(out);
    }
  }
  if (quality > 0) photo = render::decode_image(render::encode_jpeg(photo, quality), "photo");
  return photo;
}

/// The template's own photo is taken three times, the head moved by these (model units: 0.03 cm,
/// about half a pixel in a selfie) across and up: a fit's error on one shot moves by up to a
/// tenth of a centimetre with such a move (0.18-0.26 cm on one selfie), so figures take the
/// median of the three.
inline std::array<Eigen::RowVector3f, 3> own_photo_shifts() {
  return {Eigen::RowVector3f(0, 0, 0), Eigen::RowVector3f(0.03f, 0, 0),
          Eigen::RowVector3f(0, 0.03f, 0)};
}

inline double median_of_three(std::array<double, 3> v) {
  std::sort(v.begin(), v.end());
  return v[1];
}

/// The face's skin: the skin vertices of the face's UV tile (u < 1).
inline std::vector<int> face_vertices(const rigbuild::PhotoTemplate& t) {
  std::vector<int> face;
  for (int v = 0; v < t.rig.vertex_count(); ++v)
    if (t.skin[static_cast<std::size_t>(v)] && t.rig.uvs(v, 0) < 1.0f) face.push_back(v);
  return face;
}

/// Shape error of `p` against `truth` over the face skin (u < 1) after the best similarity: the
/// RMS distance (model units).
inline double face_error(const rigbuild::PhotoTemplate& t, const rig::Positions& p,
                         const rig::Positions& truth) {
  const std::vector<int> face = face_vertices(t);
  rig::Points a(static_cast<Eigen::Index>(face.size()), 3), b(a.rows(), 3);
  for (std::size_t i = 0; i < face.size(); ++i) {
    a.row(static_cast<Eigen::Index>(i)) = p.row(face[i]).cast<double>();
    b.row(static_cast<Eigen::Index>(i)) = truth.row(face[i]).cast<double>();
  }
  return rigbuild::procrustes(a, b, true).rms;
}

/// The nearest the identity modes reach to `truth` in face_error's measure (coefficients by least
/// squares over the face skin, alternated with the similarity): what a fit of the modes alone can
/// reach at best (a warped head's off-span part stays).
inline double span_error(const rigbuild::PhotoTemplate& t, const rig::Positions& truth) {
  const std::vector<int> face = face_vertices(t);
  const auto n = static_cast<Eigen::Index>(face.size());
  const auto K = static_cast<Eigen::Index>(t.modes.size());
  Eigen::MatrixXd M(3 * n, K);
  Eigen::VectorXd x0(3 * n);
  rig::Points b(n, 3);
  for (Eigen::Index i = 0; i < n; ++i) {
    const int v = face[static_cast<std::size_t>(i)];
    for (int c = 0; c < 3; ++c) {
      x0(3 * i + c) = t.rig.positions(v, c);
      for (Eigen::Index m = 0; m < K; ++m)
        M(3 * i + c, m) = t.modes[static_cast<std::size_t>(m)](v, c);
    }
    b.row(i) = truth.row(v).cast<double>();
  }
  const auto qr = M.colPivHouseholderQr();
  Eigen::VectorXd x = x0;
  rig::Points a(n, 3);
  for (int round = 0; round < 8; ++round) {
    for (Eigen::Index i = 0; i < n; ++i) a.row(i) = x.segment<3>(3 * i).transpose();
    // The truth moved onto the fit; the coefficients fitted to it.
    const rig::Points moved = rigbuild::procrustes(b, a, true).apply(b);
    Eigen::VectorXd y(3 * n);
    for (Eigen::Index i = 0; i < n; ++i) y.segment<3>(3 * i) = moved.row(i).transpose();
    x = x0 + M * qr.solve(y - x0);
  }
  for (Eigen::Index i = 0; i < n; ++i) a.row(i) = x.segment<3>(3 * i).transpose();
  return rigbuild::procrustes(a, b, true).rms;  // as face_error measures it
}

/// The side photo's turn the fit found: the yaw of the front camera's rotation to the side's,
/// degrees (the subject's right towards the camera positive, as photograph's `yaw`).
inline double fitted_turn_degrees(const rigbuild::PhotoFit& fit) {
  if (!fit.side) return 0;
  const Eigen::Matrix3d rel = fit.front.R.transpose() * fit.side->R;
  return std::atan2(rel(0, 2), rel(0, 0)) * 180 / M_PI;
}

/// `rig` rendered as the photo's camera saw it (the photo's size), with the given weights.
inline render::Image render_as_photo(const rig::Rig& rig, const rigbuild::PhotoCamera& camera,
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

/// The expression weights the fit posed the head with (the report's `expression`), by name.
inline std::vector<std::pair<std::string, float>> posed(const rigbuild::PhotoAvatar& a) {
  std::vector<std::pair<std::string, float>> out;
  for (const auto& [name, w] : a.report.at("expression").items())
    out.emplace_back(name, w.get<float>());
  return out;
}

/// Mean distance between the photo's landmarks and those dlib finds on the result rendered with
/// the estimated camera and posed with the fitted expression, in the photo's inter-ocular
/// distances.
inline double reprojection_error(const rigbuild::PhotoAvatar& a, const render::Image& photo,
                                 const rigbuild::PhotoOptions& opt) {
  const render::Image seen = render_as_photo(a.rig, a.fit.front, photo, posed(a));
  const rigbuild::PhotoLandmarks got = rigbuild::detect_photo_landmarks(seen, "render", opt);
  double sum = 0;
  for (std::size_t k = 0; k < got.points.size(); ++k)
    sum += (got.points[k] - a.front.points[k]).norm();
  return sum / static_cast<double>(got.points.size()) /
         (a.front.points[36] - a.front.points[45]).norm();
}

}  // namespace facecast::test
