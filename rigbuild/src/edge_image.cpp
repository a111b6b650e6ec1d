// A photo's brightness gradient for the photo fit's outline search (edge_image.hpp).
#include "edge_image.hpp"

#include <algorithm>
#include <cmath>

namespace facecast::rigbuild {

EdgeImage::EdgeImage(const render::Image& photo, double sigma)
    : w_(photo.width), h_(photo.height), gx_(size(), 0.0f), gy_(size(), 0.0f) {
  std::vector<float> grey(size()), tmp(size());
  const int channels = std::min(3, photo.channels);
  for (std::size_t i = 0; i < grey.size(); ++i) {
    float sum = 0;
    for (int k = 0; k < channels; ++k)
      sum +=
          photo.pixels[i * static_cast<std::size_t>(photo.channels) + static_cast<std::size_t>(k)];
    grey[i] = sum / static_cast<float>(channels);
  }
  const int r = static_cast<int>(std::ceil(3 * sigma));
  std::vector<float> kernel(static_cast<std::size_t>(2 * r + 1));
  float total = 0;
  for (int i = -r; i <= r; ++i)
    total += kernel[static_cast<std::size_t>(i + r)] =
        static_cast<float>(std::exp(-0.5 * i * i / (sigma * sigma)));
  for (auto& k : kernel) k /= total;
  const auto blur = [&](const std::vector<float>& in, std::vector<float>& out, int dx, int dy) {
    for (int y = 0; y < h_; ++y)
      for (int x = 0; x < w_; ++x) {
        float sum = 0;
        for (int i = -r; i <= r; ++i)
          sum += kernel[static_cast<std::size_t>(i + r)] *
                 in[index(std::clamp(x + i * dx, 0, w_ - 1), std::clamp(y + i * dy, 0, h_ - 1))];
        out[index(x, y)] = sum;
      }
  };
  blur(grey, tmp, 1, 0);
  blur(tmp, grey, 0, 1);
  for (int y = 1; y + 1 < h_; ++y)
    for (int x = 1; x + 1 < w_; ++x) {
      gx_[index(x, y)] = 0.5f * (grey[index(x + 1, y)] - grey[index(x - 1, y)]);
      gy_[index(x, y)] = 0.5f * (grey[index(x, y + 1)] - grey[index(x, y - 1)]);
    }
}

Eigen::Vector2d EdgeImage::gradient(const Eigen::Vector2d& at) const {
  if (!(at.x() >= 0 && at.y() >= 0 && at.x() <= w_ - 1 && at.y() <= h_ - 1))
    return Eigen::Vector2d::Zero();
  const int x0 = std::min(static_cast<int>(at.x()), w_ - 2),
            y0 = std::min(static_cast<int>(at.y()), h_ - 2);
  const double fx = at.x() - x0, fy = at.y() - y0;
  const auto lerp = [&](const std::vector<float>& g) {
    return (1 - fy) * ((1 - fx) * g[index(x0, y0)] + fx * g[index(x0 + 1, y0)]) +
           fy * ((1 - fx) * g[index(x0, y0 + 1)] + fx * g[index(x0 + 1, y0 + 1)]);
  };
  return {lerp(gx_), lerp(gy_)};
}

}  // namespace facecast::rigbuild
