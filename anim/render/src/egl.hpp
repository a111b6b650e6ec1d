#pragma once
// Private: the process-wide EGL display and headless OpenGL 3.3 core contexts.
#include <EGL/egl.h>

#include <string>

namespace facecast::render::detail {

/// The EGL display, initialized once per process (device platform first, then Mesa surfaceless,
/// then the default display). Throws facecast::Error naming the EGL call that failed.
struct Display {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLConfig config = nullptr;
  std::string platform;      // "device", "surfaceless" or "default"
  bool surfaceless = false;  // EGL_KHR_surfaceless_context
};
const Display& display();

/// An OpenGL 3.3 core context (with a 16x16 pbuffer when surfaceless contexts are unsupported).
class Context {
 public:
  Context();
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;
  void make_current() const;  // on the calling thread
  void release() const;       // no context current on the calling thread

 private:
  EGLContext context_ = EGL_NO_CONTEXT;
  EGLSurface surface_ = EGL_NO_SURFACE;
};

/// "eglFoo failed: EGL_BAD_..." for the last EGL error.
std::string egl_error(const char* call);

}  // namespace facecast::render::detail
