#pragma once
// The photo fit's edge image (photo_fit.cpp's outline search).
#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "facecast/render/image.hpp"

namespace facecast::rigbuild {

// A photo's brightness gradient, where the outline search looks for edges: grey (the channels'
// mean) blurred by a Gaussian (so that the texture's and the sensor's noise make no edges),
// central differences; grey levels per pixel.
class EdgeImage {
 public:
  EdgeImage(const render::Image& photo, double sigma);
  int width() const { return w_; }
  int height() const { return h_; }
  // The gradient at `at` (bilinear; zero outside the photo).
  Eigen::Vector2d gradient(const Eigen::Vector2d& at) const;

 private:
  std::size_t size() const { return static_cast<std::size_t>(w_) * static_cast<std::size_t>(h_); }
  std::size_t index(int x, int y) const {
    return static_cast<std::size_t>(y) * static_cast<std::size_t>(w_) + static_cast<std::size_t>(x);
  }
  int w_, h_;
  std::vector<float> gx_, gy_;
};

}  // namespace facecast::rigbuild
