// The photo avatar's texture: every skin texel's surface point looked up in each photo where a
// depth test through the fitted camera shows it, the colours blended by the normal (seed 003,
// section 5: k = |N.front| / (|N.front| + |N.side|)), the side photo colour-matched to the front
// first, unseen texels filled from the nearest seen one. Outside the face's outline only pixels of
// the head are taken: skin-coloured, or unlike the photo's border (its background, and the clothes
// at its bottom edge). See docs/algorithms.md#photo-avatar.
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <limits>
#include <vector>

#include "facecast/core/error.hpp"
#include "geometry.hpp"
#include "photo_detail.hpp"

namespace facecast::rigbuild {
namespace {

// Calls f(x, y, b) for every whole-number sample (x, y) inside the 2D triangle a, b, c (b:
// barycentric weights), clipped to [0, w) x [0, h).
template <class F>
void rasterize(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c, int w,
               int h, F&& f) {
  const double area = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
  if (std::abs(area) < 1e-12) return;
  const int x0 = std::max(0, static_cast<int>(std::ceil(std::min({a.x(), b.x(), c.x()}))));
  const int x1 = std::min(w - 1, static_cast<int>(std::floor(std::max({a.x(), b.x(), c.x()}))));
  const int y0 = std::max(0, static_cast<int>(std::ceil(std::min({a.y(), b.y(), c.y()}))));
  const int y1 = std::min(h - 1, static_cast<int>(std::floor(std::max({a.y(), b.y(), c.y()}))));
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const Eigen::Vector2d p(x, y);
      const double wa = ((b - p).x() * (c - p).y() - (b - p).y() * (c - p).x()) / area;
      const double wb = ((c - p).x() * (a - p).y() - (c - p).y() * (a - p).x()) / area;
      const double wc = 1 - wa - wb;
      if (wa < -1e-9 || wb < -1e-9 || wc < -1e-9) continue;
      f(x, y, Eigen::Vector3d(wa, wb, wc));
    }
}

Eigen::Vector3f sample(const render::Image& img, const Eigen::Vector2d& at) {
  const double x = std::clamp(at.x(), 0.0, img.width - 1.0),
               y = std::clamp(at.y(), 0.0, img.height - 1.0);
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const int x1 = std::min(x0 + 1, img.width - 1), y1 = std::min(y0 + 1, img.height - 1);
  const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
  Eigen::Vector3f c;
  for (int k = 0; k < 3; ++k)
    c(k) = (1 - fy) * ((1 - fx) * img.at(x0, y0, k) + fx * img.at(x1, y0, k)) +
           fy * ((1 - fx) * img.at(x0, y1, k) + fx * img.at(x1, y1, k));
  return c;
}

// Colour coordinates that separate hue from light: log(r / g), log(b / g) and the mean level.
Eigen::Vector3d chroma(const Eigen::Vector3f& rgb) {
  const double r = rgb(0) + 1.0, g = rgb(1) + 1.0, b = rgb(2) + 1.0;
  return {std::log(r / g), std::log(b / g), (r + g + b) / 3.0};
}

// The face's skin colour, learnt from the front photo between landmarks that skin always
// separates (jaw to nostril and to mouth corner across the cheeks, lower lip to chin, the nose's
// ridge): per coordinate the median and a robust spread (1.4826 MAD), so that a shadow, a mole or
// a stray landmark does not move it.
class SkinColour {
 public:
  SkinColour(const render::Image& photo, const std::array<Eigen::Vector2d, kLandmarkCount>& lm) {
    static constexpr std::array<std::pair<int, int>, 8> kAcrossSkin = {
        {{2, 31}, {14, 35}, {4, 48}, {12, 54}, {57, 8}, {27, 30}, {3, 31}, {13, 35}}};
    std::vector<Eigen::Vector3d> samples;
    for (const auto& [a, b] : kAcrossSkin)
      for (double t = 0.3; t <= 0.7 + 1e-9; t += 0.05) {
        const Eigen::Vector2d at = lm[a] + t * (lm[b] - lm[a]);
        if (at.x() >= 0 && at.y() >= 0 && at.x() < photo.width && at.y() < photo.height)
          samples.push_back(chroma(sample(photo, at)));
      }
    if (samples.size() < 20) return;  // the face is mostly outside the photo: no model
    for (int k = 0; k < 3; ++k) {
      std::vector<double> v, dev;
      for (const auto& c : samples) v.push_back(c(k));
      centre_(k) = median(v);
      for (double x : v) dev.push_back(std::abs(x - centre_(k)));
      spread_(k) = 1.4826 * median(dev);
    }
    // Floors: skin's hue varies over a head more than over the cheeks, and its light much more.
    spread_(0) = std::max(spread_(0), 0.05);
    spread_(1) = std::max(spread_(1), 0.05);
    known_ = true;
  }

  /// Within 4 spreads of the face's hue, and lit between a third and twice the face's level.
  bool like(const Eigen::Vector3f& rgb) const {
    if (!known_) return false;
    const Eigen::Vector3d c = chroma(rgb);
    return std::abs(c(0) - centre_(0)) < 4 * spread_(0) &&
           std::abs(c(1) - centre_(1)) < 4 * spread_(1) && c(2) > centre_(2) / 3 &&
           c(2) < 2 * centre_(2) + 10;
  }

 private:
  Eigen::Vector3d centre_ = Eigen::Vector3d::Zero(), spread_ = Eigen::Vector3d::Ones();
  bool known_ = false;
};

// Which pixels of one photo may colour the head. Inside the face's outline (front photo only)
// every pixel: eyes, brows, lips and beards belong to the face. Outside
// it (scalp, ears, neck) a pixel is refused when its colour is common on the photo's border (the
// background, and the clothes at the bottom edge: a 16-level colour histogram of a band 2 % of the
// photo wide, its 3 x 3 x 3 neighbourhood holding at least 1 % of the band) unless it is
// skin-coloured; hair, unlike the border, stays.
class PhotoRegions {
 public:
  PhotoRegions(const render::Image& photo, const std::vector<Eigen::Vector2d>& outline,
               const SkinColour& skin)
      : photo_(photo), outline_(outline), skin_(skin) {
    const int band = std::max(2, std::min(photo.width, photo.height) / 50);
    std::vector<double> count(kBins * kBins * kBins, 0.0);
    double total = 0;
    for (int y = 0; y < photo.height; ++y)
      for (int x = 0; x < photo.width; ++x) {
        if (x >= band && y >= band && x < photo.width - band && y < photo.height - band) continue;
        count[bin(photo.at(x, y, 0), photo.at(x, y, 1), photo.at(x, y, 2))] += 1;
        total += 1;
      }
    border_.assign(count.size(), 0);
    for (int r = 0; r < kBins; ++r)
      for (int g = 0; g < kBins; ++g)
        for (int b = 0; b < kBins; ++b) {
          double near = 0;
          for (int dr = -1; dr <= 1; ++dr)
            for (int dg = -1; dg <= 1; ++dg)
              for (int db = -1; db <= 1; ++db) {
                const int rr = r + dr, gg = g + dg, bb = b + db;
                if (rr >= 0 && gg >= 0 && bb >= 0 && rr < kBins && gg < kBins && bb < kBins)
                  near += count[static_cast<std::size_t>((rr * kBins + gg) * kBins + bb)];
              }
          border_[static_cast<std::size_t>((r * kBins + g) * kBins + b)] = near >= 0.01 * total;
        }
  }

  bool usable(const Eigen::Vector2d& at) const {
    if (!outline_.empty() && inside_outline(at)) return true;
    const Eigen::Vector3f c = sample(photo_, at);
    const auto level = [](float v) { return static_cast<int>(std::clamp(v, 0.0f, 255.0f)); };
    return skin_.like(c) || !border_[bin(level(c(0)), level(c(1)), level(c(2)))];
  }

 private:
  static constexpr int kBins = 16;
  static std::size_t bin(int r, int g, int b) {
    return static_cast<std::size_t>(((r * kBins / 256) * kBins + g * kBins / 256) * kBins +
                                    b * kBins / 256);
  }
  // Even-odd rule over the outline polygon.
  bool inside_outline(const Eigen::Vector2d& p) const {
    bool in = false;
    for (std::size_t i = 0, j = outline_.size() - 1; i < outline_.size(); j = i++) {
      const Eigen::Vector2d &a = outline_[i], &b = outline_[j];
      if ((a.y() > p.y()) != (b.y() > p.y()) &&
          p.x() < a.x() + (p.y() - a.y()) * (b.x() - a.x()) / (b.y() - a.y()))
        in = !in;
    }
    return in;
  }

  const render::Image& photo_;
  std::vector<Eigen::Vector2d> outline_;
  const SkinColour& skin_;
  std::vector<char> border_;
};

// The face's outline in the front photo, from the fitted landmarks: the jaw line (0-16) drawn
// 5 % in towards the face's centre (the fitted jaw need not be the person's: background lies just
// outside it) and the brows (26 to 17) 10 % out (all of the brows' hair).
std::vector<Eigen::Vector2d> face_outline(const std::array<Eigen::Vector2d, kLandmarkCount>& lm) {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  for (int k = 0; k <= 26; ++k) centre += lm[static_cast<std::size_t>(k)] / 27.0;
  std::vector<Eigen::Vector2d> out;
  for (int k = 0; k <= 16; ++k)
    out.push_back(centre + 0.95 * (lm[static_cast<std::size_t>(k)] - centre));
  for (int k = 26; k >= 17; --k)
    out.push_back(centre + 1.1 * (lm[static_cast<std::size_t>(k)] - centre));
  return out;
}

// Per texel, what each photo contributes.
struct Texels {
  int w = 0, h = 0;
  std::vector<Eigen::Vector3f> colour[2];
  std::vector<float> weight[2];
  std::vector<char> covered;  // a skin triangle covers the texel
};

// Per channel, mean and standard deviation of the side colours mapped to the front's, over the
// texels both photos see well.
void match_side_colours(Texels& t) {
  Eigen::Vector3d sf = Eigen::Vector3d::Zero(), ss = sf, qf = sf, qs = sf;
  double n = 0;
  for (std::size_t i = 0; i < t.weight[0].size(); ++i) {
    if (t.weight[0][i] < 0.3f || t.weight[1][i] < 0.3f) continue;
    const Eigen::Vector3d f = t.colour[0][i].cast<double>(), s = t.colour[1][i].cast<double>();
    sf += f;
    ss += s;
    qf += f.cwiseProduct(f);
    qs += s.cwiseProduct(s);
    n += 1;
  }
  if (n < 50) return;
  const Eigen::Vector3d mf = sf / n, ms = ss / n;
  const Eigen::Vector3d df = (qf / n - mf.cwiseProduct(mf)).cwiseMax(1.0).cwiseSqrt();
  const Eigen::Vector3d ds = (qs / n - ms.cwiseProduct(ms)).cwiseMax(1.0).cwiseSqrt();
  for (std::size_t i = 0; i < t.weight[1].size(); ++i) {
    if (t.weight[1][i] <= 0) continue;
    const Eigen::Vector3d s = t.colour[1][i].cast<double>();
    t.colour[1][i] = (mf + (s - ms).cwiseQuotient(ds).cwiseProduct(df)).cast<float>();
  }
}

}  // namespace

void fill_unseen(std::vector<Eigen::Vector3f>& colour, std::vector<char>& done, int w, int h) {
  std::deque<int> queue;
  for (int i = 0; i < w * h; ++i)
    if (done[static_cast<std::size_t>(i)]) queue.push_back(i);
  while (!queue.empty()) {
    const int i = queue.front();
    queue.pop_front();
    const int x = i % w, y = i / w;
    const int next[4] = {x > 0 ? i - 1 : -1, x + 1 < w ? i + 1 : -1, y > 0 ? i - w : -1,
                         y + 1 < h ? i + w : -1};
    for (int j : next) {
      if (j < 0 || done[static_cast<std::size_t>(j)]) continue;
      done[static_cast<std::size_t>(j)] = 1;
      colour[static_cast<std::size_t>(j)] = colour[static_cast<std::size_t>(i)];
      queue.push_back(j);
    }
  }
}

DepthBuffer::DepthBuffer(const rig::Positions& p, const Triangles& tri, const PhotoCamera& cam,
                         int w_, int h_)
    : w(w_), h(h_), depth(static_cast<std::size_t>(w_) * h_, kEmpty) {
  std::vector<Eigen::Vector2d> px(static_cast<std::size_t>(p.rows()));
  std::vector<double> z(px.size());
  for (Eigen::Index v = 0; v < p.rows(); ++v) {
    const Eigen::Vector3d q = p.row(v).cast<double>().transpose();
    px[static_cast<std::size_t>(v)] = cam.project(q);
    z[static_cast<std::size_t>(v)] = cam.depth(q);
  }
  for (Eigen::Index t = 0; t < tri.rows(); ++t) {
    const auto i = static_cast<std::size_t>(tri(t, 0)), j = static_cast<std::size_t>(tri(t, 1)),
               k = static_cast<std::size_t>(tri(t, 2));
    rasterize(px[i], px[j], px[k], w, h, [&](int x, int y, const Eigen::Vector3d& b) {
      float& d = depth[static_cast<std::size_t>(y) * w + x];
      d = std::max(d, static_cast<float>(b(0) * z[i] + b(1) * z[j] + b(2) * z[k]));
    });
  }
}

std::ptrdiff_t DepthBuffer::pixel(const Eigen::Vector2d& at) const {
  const int x = static_cast<int>(std::lround(at.x())), y = static_cast<int>(std::lround(at.y()));
  if (x < 0 || y < 0 || x >= w || y >= h) return -1;
  return static_cast<std::ptrdiff_t>(y) * w + x;
}

bool DepthBuffer::visible(const Eigen::Vector2d& at, double z, double tolerance) const {
  const std::ptrdiff_t i = pixel(at);
  return i >= 0 && z >= depth[static_cast<std::size_t>(i)] - tolerance;
}

bool DepthBuffer::covered(const Eigen::Vector2d& at) const {
  const std::ptrdiff_t i = pixel(at);
  return i >= 0 && depth[static_cast<std::size_t>(i)] > kEmpty;
}

void for_each_skin_texel(
    const PhotoTemplate& tmpl, const rig::Positions& positions, int w, int h, int tiles,
    const std::function<void(std::size_t, const Eigen::Vector3d&, const Eigen::Vector3d&)>& f) {
  const rig::Rig& rig = tmpl.rig;
  const rig::Positions normals = rig::vertex_normals(positions, rig.triangles);
  const auto uv = [&](int v) {
    return Eigen::Vector2d(rig.uvs(v, 0) / tiles * w - 0.5, rig.uvs(v, 1) * h - 0.5);
  };
  const auto at = [](const rig::Positions& p, int v) {
    return Eigen::Vector3d(p.row(v).cast<double>().transpose());
  };
  // Triangles across a UV seam (one UV per vertex: a corner takes the other island's) are
  // stretched far beyond the others in UV: left out.
  const auto stretch = [&](int t) {
    const int a = rig.triangles(t, 0), b = rig.triangles(t, 1), c = rig.triangles(t, 2);
    const double uv_area = std::abs((uv(b) - uv(a)).x() * (uv(c) - uv(a)).y() -
                                    (uv(b) - uv(a)).y() * (uv(c) - uv(a)).x());
    const double area =
        (at(positions, b) - at(positions, a)).cross(at(positions, c) - at(positions, a)).norm();
    return uv_area / std::max(area, 1e-12);
  };
  std::vector<double> stretches;
  for (int t = 0; t < rig.triangle_count(); ++t) stretches.push_back(stretch(t));
  std::vector<double> sorted = stretches;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2),
                   sorted.end());
  const double limit = 20 * sorted[sorted.size() / 2];
  for (int t = 0; t < rig.triangle_count(); ++t) {
    const int a = rig.triangles(t, 0), b = rig.triangles(t, 1), c = rig.triangles(t, 2);
    if (!tmpl.skin[static_cast<std::size_t>(a)] || !tmpl.skin[static_cast<std::size_t>(b)] ||
        !tmpl.skin[static_cast<std::size_t>(c)] || stretches[static_cast<std::size_t>(t)] > limit)
      continue;
    rasterize(uv(a), uv(b), uv(c), w, h, [&](int x, int y, const Eigen::Vector3d& k) {
      const Eigen::Vector3d p =
          k(0) * at(positions, a) + k(1) * at(positions, b) + k(2) * at(positions, c);
      const Eigen::Vector3d n =
          (k(0) * at(normals, a) + k(1) * at(normals, b) + k(2) * at(normals, c)).normalized();
      f(static_cast<std::size_t>(y) * w + x, p, n);
    });
  }
}

render::Image bake_photo_texture(const PhotoTemplate& tmpl, const PhotoFit& fit,
                                 const render::Image& front, const render::Image* side,
                                 const PhotoOptions& options, double* coverage, double* refused) {
  const rig::Rig& rig = tmpl.rig;
  if (rig.uvs.rows() != rig.vertex_count()) throw Error("photo avatar: the template has no UVs");
  float umax = 1;
  for (int v = 0; v < rig.vertex_count(); ++v)
    if (tmpl.skin[static_cast<std::size_t>(v)]) umax = std::max(umax, rig.uvs(v, 0));
  const int tiles = static_cast<int>(std::ceil(umax - 1e-4));
  Texels t;
  t.h = options.texture_size;
  t.w = tiles * options.texture_size;
  const auto n = static_cast<std::size_t>(t.w) * t.h;
  for (int k = 0; k < 2; ++k) {
    t.colour[k].assign(n, Eigen::Vector3f::Zero());
    t.weight[k].assign(n, 0.0f);
  }
  t.covered.assign(n, 0);

  const render::Image* photos[2] = {&front, side};
  const PhotoCamera* cams[2] = {&fit.front, fit.side ? &*fit.side : nullptr};
  const rig::Positions posed = posed_positions(tmpl, fit);  // as the photos show the head
  const double iod =
      (posed.row(tmpl.landmarks[36]) - posed.row(tmpl.landmarks[45])).cast<double>().norm();
  std::vector<DepthBuffer> depth;
  std::vector<PhotoRegions> regions;
  std::array<Eigen::Vector2d, kLandmarkCount> landmarks;
  for (int k = 0; k < kLandmarkCount; ++k)
    landmarks[static_cast<std::size_t>(k)] = fit.front.project(
        posed.row(fit.front_vertex[static_cast<std::size_t>(k)]).cast<double>().transpose());
  const SkinColour skin(front, landmarks);
  regions.reserve(2);
  for (int k = 0; k < 2; ++k)
    if (photos[k] && cams[k]) {
      depth.emplace_back(posed, rig.triangles, *cams[k], photos[k]->width, photos[k]->height);
      if (!options.mask_background) continue;
      // In the side photo the far half of the outline is hidden and encloses background: there
      // every pixel is judged by its colour (the front photo sees the face's features).
      regions.emplace_back(*photos[k],
                           k == 0 ? face_outline(landmarks) : std::vector<Eigen::Vector2d>{}, skin);
    }
  std::size_t background = 0;
  for_each_skin_texel(tmpl, posed, t.w, t.h, tiles,
                      [&](std::size_t i, const Eigen::Vector3d& p, const Eigen::Vector3d& nrm) {
                        t.covered[i] = 1;
                        bool seen = false, taken = false;
                        for (std::size_t k = 0; k < depth.size(); ++k) {
                          const double facing = nrm.dot(cams[k]->towards(p));
                          const Eigen::Vector2d at = cams[k]->project(p);
                          if (facing <= 0 || !depth[k].visible(at, cams[k]->depth(p), 0.02 * iod))
                            continue;
                          seen = true;
                          if (options.mask_background && !regions[k].usable(at)) continue;
                          taken = true;
                          t.weight[k][i] = static_cast<float>(std::pow(facing, options.side_gamma));
                          t.colour[k][i] = sample(*photos[k], at);
                        }
                        background += seen && !taken ? 1 : 0;
                      });
  if (depth.size() > 1) match_side_colours(t);

  std::vector<Eigen::Vector3f> colour(n, Eigen::Vector3f::Zero());
  std::vector<char> done(n, 0);
  std::size_t covered = 0, seen = 0;
  for (std::size_t i = 0; i < n; ++i) {
    covered += t.covered[i] ? 1 : 0;
    const float sum = t.weight[0][i] + t.weight[1][i];
    if (sum <= 1e-4f) continue;
    colour[i] = (t.weight[0][i] * t.colour[0][i] + t.weight[1][i] * t.colour[1][i]) / sum;
    done[i] = 1;
    seen += t.covered[i] ? 1 : 0;
  }
  if (coverage) *coverage = covered ? static_cast<double>(seen) / covered : 0.0;
  if (refused) *refused = covered ? static_cast<double>(background) / covered : 0.0;
  fill_unseen(colour, done, t.w, t.h);
  render::Image out;
  out.width = t.w;
  out.height = t.h;
  out.pixels.resize(n * 3);
  for (std::size_t i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k)
      out.pixels[i * 3 + static_cast<std::size_t>(k)] =
          static_cast<std::uint8_t>(std::clamp(colour[i](k), 0.0f, 255.0f) + 0.5f);
  return out;
}

namespace {

// The template's landmark vertices, and a point's distance to a chain of them (a feature's
// contour: the brows, eyes, nose and lips the painted face draws).
struct TemplateMarks {
  explicit TemplateMarks(const PhotoTemplate& t) : tmpl(t), iod((at(36) - at(45)).norm()) {}
  Eigen::Vector3d at(int k) const {
    return Eigen::Vector3d(
        tmpl.rig.positions.row(tmpl.landmarks[static_cast<std::size_t>(k)]).cast<double>());
  }
  // The distance from p to the polyline of landmarks from..to (closed: back to `from`).
  double chain(const Eigen::Vector3d& p, int from, int to, bool closed) const {
    double d = std::numeric_limits<double>::max();
    for (int k = from; k < to; ++k) d = std::min(d, segment_distance(p, at(k), at(k + 1)));
    if (closed) d = std::min(d, segment_distance(p, at(to), at(from)));
    return d;
  }
  double brows(const Eigen::Vector3d& p) const {
    return std::min(chain(p, 17, 21, false), chain(p, 22, 26, false));
  }

  const PhotoTemplate& tmpl;
  const double iod;  // inter-ocular distance (outer eye corners)
};

// Per channel, the median of the photo's colours at the points a + t (b - a), t in `ts`, for the
// landmark pairs given; `fallback` when the photo shows none of them.
Eigen::Vector3d median_colour(const render::Image& photo,
                              const std::array<Eigen::Vector2d, kLandmarkCount>& lm,
                              const std::vector<std::pair<int, int>>& pairs,
                              const std::vector<double>& ts, const Eigen::Vector3d& fallback) {
  std::array<std::vector<double>, 3> v;
  for (const auto& [a, b] : pairs)
    for (double t : ts) {
      const Eigen::Vector2d at =
          lm[static_cast<std::size_t>(a)] +
          t * (lm[static_cast<std::size_t>(b)] - lm[static_cast<std::size_t>(a)]);
      if (at.x() < 0 || at.y() < 0 || at.x() > photo.width - 1 || at.y() > photo.height - 1)
        continue;
      const Eigen::Vector3f c = sample(photo, at);
      for (int k = 0; k < 3; ++k) v[static_cast<std::size_t>(k)].push_back(c(k));
    }
  if (v[0].empty()) return fallback;
  return {median(v[0]), median(v[1]), median(v[2])};
}

// The least n . (towards the camera) of the normals the light is fitted on.
constexpr double kFacing = 0.3;
// A photo's channel this bright (0..255) is taken as clipped (its light fit leaves it out).
constexpr double kSaturated = 250;

// Real spherical harmonics up to order 2 at unit normal n (unnormalised: the constant, the three
// linear terms, the five quadratic ones).
Eigen::Matrix<double, 9, 1> harmonics(const Eigen::Vector3d& n) {
  Eigen::Matrix<double, 9, 1> y;
  y << 1, n.x(), n.y(), n.z(), n.x() * n.y(), n.x() * n.z(), n.y() * n.z(),
      n.x() * n.x() - n.y() * n.y(), 3 * n.z() * n.z() - 1;
  return y;
}

}  // namespace

Eigen::Vector3d FaceLight::operator()(const Eigen::Vector3d& n) const {
  // The fit sees normals that face the camera (n . towards >= kFacing): one turned further away
  // takes the light of the nearest seen direction, not the harmonics' extrapolation.
  Eigen::Vector3d m = n;
  const double c = n.dot(towards);
  const Eigen::Vector3d across = n - c * towards;
  if (c < kFacing && across.norm() > 1e-9)
    m = across.normalized() * std::sqrt(1 - kFacing * kFacing) + kFacing * towards;
  return (coefficients * harmonics(m)).cwiseMax(0.25).cwiseMin(4.0);
}

FaceLight fit_face_light(const PhotoTemplate& tmpl, const render::Image& photo, const PhotoFit& fit,
                         const PhotoCamera& photo_camera, const render::Image& render,
                         const PhotoCamera& render_camera) {
  const rig::Rig& rig = tmpl.rig;
  const auto at = [](const rig::Positions& x, Eigen::Index v) {
    return Eigen::Vector3d(x.row(v).cast<double>().transpose());
  };
  const TemplateMarks marks(tmpl);
  const auto lm = [&](int k) { return marks.at(k); };
  const double iod = marks.iod;
  const auto inside = [](const render::Image& img, const Eigen::Vector2d& q) {
    return q.x() >= 0 && q.y() >= 0 && q.x() <= img.width - 1 && q.y() <= img.height - 1;
  };
  const rig::Positions normals = rig::vertex_normals(rig.positions, rig.triangles);
  const rig::Positions posed = posed_positions(tmpl, fit);
  const rig::Positions fit_normals = rig::vertex_normals(posed, rig.triangles);
  // The face: between the jaw's ends, from the chin to half an IOD above the brows, in front of
  // the jaw's ends (the scalp, ears and neck are hair, shadow or clothes in a real photo).
  const double left = std::min(lm(0).x(), lm(16).x()), right = std::max(lm(0).x(), lm(16).x());
  const double top = std::max(lm(19).y(), lm(24).y()) + 0.5 * iod, bottom = lm(8).y();
  const double back = std::min(lm(0).z(), lm(16).z());
  std::vector<Eigen::Matrix<double, 9, 1>> rows;
  std::vector<Eigen::Vector3d> ratios;
  std::vector<Eigen::Vector3d> seen;  // per channel 1, or 0 where the photo is clipped
  for (Eigen::Index v = 0; v < rig.vertex_count(); ++v) {
    if (!tmpl.skin[static_cast<std::size_t>(v)]) continue;
    const Eigen::Vector3d p = at(rig.positions, v), q = at(posed, v);
    if (p.x() < left || p.x() > right || p.y() < bottom || p.y() > top || p.z() < back) continue;
    // Away from the painted features (the photo's lie where the person's are, up to the fit's
    // error) and the nostrils.
    if (marks.brows(p) < 0.15 * iod ||
        std::min(marks.chain(p, 36, 41, true), marks.chain(p, 42, 47, true)) < 0.15 * iod ||
        marks.chain(p, 48, 59, true) < 0.15 * iod || marks.chain(p, 31, 35, false) < 0.1 * iod)
      continue;
    const Eigen::Vector3d n = at(normals, v).normalized(), m = at(fit_normals, v).normalized();
    if (n.dot(render_camera.towards(p)) < kFacing || m.dot(photo_camera.towards(q)) < kFacing)
      continue;
    const Eigen::Vector2d a = photo_camera.project(q), b = render_camera.project(p);
    if (!inside(photo, a) || !inside(render, b)) continue;
    const Eigen::Vector3f cp = sample(photo, a), cr = sample(render, b);
    rows.push_back(harmonics(n));
    ratios.push_back(((cp.cast<double>().array() + 2) / (cr.cast<double>().array() + 2)).matrix());
    // A channel the photo saturates says only that the light is at least this bright there.
    seen.push_back((cp.cast<double>().array() < kSaturated).cast<double>().matrix());
  }
  FaceLight out;
  out.coefficients(0, 0) = out.coefficients(1, 0) = out.coefficients(2, 0) = 1;
  const auto m = static_cast<Eigen::Index>(rows.size());
  if (m < 60) return out;  // too little of the face seen: the renderer's light stays
  Eigen::MatrixXd A(m, 9);
  Eigen::MatrixXd Y(m, 3), S(m, 3);
  for (Eigen::Index i = 0; i < m; ++i) {
    A.row(i) = rows[static_cast<std::size_t>(i)].transpose();
    Y.row(i) = ratios[static_cast<std::size_t>(i)].transpose();
    S.row(i) = seen[static_cast<std::size_t>(i)].transpose();
  }
  // Iteratively reweighted least squares, Tukey's biweight at 4.685 robust spreads (skin the
  // fit put where the photo shows brow, hair or background), a small ridge on the non-constant
  // terms (the face's normals cover half the sphere).
  for (int c = 0; c < 3; ++c) {
    if (S.col(c).sum() < 60) continue;  // too little of the face unclipped: the renderer's light
    Eigen::VectorXd w = S.col(c), x;
    for (int round = 0; round < 6; ++round) {
      Eigen::MatrixXd N = A.transpose() * w.asDiagonal() * A;
      for (int k = 1; k < 9; ++k) N(k, k) += 1e-3 * static_cast<double>(m);
      x = N.ldlt().solve(A.transpose() * w.asDiagonal() * Y.col(c));
      const Eigen::VectorXd r = Y.col(c) - A * x;
      std::vector<double> abs;
      for (Eigen::Index i = 0; i < m; ++i)
        if (S(i, c) > 0) abs.push_back(std::abs(r(i)));
      const double scale = 4.685 * std::max(1.4826 * median(abs), 0.01);
      for (Eigen::Index i = 0; i < m; ++i) {
        const double u = r(i) / scale;
        w(i) = S(i, c) > 0 && std::abs(u) < 1 ? (1 - u * u) * (1 - u * u) : 0;
      }
    }
    out.coefficients.row(c) = x.transpose();
  }
  out.samples = static_cast<int>(m);
  out.towards = render_camera.towards();
  return out;
}

render::Image paint_face_texture(const PhotoTemplate& tmpl, const render::Image& photo,
                                 const PhotoLandmarks& marks, int n, const FaceLight* light) {
  const auto& lm = marks.points;
  // The photo's colours where dlib's points say they are: skin across the cheeks, the nose's
  // ridge and the chin; brows along their points; lips halfway between the outer and the inner
  // lip contours.
  const Eigen::Vector3d skin = median_colour(
      photo, lm, {{2, 31}, {14, 35}, {4, 48}, {12, 54}, {57, 8}, {27, 30}, {3, 31}, {13, 35}},
      {0.3, 0.4, 0.5, 0.6, 0.7}, Eigen::Vector3d(200, 150, 125));
  std::vector<std::pair<int, int>> brow_pairs;
  for (int k = 17; k < 26; ++k)
    if (k != 21) brow_pairs.emplace_back(k, k + 1);
  const Eigen::Vector3d brow =
      median_colour(photo, lm, brow_pairs, {0.0, 0.25, 0.5, 0.75}, 0.4 * skin);
  const Eigen::Vector3d lips =
      median_colour(photo, lm,
                    {{49, 61},
                     {50, 61},
                     {51, 62},
                     {52, 63},
                     {53, 63},
                     {55, 65},
                     {56, 65},
                     {57, 66},
                     {58, 67},
                     {59, 67}},
                    {0.5}, skin.cwiseProduct(Eigen::Vector3d(0.85, 0.55, 0.6)));
  const TemplateMarks features(tmpl);
  const auto at = [&](int k) { return features.at(k); };
  const double iod = features.iod;
  const Eigen::Vector3d mouth = 0.5 * (at(48) + at(54));
  const double mouth_half = (at(54) - mouth).norm();
  render::Image img{2 * n, n, 3,
                    std::vector<std::uint8_t>(static_cast<std::size_t>(2 * n) * n * 3)};
  const auto put = [&](std::size_t i, const Eigen::Vector3d& c) {
    for (int k = 0; k < 3; ++k)
      img.pixels[i * 3 + static_cast<std::size_t>(k)] =
          static_cast<std::uint8_t>(std::clamp(std::lround(c(k)), 0L, 255L));
  };
  for (std::size_t i = 0; i < img.pixels.size() / 3; ++i) put(i, skin);
  for_each_skin_texel(
      tmpl, tmpl.rig.positions, 2 * n, n, 2,
      [&](std::size_t i, const Eigen::Vector3d& p, const Eigen::Vector3d& normal) {
        Eigen::Vector3d c = skin;
        if (features.brows(p) < 0.05 * iod && p.z() > at(27).z() - 0.5 * iod) c = brow;
        if (features.chain(p, 48, 59, true) < 0.05 * iod ||
            ((p - mouth).norm() < mouth_half && std::abs(p.y() - mouth.y()) < 0.12 * iod))
          c = lips;
        if (light) c = c.cwiseProduct((*light)(normal));
        put(i, c);
      });
  return img;
}

}  // namespace facecast::rigbuild
