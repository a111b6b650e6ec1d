// The renderer: rig data packed once on the CPU (gpu_rig.cpp), uploaded once per pooled GL
// context, blended in the vertex shader (shaders.cpp) from the per-frame weights.
#include "facecast/render/renderer.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <mutex>

#include "egl.hpp"
#include "facecast/core/error.hpp"
#include "gpu_rig.hpp"
#include "shaders.hpp"

namespace facecast::render {
namespace {

using detail::check_gl;
using detail::PackedRig;

Eigen::Matrix4f perspective(float fov_y_rad, float aspect, float n, float f) {
  const float t = 1.0f / std::tan(0.5f * fov_y_rad);
  Eigen::Matrix4f m = Eigen::Matrix4f::Zero();
  m(0, 0) = t / aspect;
  m(1, 1) = t;
  m(2, 2) = (f + n) / (n - f);
  m(2, 3) = 2 * f * n / (n - f);
  m(3, 2) = -1;
  return m;
}

Eigen::Matrix4f look_at(const Eigen::Vector3f& eye, const Eigen::Vector3f& target,
                        const Eigen::Vector3f& up) {
  const Eigen::Vector3f f = (target - eye).normalized();
  const Eigen::Vector3f s = f.cross(up).normalized();
  const Eigen::Vector3f u = s.cross(f);
  Eigen::Matrix4f m = Eigen::Matrix4f::Identity();
  m.block<1, 3>(0, 0) = s.transpose();
  m.block<1, 3>(1, 0) = u.transpose();
  m.block<1, 3>(2, 0) = -f.transpose();
  m(0, 3) = -s.dot(eye);
  m(1, 3) = -u.dot(eye);
  m(2, 3) = f.dot(eye);
  return m;
}

// One pooled GL context with its own copy of the rig and its framebuffers.
struct Slot {
  detail::Context context;
  GLuint program = 0, vao = 0, buffers[4] = {}, delta_tex = 0;
  GLuint fbo = 0, color_rb = 0, depth_rb = 0, resolve_fbo = 0, resolve_rb = 0;
  GLint u_weights = -1, u_mvp = -1, u_model = -1, u_color = -1, u_eye = -1, u_deltas = -1;
  int width = 0, height = 0, samples = 0;
  std::string renderer_name;

  Slot(const PackedRig& p, const RenderOptions& o) {
    context.make_current();
    try {
      init(p, o);
    } catch (...) {
      context.release();
      throw;
    }
    context.release();
  }

  void init(const PackedRig& p, const RenderOptions& o) {
    glGetError();
    renderer_name = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
    program = detail::link_program();
    u_weights = glGetUniformLocation(program, "u_weights");
    u_mvp = glGetUniformLocation(program, "u_mvp");
    u_model = glGetUniformLocation(program, "u_model");
    u_color = glGetUniformLocation(program, "u_color");
    u_eye = glGetUniformLocation(program, "u_eye");
    u_deltas = glGetUniformLocation(program, "u_deltas");
    check_gl("glLinkProgram");

    glGenVertexArrays(1, &vao);
    glBindVertexArray(vao);
    glGenBuffers(4, buffers);
    const auto upload = [](GLenum target, GLuint buf, const void* data, std::size_t bytes) {
      glBindBuffer(target, buf);
      glBufferData(target, static_cast<GLsizeiptr>(bytes), data, GL_STATIC_DRAW);
    };
    upload(GL_ARRAY_BUFFER, buffers[0], p.positions.data(), p.positions.size() * sizeof(float));
    glVertexAttribPointer(detail::kPositionAttribute, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
    glEnableVertexAttribArray(detail::kPositionAttribute);
    upload(GL_ARRAY_BUFFER, buffers[1], p.normals.data(), p.normals.size() * sizeof(float));
    glVertexAttribPointer(detail::kNormalAttribute, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
    glEnableVertexAttribArray(detail::kNormalAttribute);
    static_assert(sizeof(p.morph[0]) == sizeof(GLint) && sizeof(p.indices[0]) == sizeof(GLuint));
    upload(GL_ARRAY_BUFFER, buffers[2], p.morph.data(), p.morph.size() * sizeof(GLint));
    glVertexAttribIPointer(detail::kMorphAttribute, 2, GL_INT, 0, nullptr);
    glEnableVertexAttribArray(detail::kMorphAttribute);
    upload(GL_ELEMENT_ARRAY_BUFFER, buffers[3], p.indices.data(),
           p.indices.size() * sizeof(GLuint));
    check_gl("glBufferData (mesh)");

    glGenTextures(1, &delta_tex);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, delta_tex);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, detail::kDeltaWidth, p.delta_rows, 0, GL_RGBA,
                 GL_FLOAT, p.deltas.data());
    check_gl("glTexImage2D (morph deltas)");

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

  void draw(const PackedRig& p, const RenderOptions& o, const Camera& cam,
            std::span<const float> weights, const Eigen::Matrix4f& model, Image& out) {
    glBindFramebuffer(GL_FRAMEBUFFER, fbo);
    glViewport(0, 0, width, height);
    glClearColor(o.background.x(), o.background.y(), o.background.z(), 1.0f);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glEnable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE);
    glUseProgram(program);
    glUniform1i(u_deltas, 0);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, delta_tex);
    float w[detail::kMaxShapes] = {};
    std::copy(weights.begin(), weights.end(), w);
    glUniform1fv(u_weights, detail::kMaxShapes, w);
    const float aspect = static_cast<float>(width) / static_cast<float>(height);
    const Eigen::Matrix4f mvp =
        perspective(cam.fov_y_deg * 3.14159265f / 180.0f, aspect, cam.near_plane, cam.far_plane) *
        look_at(cam.eye, cam.target, cam.up);
    glUniformMatrix4fv(u_mvp, 1, GL_FALSE, mvp.data());
    glUniformMatrix4fv(u_model, 1, GL_FALSE, model.data());
    glUniform3fv(u_eye, 1, cam.eye.data());
    glBindVertexArray(vao);
    for (const auto& r : p.ranges) {
      glUniform3fv(u_color, 1, r.color.data());
      glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(r.count), GL_UNSIGNED_INT,
                     reinterpret_cast<const void*>(r.first * sizeof(GLuint)));
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
    std::vector<std::uint8_t> flipped(out.pixels.size());
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
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
      glDeleteTextures(1, &delta_tex);
      glDeleteBuffers(4, buffers);
      glDeleteVertexArrays(1, &vao);
      glDeleteRenderbuffers(1, &color_rb);
      glDeleteRenderbuffers(1, &depth_rb);
      glDeleteFramebuffers(1, &fbo);
      if (resolve_fbo) {
        glDeleteRenderbuffers(1, &resolve_rb);
        glDeleteFramebuffers(1, &resolve_fbo);
      }
      glDeleteProgram(program);
      context.release();
    } catch (...) {
    }
  }
};

// Yaw about +Y, then pitch about +X, then roll about +Z, about `pivot`.
Eigen::Matrix4f head_matrix(const anim::HeadPose& head, const Eigen::Vector3f& pivot) {
  Eigen::Affine3f m =
      Eigen::Translation3f(pivot) * Eigen::AngleAxisf(head.roll, Eigen::Vector3f::UnitZ()) *
      Eigen::AngleAxisf(head.pitch, Eigen::Vector3f::UnitX()) *
      Eigen::AngleAxisf(head.yaw, Eigen::Vector3f::UnitY()) * Eigen::Translation3f(-pivot);
  return m.matrix();
}

// The neck: the centre of the skin's bounding box in x and z, 10% above its bottom.
Eigen::Vector3f neck_pivot(const anim::Rig& rig) {
  if (rig.vertex_count() == 0) return Eigen::Vector3f::Zero();
  const Eigen::Vector3f lo = rig.positions.colwise().minCoeff().transpose();
  const Eigen::Vector3f hi = rig.positions.colwise().maxCoeff().transpose();
  return {0.5f * (lo.x() + hi.x()), lo.y() + 0.1f * (hi.y() - lo.y()), 0.5f * (lo.z() + hi.z())};
}

}  // namespace

Camera frame_face(const anim::Rig& rig, float aspect, const RenderOptions& options) {
  const auto comps = anim::connected_components(rig.vertex_count(), rig.triangles);
  const int skin = comps.largest;
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(1e30f), hi = -lo;
  for (int v = 0; v < rig.vertex_count(); ++v) {
    if (comps.label[static_cast<std::size_t>(v)] != skin) continue;
    lo = lo.cwiseMin(rig.positions.row(v).transpose());
    hi = hi.cwiseMax(rig.positions.row(v).transpose());
  }
  // The front half of the skin.
  const float mid_z = 0.5f * (lo.z() + hi.z());
  Eigen::Vector3f flo = Eigen::Vector3f::Constant(1e30f), fhi = -flo;
  for (int v = 0; v < rig.vertex_count(); ++v) {
    if (comps.label[static_cast<std::size_t>(v)] != skin || rig.positions(v, 2) < mid_z) continue;
    flo = flo.cwiseMin(rig.positions.row(v).transpose());
    fhi = fhi.cwiseMax(rig.positions.row(v).transpose());
  }
  Camera c;
  c.fov_y_deg = options.fov_y_deg;
  const Eigen::Vector3f centre = 0.5f * (flo + fhi);
  const float t = std::tan(0.5f * options.fov_y_deg * 3.14159265f / 180.0f);
  const float h = (fhi.y() - flo.y()) * options.margin, w = (fhi.x() - flo.x()) * options.margin;
  const float dist = std::max(0.5f * h / t, 0.5f * w / (t * aspect));
  c.target = centre;
  c.eye = Eigen::Vector3f(centre.x(), centre.y(), fhi.z() + dist);
  const float depth = hi.z() - lo.z();
  c.near_plane = std::max(0.01f, 0.2f * dist);
  c.far_plane = fhi.z() + dist - lo.z() + depth;
  return c;
}

struct Renderer::Impl {
  RenderOptions options;
  PackedRig packed;
  Camera camera;
  Eigen::Vector3f neck = Eigen::Vector3f::Zero();  // pivot of the head pose
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
          made = std::make_unique<Slot>(packed, options);
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

Renderer::Renderer(const anim::Rig& rig, RenderOptions options) : impl_(std::make_unique<Impl>()) {
  if (options.width < 1 || options.height < 1 || options.width > 8192 || options.height > 8192)
    throw Error("renderer: image size " + std::to_string(options.width) + "x" +
                std::to_string(options.height) + " is out of range (1..8192)");
  impl_->options = options;
  impl_->packed = detail::pack_rig(rig);
  impl_->camera = frame_face(
      rig, static_cast<float>(options.width) / static_cast<float>(options.height), options);
  impl_->neck = neck_pivot(rig);
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
  return render(weights, anim::HeadPose{});
}

Image Renderer::render(std::span<const float> weights, const anim::HeadPose& head) const {
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
    slot->draw(impl_->packed, impl_->options, cam, weights, head_matrix(head, impl_->neck), image);
    slot->context.release();
  } catch (...) {
    slot->context.release();
    impl_->release(slot);
    throw;
  }
  impl_->release(slot);
  return image;
}

std::string Renderer::backend() const {
  Slot* slot = impl_->acquire();
  const std::string name = slot->renderer_name;
  impl_->release(slot);
  return "EGL " + detail::display().platform + " platform, " + name;
}

std::vector<std::pair<std::string, float>> parse_weight_list(std::string_view text) {
  std::vector<std::pair<std::string, float>> out;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t comma = std::min(text.find(',', pos), text.size());
    std::string item(text.substr(pos, comma - pos));
    pos = comma + 1;
    const auto trim = [](std::string s) {
      const auto b = s.find_first_not_of(" \t"), e = s.find_last_not_of(" \t");
      return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
    };
    item = trim(item);
    if (item.empty()) {
      if (comma == text.size()) break;
      continue;
    }
    const std::size_t eq = item.find('=');
    if (eq == std::string::npos) throw Error("weights: '" + item + "' is not name=value");
    const std::string name = trim(item.substr(0, eq)), value = trim(item.substr(eq + 1));
    char* end = nullptr;
    const float v = std::strtof(value.c_str(), &end);
    if (name.empty() || value.empty() || *end != '\0' || !std::isfinite(v))
      throw Error("weights: '" + item + "' is not name=value with a number");
    out.emplace_back(name, v);
  }
  return out;
}

std::vector<float> weights_for(const anim::Rig& rig,
                               const std::vector<std::pair<std::string, float>>& named) {
  std::vector<float> w(rig.shapes.size(), 0.0f);
  for (const auto& [name, value] : named) {
    const int s = rig.find_shape(name);
    if (s < 0)
      throw Error("weights: the rig has no shape named '" + name + "'", ErrorCode::kNotFound);
    w[static_cast<std::size_t>(s)] = value;
  }
  return w;
}

}  // namespace facecast::render
