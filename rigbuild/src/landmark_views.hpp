#pragma once
// The landmark views' cameras and their CPU z-buffers (docs/algorithms.md#landmarks), private to
// rigbuild: the same projection the renderer uses, so a pixel dlib marks is lifted onto the
// triangle the renderer drew there.
#include <optional>
#include <string>
#include <vector>

#include "facecast/render/renderer.hpp"
#include "facecast/rig/rig.hpp"
#include "facecast/rigbuild/geometry.hpp"

#include <dlib/image_processing/frontal_face_detector.h>

namespace dlib {
class shape_predictor;
}

namespace facecast::rigbuild {

/// dlib's 68-point shape predictor at `path`, read once per process (landmarks.cpp).
const dlib::shape_predictor& shape_predictor(const std::string& path);
/// dlib's HOG face detector, built once per process (landmarks.cpp): copy it to use it.
const dlib::frontal_face_detector& face_detector();

/// A camera in front of the head (render::frame_avatar with `margin`, face framing): the first,
/// wide view.
render::Camera wide_camera(const rig::Rig& head, float margin, int image_size);
/// `wide` turned to look at `centre` (the face dlib found in it) and zoomed by `zoom`.
render::Camera face_camera(const render::Camera& wide, const Eigen::Vector3d& centre, double zoom);
/// `camera` orbited by `yaw_deg` about the vertical axis through its target.
render::Camera orbit(const render::Camera& camera, double yaw_deg);

/// Per pixel of a square view: the nearest skin triangle and depths. Skin: `skin[t]` true.
class SkinBuffer {
 public:
  SkinBuffer(const Points& rest, const Triangles& faces, const std::vector<char>& skin,
             const render::Camera& camera, int size, double depth_tolerance);
  /// The skin point that the pixel position `at` (dlib's convention: pixel centres at whole
  /// numbers) shows: at `at` itself, or when the skin there is hidden (an eyeball, the far side
  /// seen through an eye hole) or absent, the nearest pixel within `search` pixels whose skin is
  /// in front. nullopt when there is none.
  std::optional<Eigen::RowVector3d> lift(const Eigen::Vector2d& at, double search) const;

 private:
  const Points& rest_;
  const Triangles& faces_;
  int size_;
  double tolerance_;
  Eigen::Matrix4d inverse_;  // of projection * view
  Eigen::Vector3d eye_;
  std::vector<float> depth_all_, depth_skin_;  // view distance; infinity where empty
  std::vector<int> skin_triangle_;             // -1 where no skin

  std::optional<Eigen::RowVector3d> hit(int triangle, const Eigen::Vector2d& pixel) const;
};

}  // namespace facecast::rigbuild
