// The photo avatar's texture: every skin texel's surface point looked up in each photo where a
// depth test through the fitted camera shows it, the colours blended by the normal (seed 003,
// section 5: k = |N.front| / (|N.front| + |N.side|)), the side photo colour-matched to the front
// first, unseen texels filled from the nearest seen one. See docs/algorithms.md#photo-avatar.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>

#include "facecast/core/error.hpp"
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

// Texels without colour take the nearest coloured texel's (breadth-first over the texture).
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

}  // namespace

DepthBuffer::DepthBuffer(const rig::Positions& p, const Triangles& tri, const OrthoCamera& cam,
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
                                 const PhotoOptions& options, double* coverage) {
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
  const OrthoCamera* cams[2] = {&fit.front, fit.side ? &*fit.side : nullptr};
  const double iod = (fit.positions.row(tmpl.landmarks[36]) - fit.positions.row(tmpl.landmarks[45]))
                         .cast<double>()
                         .norm();
  std::vector<DepthBuffer> depth;
  for (int k = 0; k < 2; ++k)
    if (photos[k] && cams[k])
      depth.emplace_back(fit.positions, rig.triangles, *cams[k], photos[k]->width,
                         photos[k]->height);
  for_each_skin_texel(tmpl, fit.positions, t.w, t.h, tiles,
                      [&](std::size_t i, const Eigen::Vector3d& p, const Eigen::Vector3d& nrm) {
                        t.covered[i] = 1;
                        for (std::size_t k = 0; k < depth.size(); ++k) {
                          const double facing = nrm.dot(cams[k]->towards());
                          const Eigen::Vector2d at = cams[k]->project(p);
                          if (facing <= 0 || !depth[k].visible(at, cams[k]->depth(p), 0.02 * iod))
                            continue;
                          t.weight[k][i] = static_cast<float>(std::pow(facing, options.side_gamma));
                          t.colour[k][i] = sample(*photos[k], at);
                        }
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

}  // namespace facecast::rigbuild
