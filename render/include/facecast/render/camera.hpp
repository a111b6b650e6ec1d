#pragma once
// The camera and its view-projection: one definition for the renderer (float, on the GPU) and for
// whatever projects rig points the way the renderer draws them (the rig builder's landmark views,
// in double). OpenGL conventions: the camera looks down -Z of its view space, clip space is
// [-1, 1] on every axis.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace facecast::render {

/// A perspective camera: eye, target, up, vertical field of view, clip planes.
struct Camera {
  Eigen::Vector3f eye{0, 0, 1};
  Eigen::Vector3f target{0, 0, 0};
  Eigen::Vector3f up{0, 1, 0};
  float fov_y_deg = 20.0f;
  float near_plane = 0.1f, far_plane = 100.0f;
};

/// OpenGL's perspective projection times a look-at view, in `T` (float: what the renderer draws
/// with; double: the same projection for measurements). clip = view_projection(c, aspect) * world.
template <typename T>
Eigen::Matrix<T, 4, 4> view_projection(const Camera& c, T aspect) {
  using V3 = Eigen::Matrix<T, 3, 1>;
  using M4 = Eigen::Matrix<T, 4, 4>;
  const T t = T(1) / std::tan(T(0.5) * (T(c.fov_y_deg) * T(3.14159265358979323846) / T(180)));
  const T n = c.near_plane, f = c.far_plane;
  M4 p = M4::Zero();
  p(0, 0) = t / aspect;
  p(1, 1) = t;
  p(2, 2) = (f + n) / (n - f);
  p(2, 3) = 2 * f * n / (n - f);
  p(3, 2) = -1;
  const V3 eye = c.eye.cast<T>();
  const V3 fw = (c.target.cast<T>() - eye).normalized();
  const V3 s = fw.cross(c.up.cast<T>()).normalized();
  const V3 u = s.cross(fw);
  M4 v = M4::Identity();
  v.template block<1, 3>(0, 0) = s.transpose();
  v.template block<1, 3>(1, 0) = u.transpose();
  v.template block<1, 3>(2, 0) = -fw.transpose();
  v(0, 3) = -s.dot(eye);
  v(1, 3) = -u.dot(eye);
  v(2, 3) = fw.dot(eye);
  return p * v;
}

}  // namespace facecast::render
