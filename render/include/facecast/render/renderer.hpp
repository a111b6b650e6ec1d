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

#include "facecast/render/camera.hpp"
#include "facecast/render/image.hpp"
#include "facecast/rig/motion.hpp"
#include "facecast/rig/rig.hpp"
#include "facecast/rig/spring_sim.hpp"

namespace facecast::render {

/// What the automatic camera frames: the face (the front of the head), head and shoulders, or the
/// whole avatar.
enum class Framing { kFace, kBust, kFull };

/// Defaults mirrored in configs/render/render.json.
struct RenderOptions {
  int width = 640;
  int height = 480;
  int msaa = 0;            // samples per pixel (4 is smoother, about 3x slower on llvmpipe)
  bool trilinear = false;  // blend mipmap levels (smoother; about 25 % more CPU on llvmpipe)
  // The sRGB output curve fitted by three square roots (within 0.25 of an 8-bit level; about 5 %
  // less CPU per textured frame on llvmpipe than pow). Off: pow, as the landmark detector's
  // measuring renders need it (their stored biases move with the renders' last bits).
  bool fast_srgb = true;
  float fov_y_deg = 20.0f;  // vertical field of view
  float margin = 1.12f;     // the framed box is scaled by this
  Framing framing = Framing::kFace;
  Eigen::Vector3f background{0.16f, 0.17f, 0.20f};  // sRGB 0..1
  std::string background_image;                     // an image file covering the frame, or ""
  int contexts = 2;                                 // size of the context pool
  // Level of detail: the mesh is also drawn simplified, at most this many pixels away from the
  // neutral at the framed distance (0: always the full mesh). Tiny triangles cost llvmpipe whole
  // 4x4 blocks of fragment shading each.
  float lod_pixels = 0.5f;
};

/// RenderOptions from configs/render/render.json; throws Error naming the field when invalid.
RenderOptions load_render_options();

/// A camera in front of the avatar (+Z) framing what options.framing asks for, at the given
/// aspect ratio. The face is the front half of the head: the connected component that the most
/// shape vertices move (the largest component when no shape moves any), narrowed to the region the
/// shapes move when that component is a whole body; with a skeleton and no shapes, the vertices
/// skinned to the head joint. Bust adds the shoulders below it; full is the whole rig.
Camera frame_avatar(const rig::Rig& rig, float aspect, const RenderOptions& options = {});

class Renderer {
 public:
  /// Prepares the rig (normal deltas, packed morph data); GL contexts are made on first use.
  /// Throws facecast::Error for an invalid rig or more than 256 shapes.
  explicit Renderer(const rig::Rig& rig, RenderOptions options = {});
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  const RenderOptions& options() const;
  const Camera& camera() const;
  void set_camera(const Camera& camera);

  /// Renders one frame with one weight per rig shape (in rig order). Thread-safe. Throws
  /// facecast::Error on a size mismatch, or naming the EGL/GL call that failed.
  Image render(std::span<const float> weights) const;
  /// The same in a body pose: a skinned avatar's joints turned as rig::body_turns says (the head
  /// through the neck and the head, breath, lean and shrug through the chest, spine and
  /// shoulders); a rig without a skeleton turns whole with the head about a pivot low in its
  /// bounds. `springs`: the spring joints' turns this frame (a SpringSim from spring_sim(),
  /// advanced in frame order); none: the springs hang as at rest.
  Image render(std::span<const float> weights, const rig::BodyPose& pose,
               const rig::JointTurns& springs = {}) const;

  /// A simulation of the rig's spring bones as this renderer draws them (empty without any):
  /// one per stream of frames, advanced in frame order, its turns passed to render().
  rig::SpringSim spring_sim() const;

  /// Creates every context of the pool now (each uploads the rig: about a second for a rig with
  /// a dozen 1024x1024 textures on llvmpipe), so that the first frames of concurrent streams do
  /// not wait for it. Throws like render().
  void create_contexts() const;

  /// Triangles of the full mesh and of its level of detail (RenderOptions::lod_pixels; the same
  /// count without one).
  std::pair<std::size_t, std::size_t> triangle_counts() const;

  /// Which EGL platform and GL renderer are in use (creates the first context if needed).
  std::string backend() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Opens the process's EGL displays now, which loads the GL driver (a few tenths of a second with
/// Mesa's llvmpipe), rather than at the first frame: a caller can do it on another thread while it
/// does other work. Throws like Renderer::render().
void open_displays();

/// Parses "name=value,name=value" (spaces allowed around items); throws facecast::Error naming the
/// bad item.
std::vector<std::pair<std::string, float>> parse_weight_list(std::string_view text);
/// One weight per rig shape from name/value pairs; an unknown name throws facecast::Error.
std::vector<float> weights_for(const rig::Rig& rig,
                               const std::vector<std::pair<std::string, float>>& named);

}  // namespace facecast::render
