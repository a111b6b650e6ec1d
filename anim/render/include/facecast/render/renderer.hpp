#pragma once
// Headless rendering of a rig with EGL and OpenGL 3.3 core.
//
// The rig (neutral positions and normals, triangles grouped by material, and every blendshape's
// position and normal deltas) is uploaded once per GL context; a frame sends only the weights and
// the vertex shader blends. Normal deltas are precomputed per shape (the shape's area-weighted
// normals minus the neutral's), so blended normals follow the shapes.
//
// EGL: the device platform (EGL_EXT_platform_device, what NVIDIA's headless driver needs) is tried
// first, then Mesa's surfaceless platform, then the default display; FACECAST_EGL_PLATFORM=device
// or surfaceless forces one. No window system is needed.
//
// Threads: a Renderer is safe to share. It owns a small pool of GL contexts (each with its own
// copy of the uploaded rig and framebuffers); render() takes a free context, makes it current on
// the calling thread, draws, reads the pixels back, releases the context and returns it to the
// pool. Sessions on worker threads therefore never share a context at the same time, and at most
// RenderOptions::contexts contexts exist (further callers wait for a free one).
#include <Eigen/Core>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "facecast/anim/animation.hpp"
#include "facecast/anim/rig.hpp"
#include "facecast/render/image.hpp"

namespace facecast::render {

/// Defaults mirrored in configs/anim/render.json.
struct RenderOptions {
  int width = 640;
  int height = 480;
  int msaa = 0;             // samples per pixel (4 is smoother, about 3x slower on llvmpipe)
  float fov_y_deg = 20.0f;  // vertical field of view
  float margin = 1.12f;     // the framed face box is scaled by this
  Eigen::Vector3f background{0.16f, 0.17f, 0.20f};  // sRGB 0..1
  int contexts = 2;                                 // size of the context pool
};

/// RenderOptions from configs/anim/render.json; throws Error naming the field when invalid.
RenderOptions load_render_options();

/// A look-at camera in rig coordinates.
struct Camera {
  Eigen::Vector3f eye{0, 0, 1};
  Eigen::Vector3f target{0, 0, 0};
  Eigen::Vector3f up{0, 1, 0};
  float fov_y_deg = 20.0f;
  float near_plane = 0.1f, far_plane = 100.0f;
};

/// A camera in front of the face (+Z) that frames the front half of the rig's largest connected
/// component (the skin), seen at the given aspect ratio.
Camera frame_face(const anim::Rig& rig, float aspect, const RenderOptions& options = {});

class Renderer {
 public:
  /// Prepares the rig (normal deltas, packed morph data); GL contexts are made on first use.
  /// Throws facecast::Error for an invalid rig or more than 256 shapes.
  explicit Renderer(const anim::Rig& rig, RenderOptions options = {});
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  const RenderOptions& options() const;
  const Camera& camera() const;
  void set_camera(const Camera& camera);

  /// Renders one frame with one weight per rig shape (in rig order). Thread-safe. Throws
  /// facecast::Error on a size mismatch, or naming the EGL/GL call that failed.
  Image render(std::span<const float> weights) const;
  /// The same with the head turned by `head` about the neck (idle head motion).
  Image render(std::span<const float> weights, const anim::HeadPose& head) const;

  /// Which EGL platform and GL renderer are in use (creates the first context if needed).
  std::string backend() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Parses "name=value,name=value" (spaces allowed around items); throws facecast::Error naming the
/// bad item.
std::vector<std::pair<std::string, float>> parse_weight_list(std::string_view text);
/// One weight per rig shape from name/value pairs; an unknown name throws facecast::Error.
std::vector<float> weights_for(const anim::Rig& rig,
                               const std::vector<std::pair<std::string, float>>& named);

}  // namespace facecast::render
