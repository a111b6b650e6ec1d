// The renderer: rig data packed once on the CPU (gpu_rig.cpp), uploaded once per pooled GL
// context; each frame blends the shapes with non-zero weights on the CPU and streams the mesh's
// positions and normals (llvmpipe runs vertex shaders on one thread: a per-vertex loop over
// every shape there cost more than the rasterization).
#include "facecast/render/renderer.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <mutex>
#include <optional>

#include "egl.hpp"
#include "facecast/core/error.hpp"
#include "gpu_rig.hpp"
#include "shaders.hpp"

namespace facecast::render {
namespace {

using detail::check_gl;
using detail::PackedRig;

// The width of a pixel at the camera's target, in rig units.
float pixel_size(const Camera& cam, int height) {
  return 2.0f * (cam.eye - cam.target).norm() *
         std::tan(0.5f * cam.fov_y_deg * 3.14159265f / 180.0f) / static_cast<float>(height);
}

// The body pose as the vertex shader takes it: detail::BodySkin's palette, column-major 4x4
// matrices.
struct Palette {
  std::vector<Eigen::Matrix4f> entries;
  int head = 1;  // the head's entry
};

Palette palette(const detail::BodySkin& b, const rig::BodyPose& pose,
                const rig::JointTurns& springs) {
  Palette out{std::vector<Eigen::Matrix4f>(b.group_joint.size(), Eigen::Matrix4f::Identity()),
              b.head_group};
  if (!b.skinned) {
    // Yaw about +Y, then pitch about +X, then roll about +Z, about the pivot.
    const Eigen::Affine3f m =
        Eigen::Translation3f(b.pivot) * Eigen::AngleAxisf(pose.roll, Eigen::Vector3f::UnitZ()) *
        Eigen::AngleAxisf(pose.pitch, Eigen::Vector3f::UnitX()) *
        Eigen::AngleAxisf(pose.yaw, Eigen::Vector3f::UnitY()) * Eigen::Translation3f(-b.pivot);
    out.entries[1] = m.matrix();
    return out;
  }
  rig::JointTurns turns = rig::body_turns(b.joints, b.skeleton, pose);
  const auto nj = static_cast<int>(b.skeleton.parent.size());
  for (const auto& turn : springs)  // after the body's: a spring's turn is the joint's own
    if (turn.first >= 0 && turn.first < nj) turns.push_back(turn);
  const auto motion = rig::compose_turns(b.skeleton, turns);
  for (std::size_t g = 1; g < b.group_joint.size(); ++g)
    out.entries[g] = motion[static_cast<std::size_t>(b.group_joint[g])].matrix();
  return out;
}

// One pooled GL context with its own copy of the rig and its framebuffers.
struct Slot {
  detail::Context context;
  enum {
    kBlendedBuffer,
    kUvBuffer,
    kTangentBuffer,
    kSkinBuffer,
    kSkinWeightBuffer,
    kIndexBuffer,
    kBufferCount
  };
  GLuint vao = 0, buffers[kBufferCount] = {};
  std::vector<float> mesh;  // this frame's mesh, detail::kBlendedStride floats per vertex
  GLuint background_program = 0, background_vao = 0, background_tex = 0;
  float background_scale[2] = {1, 1};
  std::vector<GLuint> textures;  // PackedRig::textures
  GLuint white_tex = 0;          // bound to the slots a material leaves empty
  GLuint fbo = 0, color_rb = 0, depth_rb = 0, resolve_fbo = 0, resolve_rb = 0;
  // The avatar's program in one variant per kind of material (detail::ProgramVariant).
  struct Program {
    GLuint id = 0;
    GLint mvp = -1, palette = -1, eye = -1, base_color = -1, emissive = -1, metallic_roughness = -1,
          normal_scale = -1, occlusion_strength = -1, blend = -1, alpha_cutoff = -1, uv = -1,
          unlit = -1, toon = -1, shade = -1, rim = -1, toon_params = -1;
  };
  std::vector<Program> programs;
  std::vector<std::size_t> program_of;  // per material, into `programs`
  GLint background_scale_at = -1;
  int width = 0, height = 0, samples = 0;
  // glReadPixels' rows come bottom-up; flipped per frame (GL_MESA_pack_invert is slower).
  std::vector<std::uint8_t> flipped;
  std::string renderer_name;

  Slot(std::size_t index, const PackedRig& p, const RenderOptions& o, const Image* background)
      : context(index) {
    context.make_current();
    try {
      init(p, o);
      if (background) init_background(*background);
    } catch (...) {
      context.release();
      throw;
    }
    context.release();
  }

  void init(const PackedRig& p, const RenderOptions& o) {
    glGetError();
    renderer_name = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
    std::vector<detail::ProgramVariant> variants;
    for (const auto& m : p.materials) {
      detail::ProgramVariant v;
      v.alpha_mask = m.alpha_mode == rig::AlphaMode::kMask;
      v.fast_srgb = o.fast_srgb;
      v.influences = p.body.influences;
      v.palette_size = static_cast<int>(p.body.group_joint.size());
      v.occlusion_source = m.occlusion;
      for (int slot = 0; slot < detail::kSlotCount; ++slot)
        if (m.texture[slot] >= 0) {
          v.textures |= 1u << slot;
          v.uv_transform |= m.uv_transform[slot] != Eigen::Matrix3f::Identity();
        }
      const auto found = std::find(variants.begin(), variants.end(), v);
      program_of.push_back(static_cast<std::size_t>(found - variants.begin()));
      if (found == variants.end()) {
        variants.push_back(v);
        programs.push_back(link_program(v));
      }
    }

    glGenVertexArrays(1, &vao);
    glBindVertexArray(vao);
    glGenBuffers(kBufferCount, buffers);
    const auto attribute = [&](int buffer, int index, const std::vector<float>& data, int size) {
      glBindBuffer(GL_ARRAY_BUFFER, buffers[buffer]);
      glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(data.size() * sizeof(float)),
                   data.data(), GL_STATIC_DRAW);
      glVertexAttribPointer(static_cast<GLuint>(index), size, GL_FLOAT, GL_FALSE, 0, nullptr);
      glEnableVertexAttribArray(static_cast<GLuint>(index));
    };
    attribute(kUvBuffer, detail::kUvAttribute, p.uvs, 2);
    attribute(kSkinBuffer, detail::kSkinAttribute, p.skin_groups, 4);
    attribute(kSkinWeightBuffer, detail::kSkinWeightAttribute, p.skin_weights, 4);
    if (p.tangents.empty())
      glVertexAttrib4f(detail::kTangentAttribute, 1, 0, 0, 1);
    else
      attribute(kTangentBuffer, detail::kTangentAttribute, p.tangents, 4);
    // Positions and normals interleaved in one buffer that draw() rewrites each frame.
    glBindBuffer(GL_ARRAY_BUFFER, buffers[kBlendedBuffer]);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(p.neutral.size() * sizeof(float)),
                 p.neutral.data(), GL_STREAM_DRAW);
    constexpr GLsizei stride = detail::kBlendedStride * sizeof(float);
    glVertexAttribPointer(detail::kPositionAttribute, 3, GL_FLOAT, GL_FALSE, stride, nullptr);
    glVertexAttribPointer(detail::kNormalAttribute, 3, GL_FLOAT, GL_FALSE, stride,
                          reinterpret_cast<const void*>(3 * sizeof(float)));
    glEnableVertexAttribArray(detail::kPositionAttribute);
    glEnableVertexAttribArray(detail::kNormalAttribute);
    static_assert(sizeof(p.indices[0]) == sizeof(GLuint));
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, buffers[kIndexBuffer]);
    glBufferData(GL_ELEMENT_ARRAY_BUFFER,
                 static_cast<GLsizeiptr>(p.indices.size() * sizeof(GLuint)), p.indices.data(),
                 GL_STATIC_DRAW);
    check_gl("glBufferData (mesh)");

    upload_textures(p, o.trilinear);
    init_framebuffers(o);
  }

  static Program link_program(const detail::ProgramVariant& v) {
    Program g;
    g.id = detail::link_program(v);
    const auto at = [&](const char* name) { return glGetUniformLocation(g.id, name); };
    g = {g.id,
         at("u_mvp"),
         at("u_palette"),
         at("u_eye"),
         at("u_base_color"),
         at("u_emissive"),
         at("u_metallic_roughness"),
         at("u_normal_scale"),
         at("u_occlusion_strength"),
         at("u_blend"),
         at("u_alpha_cutoff"),
         at("u_uv"),
         at("u_unlit"),
         at("u_toon"),
         at("u_shade"),
         at("u_rim"),
         at("u_toon_params")};
    glUseProgram(g.id);
    GLint units[detail::kSlotCount];
    for (int i = 0; i < detail::kSlotCount; ++i) units[i] = detail::kFirstMaterialUnit + i;
    glUniform1iv(at("u_textures"), detail::kSlotCount, units);
    check_gl("glLinkProgram");
    return g;
  }

  // Mipmapped; `trilinear` blends the two nearest levels, otherwise the nearest level is filtered
  // bilinearly (half the texel fetches: llvmpipe renders the textured avatar in about 20 % less
  // CPU time).
  static GLuint upload_texture(int w, int h, const std::uint8_t* rgba, bool srgb, bool repeat_s,
                               bool repeat_t, bool nearest, bool trilinear = false) {
    GLuint t = 0;
    glGenTextures(1, &t);
    glBindTexture(GL_TEXTURE_2D, t);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexImage2D(GL_TEXTURE_2D, 0, srgb ? GL_SRGB8_ALPHA8 : GL_RGBA8, w, h, 0, GL_RGBA,
                 GL_UNSIGNED_BYTE, rgba);
    glGenerateMipmap(GL_TEXTURE_2D);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER,
                    nearest     ? GL_NEAREST_MIPMAP_NEAREST
                    : trilinear ? GL_LINEAR_MIPMAP_LINEAR
                                : GL_LINEAR_MIPMAP_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, nearest ? GL_NEAREST : GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, repeat_s ? GL_REPEAT : GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, repeat_t ? GL_REPEAT : GL_CLAMP_TO_EDGE);
    return t;
  }

  // glTF's UV origin is the image's top-left, which is where the rows start: no flip.
  void upload_textures(const PackedRig& p, bool trilinear) {
    glActiveTexture(GL_TEXTURE0 + detail::kFirstMaterialUnit);
    const std::uint8_t white[4] = {255, 255, 255, 255};
    white_tex = upload_texture(1, 1, white, false, true, true, true);
    for (const auto& t : p.textures)
      textures.push_back(upload_texture(t.width, t.height, t.rgba.data(), t.srgb, t.repeat_s,
                                        t.repeat_t, t.nearest, trilinear));
    check_gl("glTexImage2D (material textures)");
  }

  void init_background(const Image& image) {
    background_program = detail::link_background_program();
    glUseProgram(background_program);
    glUniform1i(glGetUniformLocation(background_program, "u_image"), detail::kBackgroundUnit);
    background_scale_at = glGetUniformLocation(background_program, "u_scale");
    glGenVertexArrays(1, &background_vao);
    glActiveTexture(GL_TEXTURE0 + detail::kBackgroundUnit);
    std::vector<std::uint8_t> rgba(static_cast<std::size_t>(image.width) * image.height * 4, 255);
    for (std::size_t i = 0, n = static_cast<std::size_t>(image.width) * image.height; i < n; ++i)
      for (int c = 0; c < 3; ++c)
        rgba[4 * i + c] = image.pixels[i * image.channels + (image.channels >= 3 ? c : 0)];
    background_tex =
        upload_texture(image.width, image.height, rgba.data(), false, false, false, false);
    // Cover the frame: crop the image's longer side to the frame's aspect ratio.
    const float frame = static_cast<float>(width) / static_cast<float>(height);
    const float img = static_cast<float>(image.width) / static_cast<float>(image.height);
    background_scale[0] = img > frame ? frame / img : 1.0f;
    background_scale[1] = img > frame ? 1.0f : img / frame;
    check_gl("background image");
  }

  void init_framebuffers(const RenderOptions& o) {
    width = o.width;
    height = o.height;
    samples = o.msaa > 1 ? o.msaa : 0;
    GLint max_samples = 0;
    glGetIntegerv(GL_MAX_SAMPLES, &max_samples);
    samples = std::min(samples, static_cast<int>(max_samples));
    glGenFramebuffers(1, &fbo);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo);
    glGenRenderbuffers(1, &color_rb);
    glBindRenderbuffer(GL_RENDERBUFFER, color_rb);
    glRenderbufferStorageMultisample(GL_RENDERBUFFER, samples, GL_RGBA8, width, height);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, color_rb);
    glGenRenderbuffers(1, &depth_rb);
    glBindRenderbuffer(GL_RENDERBUFFER, depth_rb);
    glRenderbufferStorageMultisample(GL_RENDERBUFFER, samples, GL_DEPTH_COMPONENT24, width, height);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_rb);
    check_gl("glRenderbufferStorageMultisample");
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
      throw Error("glCheckFramebufferStatus: framebuffer incomplete", ErrorCode::kInternal);
    if (samples) {
      glGenFramebuffers(1, &resolve_fbo);
      glBindFramebuffer(GL_FRAMEBUFFER, resolve_fbo);
      glGenRenderbuffers(1, &resolve_rb);
      glBindRenderbuffer(GL_RENDERBUFFER, resolve_rb);
      glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width, height);
      glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, resolve_rb);
      if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
        throw Error("glCheckFramebufferStatus: resolve framebuffer incomplete",
                    ErrorCode::kInternal);
    }
    check_gl("framebuffer setup");
  }

  void draw_range(const PackedRig& p, const PackedRig::Range& r) {
    const detail::PackedMaterial& m = p.materials[static_cast<std::size_t>(r.material)];
    const Program& u = programs[program_of[static_cast<std::size_t>(r.material)]];
    glUseProgram(u.id);
    if (m.double_sided)
      glDisable(GL_CULL_FACE);
    else
      glEnable(GL_CULL_FACE);
    glUniform4fv(u.base_color, 1, m.base_color.data());
    glUniform3fv(u.emissive, 1, m.emissive.data());
    glUniform2f(u.metallic_roughness, m.metallic, m.roughness);
    glUniform1f(u.normal_scale, m.normal_scale);
    glUniform1f(u.occlusion_strength, m.occlusion_strength);
    glUniform1i(u.blend, m.alpha_mode == rig::AlphaMode::kBlend);
    glUniform1f(u.alpha_cutoff, m.alpha_cutoff);
    glUniform1i(u.unlit, m.unlit);
    glUniform1i(u.toon, m.toon);
    glUniform3fv(u.shade, 1, m.shade_color.data());
    glUniform3fv(u.rim, 1, m.rim_color.data());
    glUniform4fv(u.toon_params, 1, m.toon_params.data());
    for (int slot = 0; slot < detail::kSlotCount; ++slot) {
      glActiveTexture(GL_TEXTURE0 + static_cast<GLenum>(detail::kFirstMaterialUnit + slot));
      glBindTexture(GL_TEXTURE_2D, m.texture[slot] >= 0
                                       ? textures[static_cast<std::size_t>(m.texture[slot])]
                                       : white_tex);
    }
    glUniformMatrix3fv(u.uv, detail::kSlotCount, GL_FALSE, m.uv_transform[0].data());
    glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(r.count), GL_UNSIGNED_INT,
                   reinterpret_cast<const void*>(r.first * sizeof(GLuint)));
  }

  void draw(const PackedRig& p, const RenderOptions& o, const Camera& cam,
            std::span<const float> weights, const Palette& pose, Image& out) {
    glBindFramebuffer(GL_FRAMEBUFFER, fbo);
    glViewport(0, 0, width, height);
    glClearColor(o.background.x(), o.background.y(), o.background.z(), 1.0f);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glDisable(GL_CULL_FACE);
    glDisable(GL_BLEND);
    if (background_program) {
      glDisable(GL_DEPTH_TEST);
      glUseProgram(background_program);
      glUniform2fv(background_scale_at, 1, background_scale);
      glActiveTexture(GL_TEXTURE0 + detail::kBackgroundUnit);
      glBindTexture(GL_TEXTURE_2D, background_tex);
      glBindVertexArray(background_vao);
      glDrawArrays(GL_TRIANGLES, 0, 3);
    }
    glEnable(GL_DEPTH_TEST);
    glDepthMask(GL_TRUE);
    detail::blend(p, weights, mesh);
    glBindBuffer(GL_ARRAY_BUFFER, buffers[kBlendedBuffer]);
    glBufferSubData(GL_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(mesh.size() * sizeof(float)),
                    mesh.data());
    const float aspect = static_cast<float>(width) / static_cast<float>(height);
    const Eigen::Matrix4f mvp = view_projection(cam, aspect);
    for (const Program& g : programs) {
      glUseProgram(g.id);
      glUniformMatrix4fv(g.mvp, 1, GL_FALSE, mvp.data());
      glUniformMatrix4fv(g.palette, static_cast<GLsizei>(pose.entries.size()), GL_FALSE,
                         pose.entries[0].data());
      glUniform3fv(g.eye, 1, cam.eye.data());
    }
    glBindVertexArray(vao);
    // Opaque ranges first, then masked ones, then blended ones far to near without writing depth.
    const auto mode = [&](const PackedRig::Range& r) {
      return p.materials[static_cast<std::size_t>(r.material)].alpha_mode;
    };
    const bool lod = !p.lod_ranges.empty() && p.lod_error <= o.lod_pixels * pixel_size(cam, height);
    const auto& ranges = lod ? p.lod_ranges : p.ranges;
    for (const auto& r : ranges)
      if (mode(r) == rig::AlphaMode::kOpaque) draw_range(p, r);
    std::vector<const PackedRig::Range*> blended;
    for (const auto& r : ranges) {
      if (mode(r) == rig::AlphaMode::kBlend)
        blended.push_back(&r);
      else if (mode(r) == rig::AlphaMode::kMask)
        draw_range(p, r);
    }
    if (!blended.empty()) {
      const auto depth = [&](const PackedRig::Range* r) {
        // View-space z (more negative: farther), which the projection's last row copies negated
        // into w.
        return -(mvp * pose.entries[static_cast<std::size_t>(pose.head)] *
                 r->centroid.homogeneous())
                    .w();
      };
      std::stable_sort(blended.begin(), blended.end(),
                       [&](auto* a, auto* b) { return depth(a) < depth(b); });
      glEnable(GL_BLEND);
      glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
      glDepthMask(GL_FALSE);
      for (const auto* r : blended) draw_range(p, *r);
      glDepthMask(GL_TRUE);
      glDisable(GL_BLEND);
    }
    check_gl("glDrawElements");
    if (samples) {
      glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo);
      glBindFramebuffer(GL_DRAW_FRAMEBUFFER, resolve_fbo);
      glBlitFramebuffer(0, 0, width, height, 0, 0, width, height, GL_COLOR_BUFFER_BIT, GL_NEAREST);
      glBindFramebuffer(GL_READ_FRAMEBUFFER, resolve_fbo);
      check_gl("glBlitFramebuffer (MSAA resolve)");
    }
    out.width = width;
    out.height = height;
    out.channels = 3;
    out.pixels.resize(static_cast<std::size_t>(width) * height * 3);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    flipped.resize(out.pixels.size());
    glReadPixels(0, 0, width, height, GL_RGB, GL_UNSIGNED_BYTE, flipped.data());
    check_gl("glReadPixels");
    const std::size_t row = static_cast<std::size_t>(width) * 3;
    for (int y = 0; y < height; ++y)
      std::memcpy(&out.pixels[static_cast<std::size_t>(y) * row],
                  &flipped[static_cast<std::size_t>(height - 1 - y) * row], row);
  }

  ~Slot() {
    try {
      context.make_current();
      glDeleteTextures(static_cast<GLsizei>(textures.size()), textures.data());
      glDeleteTextures(1, &white_tex);
      glDeleteBuffers(kBufferCount, buffers);
      glDeleteVertexArrays(1, &vao);
      if (background_program) {
        glDeleteTextures(1, &background_tex);
        glDeleteVertexArrays(1, &background_vao);
        glDeleteProgram(background_program);
      }
      glDeleteRenderbuffers(1, &color_rb);
      glDeleteRenderbuffers(1, &depth_rb);
      glDeleteFramebuffers(1, &fbo);
      if (resolve_fbo) {
        glDeleteRenderbuffers(1, &resolve_rb);
        glDeleteFramebuffers(1, &resolve_fbo);
      }
      for (const Program& g : programs) glDeleteProgram(g.id);
      context.release();
    } catch (...) {
    }
  }
};

}  // namespace

struct Renderer::Impl {
  RenderOptions options;
  PackedRig packed;
  Camera camera;
  std::optional<Image> background;  // options.background_image, read once
  mutable std::mutex mutex;
  mutable std::condition_variable freed;
  mutable std::vector<std::unique_ptr<Slot>> slots;
  mutable std::vector<Slot*> idle;

  Slot* acquire() const {
    std::unique_lock lock(mutex);
    for (;;) {
      if (!idle.empty()) {
        Slot* s = idle.back();
        idle.pop_back();
        return s;
      }
      if (static_cast<int>(slots.size()) < std::max(1, options.contexts)) {
        slots.push_back(nullptr);  // reserve the place while creating outside the lock
        const std::size_t at = slots.size() - 1;
        lock.unlock();
        std::unique_ptr<Slot> made;
        try {
          made = std::make_unique<Slot>(at, packed, options, background ? &*background : nullptr);
        } catch (...) {
          lock.lock();
          slots.erase(slots.begin() + static_cast<std::ptrdiff_t>(at));
          freed.notify_one();
          throw;
        }
        lock.lock();
        slots[at] = std::move(made);
        return slots[at].get();
      }
      freed.wait(lock);
    }
  }
  void release(Slot* s) const {
    std::lock_guard lock(mutex);
    idle.push_back(s);
    freed.notify_one();
  }
};

Renderer::Renderer(const rig::Rig& rig, RenderOptions options) : impl_(std::make_unique<Impl>()) {
  if (options.width < 1 || options.height < 1 || options.width > 8192 || options.height > 8192)
    throw Error("renderer: image size " + std::to_string(options.width) + "x" +
                std::to_string(options.height) + " is out of range (1..8192)");
  impl_->options = options;
  impl_->packed = detail::pack_rig(rig);
  if (!options.background_image.empty()) impl_->background = read_image(options.background_image);
  impl_->camera = frame_avatar(
      rig, static_cast<float>(options.width) / static_cast<float>(options.height), options);
  if (options.lod_pixels > 0)
    detail::add_lod(impl_->packed, options.lod_pixels * pixel_size(impl_->camera, options.height));
}

Renderer::~Renderer() = default;

const RenderOptions& Renderer::options() const {
  return impl_->options;
}
const Camera& Renderer::camera() const {
  return impl_->camera;
}
void Renderer::set_camera(const Camera& camera) {
  std::lock_guard lock(impl_->mutex);
  impl_->camera = camera;
}

Image Renderer::render(std::span<const float> weights) const {
  return render(weights, rig::BodyPose{});
}

rig::SpringSim Renderer::spring_sim() const {
  const detail::BodySkin& b = impl_->packed.body;
  return b.skinned ? rig::SpringSim(b.skeleton, b.joints) : rig::SpringSim();
}

Image Renderer::render(std::span<const float> weights, const rig::BodyPose& pose,
                       const rig::JointTurns& springs) const {
  if (static_cast<int>(weights.size()) != impl_->packed.shape_count)
    throw Error("render: " + std::to_string(weights.size()) + " weights for a rig with " +
                std::to_string(impl_->packed.shape_count) + " shapes");
  Camera cam;
  {
    std::lock_guard lock(impl_->mutex);
    cam = impl_->camera;
  }
  Slot* slot = impl_->acquire();
  Image image;
  try {
    slot->context.make_current();
    slot->draw(impl_->packed, impl_->options, cam, weights,
               palette(impl_->packed.body, pose, springs), image);
    slot->context.release();
  } catch (...) {
    slot->context.release();
    impl_->release(slot);
    throw;
  }
  impl_->release(slot);
  return image;
}

void open_displays() {
  detail::displays();
}

void Renderer::create_contexts() const {
  // Taking every slot at once makes acquire() create the missing ones.
  std::vector<Slot*> taken;
  try {
    while (static_cast<int>(taken.size()) < std::max(1, impl_->options.contexts))
      taken.push_back(impl_->acquire());
  } catch (...) {
    for (Slot* s : taken) impl_->release(s);
    throw;
  }
  for (Slot* s : taken) impl_->release(s);
}

std::pair<std::size_t, std::size_t> Renderer::triangle_counts() const {
  const auto count = [](const std::vector<PackedRig::Range>& ranges) {
    std::size_t n = 0;
    for (const auto& r : ranges) n += r.count / 3;
    return n;
  };
  const PackedRig& p = impl_->packed;
  return {count(p.ranges), count(p.lod_ranges.empty() ? p.ranges : p.lod_ranges)};
}

std::string Renderer::backend() const {
  Slot* slot = impl_->acquire();
  const std::string name = slot->renderer_name;
  impl_->release(slot);
  std::string platforms;
  for (const auto& d : detail::displays()) platforms += (platforms.empty() ? "" : "+") + d.platform;
  return "EGL " + platforms + " platform, " + name;
}

}  // namespace facecast::render
