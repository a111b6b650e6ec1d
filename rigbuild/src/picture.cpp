#include "facecast/rigbuild/picture.hpp"

#include <OpenImageIO/imageio.h>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "facecast/core/error.hpp"

namespace facecast::rigbuild {
namespace {

struct Canvas {
  int w, h;
  std::vector<float> rgb, depth;
  Canvas(int width, int height)
      : w(width),
        h(height),
        rgb(static_cast<std::size_t>(3 * w * h), 1.0f),
        depth(static_cast<std::size_t>(w * h), -1e30f) {}
  void put(int x, int y, const Eigen::Vector3f& c, float alpha = 1.0f) {
    if (x < 0 || y < 0 || x >= w || y >= h) return;
    float* p = &rgb[static_cast<std::size_t>(3 * (y * w + x))];
    for (int k = 0; k < 3; ++k) p[k] = (1 - alpha) * p[k] + alpha * c[k];
  }
};

// View: screen x = dot(p, right), y = dot(p, up), depth = dot(p, toward viewer).
struct View {
  Eigen::Vector3f right, up, toward;
  int x0;
};

void draw(Canvas& cv, const View& v, const rig::Rig& rig, const rig::Positions& p,
          const std::vector<VirtualEdge>& edges, const std::vector<char>& marked,
          const Eigen::Vector3f& lo, float scale, bool see_through) {
  const int size = cv.h;
  auto project = [&](int i) {
    const Eigen::Vector3f q = p.row(i).transpose() - lo;
    return Eigen::Vector3f(v.x0 + q.dot(v.right) * scale, size - 1 - q.dot(v.up) * scale,
                           q.dot(v.toward));
  };
  // Calls fn(x, y, depth) for every pixel that triangle f covers in this view.
  const auto raster = [&](int f, auto&& fn) {
    const Eigen::Vector3f a = project(rig.triangles(f, 0)), b = project(rig.triangles(f, 1)),
                          c = project(rig.triangles(f, 2));
    const int xmin = std::max(v.x0, static_cast<int>(std::floor(std::min({a.x(), b.x(), c.x()}))));
    const int xmax =
        std::min(v.x0 + size - 1, static_cast<int>(std::ceil(std::max({a.x(), b.x(), c.x()}))));
    const int ymin = std::max(0, static_cast<int>(std::floor(std::min({a.y(), b.y(), c.y()}))));
    const int ymax =
        std::min(size - 1, static_cast<int>(std::ceil(std::max({a.y(), b.y(), c.y()}))));
    const float area = (b.x() - a.x()) * (c.y() - a.y()) - (c.x() - a.x()) * (b.y() - a.y());
    if (std::abs(area) < 1e-12f) return;
    for (int y = ymin; y <= ymax; ++y) {
      for (int x = xmin; x <= xmax; ++x) {
        const float px = x + 0.5f, py = y + 0.5f;
        const float w0 = ((b.x() - px) * (c.y() - py) - (c.x() - px) * (b.y() - py)) / area;
        const float w1 = ((c.x() - px) * (a.y() - py) - (a.x() - px) * (c.y() - py)) / area;
        const float w2 = 1 - w0 - w1;
        if (w0 < 0 || w1 < 0 || w2 < 0) continue;
        fn(x, y, w0 * a.z() + w1 * b.z() + w2 * c.z());
      }
    }
  };
  const auto is_marked = [&](int f) {
    return !marked.empty() && marked[static_cast<std::size_t>(f)];
  };
  const Eigen::Vector3f red(0.9f, 0.05f, 0.05f);
  // Triangles: flat Lambert shading with a z-buffer; marked ones red.
  for (int f = 0; f < rig.triangle_count(); ++f) {
    const Eigen::Vector3f n = (p.row(rig.triangles(f, 1)) - p.row(rig.triangles(f, 0)))
                                  .cross(p.row(rig.triangles(f, 2)) - p.row(rig.triangles(f, 0)))
                                  .normalized()
                                  .transpose();
    const float shade = 0.25f + 0.7f * std::abs(n.dot((v.toward + 0.4f * v.up).normalized()));
    const Eigen::Vector3f colour = is_marked(f) ? Eigen::Vector3f(red * (0.5f + 0.5f * shade))
                                                : Eigen::Vector3f(Eigen::Vector3f::Constant(shade));
    raster(f, [&](int x, int y, float z) {
      float& d = cv.depth[static_cast<std::size_t>(y * cv.w + x)];
      if (z <= d) return;
      d = z;
      cv.put(x, y, colour);
    });
  }
  // Marked triangles behind the surface (inside the mouth, under a lid): pale red through it.
  const float eps = 0.002f / scale * size;
  if (see_through) {
    for (int f = 0; f < rig.triangle_count(); ++f) {
      if (!is_marked(f)) continue;
      raster(f, [&](int x, int y, float z) {
        if (z < cv.depth[static_cast<std::size_t>(y * cv.w + x)] - eps) cv.put(x, y, red, 0.35f);
      });
    }
  }
  // Virtual edges: red where visible, pale red where hidden.
  for (const auto& e : edges) {
    const Eigen::Vector3f a = project(e.a), b = project(e.b);
    const int steps = std::max(1, static_cast<int>((b - a).head<2>().norm() * 2));
    for (int s = 0; s <= steps; ++s) {
      const Eigen::Vector3f q = a + (b - a) * (static_cast<float>(s) / steps);
      const int x = static_cast<int>(q.x()), y = static_cast<int>(q.y());
      if (x < v.x0 || x >= v.x0 + size || y < 0 || y >= size) continue;
      const bool visible = q.z() >= cv.depth[static_cast<std::size_t>(y * cv.w + x)] - eps;
      if (!visible && !see_through) continue;
      cv.put(x, y, red, visible ? 1.0f : 0.45f);
    }
  }
}

void write_views(const std::filesystem::path& png, const rig::Rig& rig,
                 const rig::Positions& positions, const std::vector<VirtualEdge>& edges,
                 const std::vector<char>& marked, const PictureOptions& options) {
  const int size = options.size;
  Canvas cv(2 * size, size);
  // Frame the front of the face: the bounding box of the vertices in the front half (z above the
  // middle), so the back of the head and the neck do not shrink the face.
  const Eigen::Vector3f lo_all = positions.colwise().minCoeff(),
                        hi_all = positions.colwise().maxCoeff();
  const float zmid = 0.5f * (lo_all.z() + hi_all.z());
  Eigen::Vector3f lo = hi_all, hi = lo_all;
  for (Eigen::Index i = 0; i < positions.rows(); ++i) {
    if (positions(i, 2) < zmid) continue;
    lo = lo.cwiseMin(positions.row(i).transpose());
    hi = hi.cwiseMax(positions.row(i).transpose());
  }
  const float extent = std::max({hi.x() - lo.x(), hi.y() - lo.y(), hi_all.z() - zmid}) * 1.05f;
  const float scale = static_cast<float>(size) / extent;
  const Eigen::Vector3f center = 0.5f * (lo + hi);
  const Eigen::Vector3f origin(center.x() - 0.5f * extent, center.y() - 0.5f * extent, zmid);
  draw(cv, View{Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitY(), Eigen::Vector3f::UnitZ(), 0},
       rig, positions, edges, marked, origin, scale, options.see_through);
  // Right side of the subject (-x), looking along +x; the face points to the left of the image.
  draw(cv,
       View{-Eigen::Vector3f::UnitZ(), Eigen::Vector3f::UnitY(), -Eigen::Vector3f::UnitX(), size},
       rig, positions, edges, marked, Eigen::Vector3f(lo_all.x(), origin.y(), hi_all.z()), scale,
       options.see_through);

  std::vector<unsigned char> bytes(cv.rgb.size());
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    bytes[i] = static_cast<unsigned char>(std::clamp(cv.rgb[i], 0.0f, 1.0f) * 255.0f + 0.5f);
  }
  if (png.has_parent_path()) std::filesystem::create_directories(png.parent_path());
  const std::string tmp = png.string() + ".tmp.png";  // written, then renamed: never half a file
  auto out = OIIO::ImageOutput::create(tmp);
  if (!out)
    throw Error(png.string() + ": cannot write PNG: " + OIIO::geterror(), ErrorCode::kInternal);
  OIIO::ImageSpec spec(cv.w, cv.h, 3, OIIO::TypeDesc::UINT8);
  if (!out->open(tmp, spec) || !out->write_image(OIIO::TypeDesc::UINT8, bytes.data()) ||
      !out->close()) {
    std::filesystem::remove(tmp);
    throw Error(png.string() + ": cannot write PNG: " + out->geterror(), ErrorCode::kInternal);
  }
  std::filesystem::rename(tmp, png);
}

}  // namespace

void write_virtual_edge_picture(const std::filesystem::path& png, const rig::Rig& rig,
                                const rig::Positions& positions,
                                const std::vector<VirtualEdge>& edges,
                                const PictureOptions& options) {
  write_views(png, rig, positions, edges, {}, options);
}

void write_crossing_picture(const std::filesystem::path& png, const rig::Rig& rig,
                            const rig::Positions& positions,
                            const std::vector<std::pair<int, int>>& pairs,
                            const PictureOptions& options) {
  std::vector<char> marked(static_cast<std::size_t>(rig.triangle_count()), 0);
  for (const auto& [a, b] : pairs) {
    marked.at(static_cast<std::size_t>(a)) = 1;
    marked.at(static_cast<std::size_t>(b)) = 1;
  }
  write_views(png, rig, positions, {}, marked, options);
}

}  // namespace facecast::rigbuild
