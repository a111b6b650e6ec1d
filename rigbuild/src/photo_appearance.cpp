// The photo matched pixel by pixel to renders of the painted template (analysis by synthesis's
// dense term, as a morphable model is fitted to an image: Blanz and Vetter 1999): renders of the
// painted head at the fitted identity and moved along each identity mode give how the picture
// changes with the mode; the photo's difference from the first render, blurred and sampled over
// the face's skin, weighed against them is evidence on the identity beyond the 68 points. See
// docs/algorithms.md#photo-avatar.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <vector>

#include "facecast/rig/mesh.hpp"
#include "geometry.hpp"
#include "parallel.hpp"
#include "photo_detail.hpp"

namespace facecast::rigbuild {
namespace {

constexpr int kNuisance = 10;  // per channel gain and offset (6), the photo's similarity warp (4)
// Points nearer than this (inter-ocular distances) to dlib's brows, eyes, nostrils and lips are
// left out: a real face's features are not where the painted template's rule puts them (its brows
// and lips follow the template's landmark vertices), and their colours are the painting's guess.
constexpr double kFeatureGap = 0.15;
// The photo farther than this (face box widths) from the rendered head shows what lies behind it
// (AppearanceGrid::set_backdrop): the renders' outline moves by less along a mode.
constexpr double kBackdropMargin = 0.1;

// The image blurred by a Gaussian of `sigma` pixels at `at`, per channel, 0..1, and its
// derivatives along x and y (derivative of Gaussian). Pixels outside the image are left out; the
// kernel is sampled every sigma / 8 pixels, so that a point costs the same on a large face as on a
// small one. With `behind`, a render's pixels of that colour are its background: `backdrop`'s
// pixel is read there (when not empty), and `head` is the kernel's share of the others.
struct Blurred {
  Eigen::Vector3d value = Eigen::Vector3d::Zero(), dx = Eigen::Vector3d::Zero(),
                  dy = Eigen::Vector3d::Zero();
  double head = 1;
};

bool is_behind(const std::uint8_t* p, const std::array<int, 3>& behind) {
  return std::abs(p[0] - behind[0]) <= 1 && std::abs(p[1] - behind[1]) <= 1 &&
         std::abs(p[2] - behind[2]) <= 1;
}

Blurred blurred(const render::Image& img, const Eigen::Vector2d& at, double sigma,
                const std::optional<std::array<int, 3>>& behind = std::nullopt,
                const render::Image* backdrop = nullptr) {
  const int stride = std::max(1, static_cast<int>(sigma / 8));
  const int r = static_cast<int>(std::ceil(3 * sigma / stride)) * stride;
  const int cx = static_cast<int>(std::lround(at.x())), cy = static_cast<int>(std::lround(at.y()));
  Blurred out;
  double total = 0, head = 0;
  const double inv = 1 / (2 * sigma * sigma);
  for (int y = cy - r; y <= cy + r; y += stride)
    for (int x = cx - r; x <= cx + r; x += stride) {
      if (x < 0 || y < 0 || x >= img.width || y >= img.height) continue;
      const double ox = x - at.x(), oy = y - at.y();
      const double w = std::exp(-(ox * ox + oy * oy) * inv);
      const std::size_t i = static_cast<std::size_t>(y) * img.width + x;
      const auto* p = &img.pixels[i * img.channels];
      if (behind && is_behind(p, *behind)) {
        if (backdrop) p = &backdrop->pixels[i * backdrop->channels];
      } else {
        head += w;
      }
      const Eigen::Vector3d c(p[0], p[1], p[2]);
      out.value += w * c;
      out.dx += w * ox / (sigma * sigma) * c;
      out.dy += w * oy / (sigma * sigma) * c;
      total += w;
    }
  if (total <= 0) return out;
  out.value /= 255 * total;
  out.dx /= 255 * total;
  out.dy /= 255 * total;
  out.head = behind ? head / total : 1.0;
  return out;
}

}  // namespace

AppearanceGrid::AppearanceGrid(const PhotoLandmarks& marks, double sigma_fraction) {
  const double width = marks.rect[2] - marks.rect[0], height = marks.rect[3] - marks.rect[1];
  sigma = std::max(1.0, sigma_fraction * width);
  box = width;
  centre =
      Eigen::Vector2d((marks.rect[0] + marks.rect[2]) / 2, (marks.rect[1] + marks.rect[3]) / 2);
  // dlib's box spans the brows to the chin and cheek to cheek: a fifth of it more each way takes
  // in the face's outline against what lies behind, a third more upwards the forehead. The points
  // are the skin's: its shading and outline.
  const double x0 = marks.rect[0] - 0.2 * width, x1 = marks.rect[2] + 0.2 * width;
  const double y0 = marks.rect[1] - 0.35 * height, y1 = marks.rect[3] + 0.2 * height;
  const double step = 2 * sigma;
  // dlib's points as 3D points in the photo's plane.
  std::array<Eigen::Vector3d, kLandmarkCount> lm;
  for (std::size_t k = 0; k < kLandmarkCount; ++k)
    lm[k] = Eigen::Vector3d(marks.points[k].x(), marks.points[k].y(), 0);
  const double iod = ((lm[36] + lm[39]) / 2 - (lm[42] + lm[45]) / 2).norm();
  const auto chain = [&](const Eigen::Vector3d& q, std::size_t from, std::size_t to, bool closed) {
    double d = closed ? segment_distance(q, lm[to], lm[from]) : 1e30;
    for (std::size_t k = from; k < to; ++k) d = std::min(d, segment_distance(q, lm[k], lm[k + 1]));
    return d;
  };
  for (double y = y0; y <= y1; y += step)
    for (double x = x0; x <= x1; x += step) {
      if (!(x >= 0 && y >= 0 && x <= marks.width - 1 && y <= marks.height - 1)) continue;
      const Eigen::Vector3d q(x, y, 0);
      if (std::min({chain(q, 17, 21, false), chain(q, 22, 26, false), chain(q, 36, 41, true),
                    chain(q, 42, 47, true), chain(q, 48, 59, true), chain(q, 31, 35, false)}) <
          kFeatureGap * iod)
        continue;
      points.emplace_back(x, y);
    }
}

void AppearanceGrid::set_backdrop(const render::Image& photo, const render::Image& shot) {
  behind = {shot.at(0, 0, 0), shot.at(0, 0, 1), shot.at(0, 0, 2)};
  const int w = shot.width, h = shot.height;
  const auto n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  // The distance from the head (chamfer 3-4, in thirds of a pixel).
  constexpr int kFar = 1 << 28;
  std::vector<int> d(n);
  for (std::size_t i = 0; i < n; ++i)
    d[i] = is_behind(&shot.pixels[i * static_cast<std::size_t>(shot.channels)], *behind) ? kFar : 0;
  const auto at = [&](int x, int y) -> int& {
    return d[static_cast<std::size_t>(y) * static_cast<std::size_t>(w) +
             static_cast<std::size_t>(x)];
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      int& v = at(x, y);
      if (x > 0) v = std::min(v, at(x - 1, y) + 3);
      if (y > 0) {
        v = std::min(v, at(x, y - 1) + 3);
        if (x > 0) v = std::min(v, at(x - 1, y - 1) + 4);
        if (x + 1 < w) v = std::min(v, at(x + 1, y - 1) + 4);
      }
    }
  for (int y = h - 1; y >= 0; --y)
    for (int x = w - 1; x >= 0; --x) {
      int& v = at(x, y);
      if (x + 1 < w) v = std::min(v, at(x + 1, y) + 3);
      if (y + 1 < h) {
        v = std::min(v, at(x, y + 1) + 3);
        if (x + 1 < w) v = std::min(v, at(x + 1, y + 1) + 4);
        if (x > 0) v = std::min(v, at(x - 1, y + 1) + 4);
      }
    }
  // The photo's pixels farther than kBackdropMargin of the face box from the head are what lies
  // behind it; nearer, and under the head, they take the colour of the nearest such pixel.
  const int margin = static_cast<int>(3 * kBackdropMargin * box);
  std::vector<Eigen::Vector3f> colour(n, Eigen::Vector3f::Zero());
  std::vector<char> known(n, 0);
  const auto channels = static_cast<std::size_t>(photo.channels);
  for (std::size_t i = 0; i < n; ++i)
    if (d[i] > margin) {
      const auto* p = &photo.pixels[i * channels];
      colour[i] = Eigen::Vector3f(p[0], p[1], p[2]);
      known[i] = 1;
    }
  fill_unseen(colour, known, w, h);
  backdrop = photo;
  for (std::size_t i = 0; i < n; ++i)
    if (known[i])
      for (std::size_t k = 0; k < 3; ++k)
        backdrop.pixels[i * channels + k] =
            static_cast<std::uint8_t>(colour[i](static_cast<Eigen::Index>(k)));
}

AppearanceShot AppearanceGrid::read(const render::Image& render) const {
  const auto n = static_cast<Eigen::Index>(points.size());
  AppearanceShot out{Eigen::VectorXd(3 * n), Eigen::VectorXd(n)};
  for (Eigen::Index i = 0; i < n; ++i) {
    const Blurred b = blurred(render, points[static_cast<std::size_t>(i)], sigma, behind,
                              backdrop.pixels.empty() ? nullptr : &backdrop);
    out.colour.segment<3>(3 * i) = b.value;
    out.head(i) = b.head;
  }
  return out;
}

IdentityEvidence appearance_evidence(const AppearanceGrid& grid, const render::Image& photo,
                                     const std::vector<AppearanceShot>& shots, double amplitude,
                                     double weight) {
  IdentityEvidence out;
  const auto modes = static_cast<Eigen::Index>((shots.size() - 1) / 2);
  const auto n = static_cast<Eigen::Index>(grid.points.size());
  if (modes < 1 || n < 16) return out;
  const Eigen::VectorXd& base = shots[0].colour;
  // Each mode's change of the picture per unit (central difference).
  Eigen::MatrixXd J(3 * n, modes);
  for (Eigen::Index m = 0; m < modes; ++m)
    J.col(m) = (shots[static_cast<std::size_t>(1 + 2 * m)].colour -
                shots[static_cast<std::size_t>(2 + 2 * m)].colour) /
               (2 * amplitude);
  // Where a render shows the head (the background there in none of them: only the photo's room).
  std::vector<char> head(static_cast<std::size_t>(n), 0);
  for (Eigen::Index i = 0; i < n; ++i)
    for (const AppearanceShot& s : shots)
      if (s.head(i) > 0.02) head[static_cast<std::size_t>(i)] = 1;
  // The photo's pixels at the grid moved by a similarity about the box's centre (translation t,
  // scale 1 + a, turn theta): the fit's camera, the renders', carries dlib's mean offset from the
  // template's landmark vertices, a few pixels. Solved with the identity, the per channel gain and
  // offset (the fitted light's error), Tukey-weighted, by Gauss-Newton.
  Eigen::Vector4d warp = Eigen::Vector4d::Zero();  // tx, ty, a, theta
  const Eigen::Index k = modes + kNuisance;
  Eigen::MatrixXd A(3 * n, k);
  Eigen::VectorXd y(3 * n), w = Eigen::VectorXd::Ones(3 * n);
  for (Eigen::Index i = 0; i < n; ++i)
    if (!head[static_cast<std::size_t>(i)]) w.segment<3>(3 * i).setZero();
  double scale = 0;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(k);
  for (int round = 0; round < 8; ++round) {
    const double cs = std::cos(warp(3)), sn = std::sin(warp(3));
    A.setZero();
    A.leftCols(modes) = J;
    for (Eigen::Index i = 0; i < n; ++i) {
      const Eigen::Vector2d d = grid.points[static_cast<std::size_t>(i)] - grid.centre;
      const Eigen::Vector2d turned(cs * d.x() - sn * d.y(), sn * d.x() + cs * d.y());
      const Eigen::Vector2d at = grid.centre + (1 + warp(2)) * turned + warp.head<2>();
      const Blurred b = blurred(photo, at, grid.sigma);
      const Eigen::Vector2d dtheta = (1 + warp(2)) * Eigen::Vector2d(-turned.y(), turned.x());
      for (int c = 0; c < 3; ++c) {
        const Eigen::Index row = 3 * i + c;
        y(row) = b.value(c) - base(row);
        A(row, modes + c) = base(row);  // gain
        A(row, modes + 3 + c) = 1;      // offset
        A(row, modes + 6) = -b.dx(c);   // the photo moved: y + grad . d(at) = model
        A(row, modes + 7) = -b.dy(c);
        A(row, modes + 8) = -(b.dx(c) * turned.x() + b.dy(c) * turned.y());
        A(row, modes + 9) = -(b.dx(c) * dtheta.x() + b.dy(c) * dtheta.y());
      }
    }
    Eigen::MatrixXd N = A.transpose() * w.asDiagonal() * A;
    N.diagonal().head(modes).array() += scale > 0 ? scale * scale : 1e-4 * N.trace() / k;
    N.diagonal().tail(kNuisance).array() += 1e-9 * N.trace() / k;
    x = N.ldlt().solve(A.transpose() * w.asDiagonal() * y);
    warp += x.tail<4>();
    const Eigen::VectorXd r = y - A * x;
    std::vector<double> abs;
    for (Eigen::Index i = 0; i < 3 * n; ++i)
      if (head[static_cast<std::size_t>(i / 3)]) abs.push_back(std::abs(r(i)));
    if (abs.size() < 16) return out;
    scale = std::max(1.4826 * median(abs), 1e-3);
    for (Eigen::Index i = 0; i < 3 * n; ++i) {
      const double u = r(i) / (4.685 * scale);
      w(i) =
          head[static_cast<std::size_t>(i / 3)] && std::abs(u) < 1 ? (1 - u * u) * (1 - u * u) : 0;
    }
  }
  // The identity's information with the nuisance profiled out, in the noise's units.
  const Eigen::MatrixXd N = A.transpose() * w.asDiagonal() * A;
  const Eigen::VectorXd g = A.transpose() * w.asDiagonal() * (y - A.rightCols<4>() * x.tail<4>());
  const Eigen::MatrixXd Nnn =
      N.bottomRightCorner(kNuisance, kNuisance) +
      1e-9 * N.trace() / k * Eigen::MatrixXd::Identity(kNuisance, kNuisance);
  const auto nuisance = Nnn.ldlt();
  const Eigen::MatrixXd Ncn = N.topRightCorner(modes, kNuisance);
  const double var = scale * scale / weight;
  out.information = (N.topLeftCorner(modes, modes) - Ncn * nuisance.solve(Ncn.transpose())) / var;
  out.pull = (g.head(modes) - Ncn * nuisance.solve(g.tail(kNuisance))) / var;
  out.samples = static_cast<int>(std::count(head.begin(), head.end(), 1));
  out.noise = scale;
  out.warp = warp;
  return out;
}

namespace {

// A photo in linear light, 0..1 per channel (its sRGB encoding undone: a highlight adds to the
// skin's colour there, not after the encoding).
struct LinearPhoto {
  int width = 0, height = 0;
  std::vector<Eigen::Vector3f> rgb;
  explicit LinearPhoto(const render::Image& img) : width(img.width), height(img.height) {
    rgb.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
    const auto channels = static_cast<std::size_t>(img.channels);
    for (std::size_t i = 0; i < rgb.size(); ++i)
      for (std::size_t c = 0; c < 3; ++c)
        rgb[i](static_cast<Eigen::Index>(c)) =
            rig::srgb_to_linear(img.pixels[i * channels + c] / 255.0f);
  }
  Eigen::Vector3d bilinear(double x, double y) const {
    x = std::clamp(x, 0.0, width - 1.001);
    y = std::clamp(y, 0.0, height - 1.001);
    const int bx = static_cast<int>(x), by = static_cast<int>(y);
    const double fx = x - bx, fy = y - by;
    const auto at = [&](int dx, int dy) -> Eigen::Vector3d {
      return rgb[static_cast<std::size_t>(by + dy) * static_cast<std::size_t>(width) +
                 static_cast<std::size_t>(bx + dx)]
          .cast<double>();
    };
    return (1 - fy) * ((1 - fx) * at(0, 0) + fx * at(1, 0)) +
           fy * ((1 - fx) * at(0, 1) + fx * at(1, 1));
  }
  // Blurred by a Gaussian of sigma pixels carried by M (the front photo's pixels to this photo's
  // over the same patch of skin), and its derivatives along x and y (central differences).
  Blurred read(const Eigen::Vector2d& q, const Eigen::Matrix2d& M, double sigma) const {
    const double stride = std::max(1.0, sigma / 3);
    const int r = static_cast<int>(std::ceil(3 * sigma / stride));
    const auto value = [&](const Eigen::Vector2d& c) {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      double total = 0;
      for (int j = -r; j <= r; ++j)
        for (int i = -r; i <= r; ++i) {
          const Eigen::Vector2d u(i * stride, j * stride);
          const double w = std::exp(-u.squaredNorm() / (2 * sigma * sigma));
          const Eigen::Vector2d o = c + M * u;
          sum += w * bilinear(o.x(), o.y());
          total += w;
        }
      return Eigen::Vector3d(sum / total);
    };
    Blurred b;
    b.value = value(q);
    b.dx = value(q + Eigen::Vector2d(0.5, 0)) - value(q - Eigen::Vector2d(0.5, 0));
    b.dy = value(q + Eigen::Vector2d(0, 0.5)) - value(q - Eigen::Vector2d(0, 0.5));
    return b;
  }
};

Eigen::Matrix<double, 2, 3> image_jacobian(const PhotoCamera& cam, const Eigen::Vector3d& p) {
  Eigen::Matrix<double, 2, 3> J = cam.jacobian(p);
  J.row(1) = -J.row(1);  // pixels' y down
  return J;
}

// stereo_evidence's points: the head's skin seen by both photos, facing both cameras, over
// dlib's face box and around it as AppearanceGrid's; one vertex per 2 sigma cell of the front
// photo (the one nearest the cell's centre), so that the blurred samples overlap little.
std::vector<int> stereo_points(const PhotoTemplate& tmpl, const rig::Positions& at,
                               const rig::Positions& normals, const PhotoLandmarks& marks,
                               const render::Image& front, const PhotoCamera& front_camera,
                               const render::Image& side, const PhotoCamera& side_camera,
                               double sigma) {
  const double width = marks.rect[2] - marks.rect[0], height = marks.rect[3] - marks.rect[1];
  const double x0 = marks.rect[0] - 0.2 * width, x1 = marks.rect[2] + 0.2 * width;
  const double y0 = marks.rect[1] - 0.35 * height, y1 = marks.rect[3] + 0.2 * height;
  const double cell = 2 * sigma;
  const int cols = std::max(1, static_cast<int>(std::ceil((x1 - x0) / cell)));
  const int rows = std::max(1, static_cast<int>(std::ceil((y1 - y0) / cell)));
  const DepthBuffer front_depth(at, tmpl.rig.triangles, front_camera, front.width, front.height);
  const DepthBuffer side_depth(at, tmpl.rig.triangles, side_camera, side.width, side.height);
  const auto point = [&](Eigen::Index v) -> Eigen::Vector3d {
    return at.row(v).cast<double>().transpose();
  };
  const double iod = (point(tmpl.landmarks[36]) - point(tmpl.landmarks[45])).norm();
  const double margin = 6 * sigma + 2;
  const auto inside = [&](const Eigen::Vector2d& q, const render::Image& img) {
    return q.x() >= margin && q.y() >= margin && q.x() <= img.width - 1 - margin &&
           q.y() <= img.height - 1 - margin;
  };
  // The blur's reach around a point shows the head in either photo, none of it hidden by a nearer
  // part (the nose before the far cheek) or beyond the outline: there the views differ.
  const double reach = 3 * sigma;
  const auto clear = [&](const DepthBuffer& depth, const PhotoCamera& cam, const Eigen::Vector3d& p,
                         const Eigen::Vector2d& q) {
    const double z = cam.depth(p), slack = 1.2 * reach / cam.s;
    for (int a = 0; a < 8; ++a) {
      const Eigen::Vector2d o =
          q + reach * Eigen::Vector2d(std::cos(a * M_PI / 4), std::sin(a * M_PI / 4));
      if (!depth.covered(o) || !depth.visible(o, z, slack)) return false;
    }
    return true;
  };
  std::vector<std::pair<int, double>> best(static_cast<std::size_t>(cols * rows), {-1, 1e30});
  for (Eigen::Index v = 0; v < at.rows(); ++v) {
    if (!tmpl.skin[static_cast<std::size_t>(v)]) continue;
    const Eigen::Vector3d p = point(v);
    const Eigen::Vector3d nrm = normals.row(v).cast<double>().transpose();
    const Eigen::Vector2d f = front_camera.project(p), s = side_camera.project(p);
    if (f.x() < x0 || f.x() >= x1 || f.y() < y0 || f.y() >= y1) continue;
    if (!inside(f, front) || !inside(s, side)) continue;
    if (nrm.dot(front_camera.towards(p)) < 0.3 || nrm.dot(side_camera.towards(p)) < 0.3) continue;
    if (!front_depth.visible(f, front_camera.depth(p), 0.02 * iod) ||
        !side_depth.visible(s, side_camera.depth(p), 0.02 * iod))
      continue;
    if (!clear(front_depth, front_camera, p, f) || !clear(side_depth, side_camera, p, s)) continue;
    const int cx = static_cast<int>((f.x() - x0) / cell),
              cy = static_cast<int>((f.y() - y0) / cell);
    const Eigen::Vector2d middle(x0 + (cx + 0.5) * cell, y0 + (cy + 0.5) * cell);
    auto& b = best[static_cast<std::size_t>(cy * cols + cx)];
    if ((f - middle).squaredNorm() < b.second)
      b = {static_cast<int>(v), (f - middle).squaredNorm()};
  }
  std::vector<int> vertices;
  for (const auto& b : best)
    if (b.first >= 0) vertices.push_back(b.first);
  return vertices;
}

}  // namespace

IdentityEvidence stereo_evidence(const PhotoTemplate& tmpl, const rig::Positions& at,
                                 const PhotoLandmarks& marks, const render::Image& front,
                                 const PhotoCamera& front_camera, const render::Image& side,
                                 const PhotoCamera& side_camera, double sigma_fraction,
                                 double weight) {
  IdentityEvidence out;
  const auto modes = static_cast<Eigen::Index>(tmpl.modes.size());
  const double width = marks.rect[2] - marks.rect[0];
  const double sigma = std::max(1.0, sigma_fraction * width);
  const rig::Positions normals = rig::vertex_normals(at, tmpl.rig.triangles);
  const std::vector<int> vertices =
      stereo_points(tmpl, at, normals, marks, front, front_camera, side, side_camera, sigma);
  const auto point = [&](Eigen::Index v) -> Eigen::Vector3d {
    return at.row(v).cast<double>().transpose();
  };
  const auto n = static_cast<Eigen::Index>(vertices.size());
  if (modes < 1 || n < 16) return out;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const int v : vertices) centre += point(v);
  centre /= static_cast<double>(n);

  const LinearPhoto front_light(front), side_light(side);
  // The two colour components across the light's own (white) colour: a highlight, the light's
  // colour added (the dichromatic model), moves neither, so the view-dependent sheen drops out.
  Eigen::Matrix<double, 2, 3> chroma;
  chroma << 1 / std::sqrt(2.0), -1 / std::sqrt(2.0), 0, 1 / std::sqrt(6.0), 1 / std::sqrt(6.0),
      -2 / std::sqrt(6.0);
  // Solved with the identity, profiled out: per channel, a gain and an offset varying over the
  // face to second order in the front photo's position (the light on the skin seen from two
  // sides); the lens (a change of kappa for both cameras: the fit keeps a long lens orthographic,
  // the disparity between the views depends on it as on depth), re-projected each round; the
  // head's move (below); the side camera's small move (turned about the points' centre, shifted,
  // scaled about the centre's image: the fitted cameras' relative error).
  constexpr int kTerms = 6, kChannels = 2, kMotion = 6, kHead = 5;
  constexpr int kFixed = 2 * kChannels * kTerms + 1 + kHead;
  const Eigen::Index k = modes + kFixed + kMotion;
  const Eigen::Index lens = modes + 2 * kChannels * kTerms, head = lens + 1;
  // The head's small move in both photos (turned about the points' centre, shifted across the
  // front camera): the fitted pose is uncertain by a degree or a pixel, and a move there reads
  // another patch of skin in each photo, which the side camera's move alone cannot follow. Its
  // prior: the landmarks' pose within kTurnSd and kShiftSd (degrees, pixels; tried 0.5, 1, 2 and
  // 4: development window mixtures 0.46, 0.44, 0.43, 0.46; free, it turned the template's own
  // head 1-4 degrees and followed the shading with it).
  constexpr double kTurnSd = 2, kShiftSd = 2;
  const double turn_sd = kTurnSd * M_PI / 180, shift_sd = kShiftSd / front_camera.s;
  Eigen::Vector3d shift = Eigen::Vector3d::Zero();
  Eigen::Matrix3d turn = Eigen::Matrix3d::Identity();
  const Eigen::Vector2d box_centre(0.5 * (marks.rect[0] + marks.rect[2]),
                                   0.5 * (marks.rect[1] + marks.rect[3]));
  PhotoCamera fc = front_camera, sc = side_camera;
  for (auto [cam, img] : {std::pair{&fc, &front}, {&sc, &side}})
    if (!cam->perspective()) cam->centre = {0.5 * (img->width - 1), 0.5 * (img->height - 1)};
  // The lens's change moves a point away from the principal point by its depth.
  const auto lens_move = [](const PhotoCamera& cam, const Eigen::Vector3d& p) -> Eigen::Vector2d {
    const double z = cam.depth(p);
    return (cam.project(p) - cam.centre) * z / std::max(1e-6, 1 - cam.kappa * z);
  };
  double max_depth = 0;
  for (const int v : vertices)
    max_depth = std::max({max_depth, std::abs(fc.depth(point(v))), std::abs(sc.depth(point(v)))});
  Eigen::Matrix<double, kMotion, 1> motion = Eigen::Matrix<double, kMotion, 1>::Zero();
  Eigen::MatrixXd A(kChannels * n, k);
  Eigen::VectorXd y(kChannels * n), w = Eigen::VectorXd::Ones(kChannels * n),
                                    x = Eigen::VectorXd::Zero(k);
  double scale = 0;
  for (int round = 0; round < 8; ++round) {
    const Eigen::Vector2d side_centre = sc.project(centre);
    A.setZero();
    // Each point's rows, the photos read at it (most of the cost).
    parallel_for(n, [&](Eigen::Index i) {
      const Eigen::Vector3d p =
          centre + turn * (point(vertices[static_cast<std::size_t>(i)]) - centre) + shift;
      const Eigen::Matrix<double, 2, 3> Jf = image_jacobian(fc, p), Js = image_jacobian(sc, p);
      Eigen::Matrix<double, 2, kMotion> camera_move;
      for (int a = 0; a < 3; ++a)
        camera_move.col(a) = Js * Eigen::Vector3d::Unit(a).cross(p - centre);
      const Eigen::Vector2d pf = fc.project(p), ps0 = sc.project(p);
      camera_move.col(3) = Eigen::Vector2d(1, 0);
      camera_move.col(4) = Eigen::Vector2d(0, 1);
      camera_move.col(5) = (ps0 - side_centre) / width;
      const Eigen::Vector2d ps = ps0 + camera_move * motion;
      // The side photo read over the front's patch of skin.
      const Eigen::Vector3d nrm =
          turn * normals.row(vertices[static_cast<std::size_t>(i)]).cast<double>().transpose();
      const Eigen::Vector3d t1 = nrm.unitOrthogonal(), t2 = nrm.cross(t1);
      Eigen::Matrix<double, 3, 2> T;
      T << t1, t2;
      const Eigen::Matrix2d F2 = Jf * T, S2 = Js * T;
      const Eigen::Matrix2d to_side = std::abs(F2.determinant()) > 1e-9
                                          ? Eigen::Matrix2d(S2 * F2.inverse())
                                          : Eigen::Matrix2d::Identity();
      const Blurred f = front_light.read(pf, Eigen::Matrix2d::Identity(), sigma);
      const Blurred s = side_light.read(ps, to_side, sigma);
      const Eigen::Vector2d fv = chroma * f.value, sv = chroma * s.value;
      Eigen::Matrix<double, 2, 2> gf, gs;  // per channel, d/dx and d/dy
      gf << chroma * f.dx, chroma * f.dy;
      gs << chroma * s.dx, chroma * s.dy;
      const Eigen::Vector2d q = (pf - box_centre) / width;
      const double terms[kTerms] = {1, q.x(), q.y(), q.x() * q.x(), q.x() * q.y(), q.y() * q.y()};
      const Eigen::Vector2d lens_f = lens_move(fc, p), lens_s = lens_move(sc, p);
      for (int c = 0; c < kChannels; ++c) {
        const Eigen::Index row = kChannels * i + c;
        y(row) = sv(c) - fv(c);
        for (Eigen::Index m = 0; m < modes; ++m) {
          const Eigen::Vector3d d = turn * tmpl.modes[static_cast<std::size_t>(m)]
                                               .row(vertices[static_cast<std::size_t>(i)])
                                               .cast<double>()
                                               .transpose();
          A(row, m) = gf.row(c).dot(Jf * d) - gs.row(c).dot(Js * d);
        }
        for (int b = 0; b < kTerms; ++b) {
          A(row, modes + kTerms * c + b) = fv(c) * terms[b];        // gain
          A(row, modes + kTerms * (kChannels + c) + b) = terms[b];  // offset
        }
        A(row, lens) = gf.row(c).dot(lens_f) - gs.row(c).dot(lens_s);
        for (int a = 0; a < 3; ++a) {
          const Eigen::Vector3d dr = Eigen::Vector3d::Unit(a).cross(p - centre - shift);
          A(row, head + a) = gf.row(c).dot(Jf * dr) - gs.row(c).dot(Js * dr);
        }
        for (int a = 0; a < 2; ++a) {
          const Eigen::Vector3d dt = front_camera.R.row(a).transpose();
          A(row, head + 3 + a) = gf.row(c).dot(Jf * dt) - gs.row(c).dot(Js * dt);
        }
        A.block(row, modes + kFixed, 1, kMotion) = -gs.row(c) * camera_move;
      }
    });
    Eigen::MatrixXd N = A.transpose() * w.asDiagonal() * A;
    N.diagonal().head(modes).array() += scale > 0 ? scale * scale : 1e-4 * N.trace() / k;
    N.diagonal().tail(kFixed + kMotion).array() += 1e-9 * N.trace() / k;
    Eigen::VectorXd rhs = A.transpose() * w.asDiagonal() * y;
    const double noise2 = std::max(scale, 1e-4) * std::max(scale, 1e-4) / weight;
    const Eigen::AngleAxisd current(turn);
    const Eigen::Vector3d omega_now = current.angle() * current.axis();
    for (int a = 0; a < 3; ++a) {
      N(head + a, head + a) += noise2 / (turn_sd * turn_sd);
      rhs(head + a) -= noise2 / (turn_sd * turn_sd) * omega_now(a);
    }
    for (int a = 0; a < 2; ++a) {
      N(head + 3 + a, head + 3 + a) += noise2 / (shift_sd * shift_sd);
      rhs(head + 3 + a) -= noise2 / (shift_sd * shift_sd) * front_camera.R.row(a).dot(shift);
    }
    x = N.ldlt().solve(rhs);
    motion += x.tail<kMotion>();
    const Eigen::Vector3d omega = x.segment<3>(head);
    if (omega.norm() > 0)
      turn = Eigen::AngleAxisd(omega.norm(), omega.normalized()).toRotationMatrix() * turn;
    for (int a = 0; a < 2; ++a) shift += x(head + 3 + a) * front_camera.R.row(a).transpose();
    // The lens moved, both cameras alike, a distance no nearer than twice the head's depth.
    for (PhotoCamera* cam : {&fc, &sc})
      cam->kappa = std::clamp(cam->kappa + x(lens), 0.0, 0.5 / std::max(1e-6, max_depth));
    const Eigen::VectorXd r = y - A * x;
    std::vector<double> abs(static_cast<std::size_t>(r.size()));
    for (Eigen::Index i = 0; i < r.size(); ++i) abs[static_cast<std::size_t>(i)] = std::abs(r(i));
    scale = std::max(1.4826 * median(abs), 1e-5);
    for (Eigen::Index i = 0; i < r.size(); ++i) {
      const double t = r(i) / (4.685 * scale);
      w(i) = std::abs(t) < 1 ? (1 - t * t) * (1 - t * t) : 0;
    }
  }
  Eigen::MatrixXd N = A.transpose() * w.asDiagonal() * A;
  {
    const double noise2 = scale * scale / weight;
    for (int a = 0; a < 3; ++a) N(head + a, head + a) += noise2 / (turn_sd * turn_sd);
    for (int a = 0; a < 2; ++a) N(head + 3 + a, head + 3 + a) += noise2 / (shift_sd * shift_sd);
  }
  const Eigen::VectorXd g =
      A.transpose() * w.asDiagonal() * (y - A.rightCols<kMotion>() * x.tail<kMotion>());
  const Eigen::MatrixXd Nnn =
      N.bottomRightCorner(kFixed + kMotion, kFixed + kMotion) +
      1e-9 * N.trace() / k * Eigen::MatrixXd::Identity(kFixed + kMotion, kFixed + kMotion);
  const auto nuisance = Nnn.ldlt();
  const Eigen::MatrixXd Ncn = N.topRightCorner(modes, kFixed + kMotion);
  const double var = scale * scale / weight;
  out.information = (N.topLeftCorner(modes, modes) - Ncn * nuisance.solve(Ncn.transpose())) / var;
  out.pull = (g.head(modes) - Ncn * nuisance.solve(g.tail(kFixed + kMotion))) / var;
  out.samples = static_cast<int>(n);
  out.noise = scale;
  // The side photo's move: its shift (pixels), scale and turn in its own plane (the rotation's
  // part about the side camera's axis).
  out.warp = Eigen::Vector4d(motion(3), motion(4), motion(5) / width,
                             side_camera.towards().dot(motion.head<3>()));
  return out;
}

}  // namespace facecast::rigbuild
