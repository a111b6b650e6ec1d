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

#include "geometry.hpp"
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

}  // namespace facecast::rigbuild
