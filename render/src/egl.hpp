#pragma once
// Private: the process-wide EGL display and headless OpenGL 3.3 core contexts.
#include <EGL/egl.h>

#include <string>
#include <vector>

namespace facecast::render::detail {

/// An initialized EGL display.
struct Display {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLConfig config = nullptr;
  std::string platform;      // "device", "surfaceless" or "default"
  bool surfaceless = false;  // EGL_KHR_surfaceless_context
};
/// Every usable EGL display, opened once per process: the device platform's first usable device,
/// then Mesa's surfaceless platform, else the default display. Each is its own Mesa screen, and an
/// llvmpipe screen owns one rasterizer whose threads work through the scenes of all its contexts
/// one at a time: contexts on different displays rasterize at the same time. Throws
/// facecast::Error naming the EGL call that failed when there is none.
const std::vector<Display>& displays();

/// An OpenGL 3.3 core context (with a 16x16 pbuffer when surfaceless contexts are unsupported) on
/// displays()[index % displays().size()], so that consecutive indices use different displays.
class Context {
 public:
  explicit Context(std::size_t index);
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;
  void make_current() const;  // on the calling thread
  void release() const;       // no context current on the calling thread
  const Display& display() const { return *display_; }

 private:
  const Display* display_;
  EGLContext context_ = EGL_NO_CONTEXT;
  EGLSurface surface_ = EGL_NO_SURFACE;
};

/// "eglFoo failed: EGL_BAD_..." for the last EGL error.
std::string egl_error(const char* call);

}  // namespace facecast::render::detail
