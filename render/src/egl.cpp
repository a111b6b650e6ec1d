#include "egl.hpp"

#include <EGL/eglext.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <mutex>

#include "facecast/core/error.hpp"

namespace facecast::render::detail {
namespace {

const char* egl_error_name(EGLint e) {
  switch (e) {
    case EGL_SUCCESS:
      return "EGL_SUCCESS";
    case EGL_NOT_INITIALIZED:
      return "EGL_NOT_INITIALIZED";
    case EGL_BAD_ACCESS:
      return "EGL_BAD_ACCESS";
    case EGL_BAD_ALLOC:
      return "EGL_BAD_ALLOC";
    case EGL_BAD_ATTRIBUTE:
      return "EGL_BAD_ATTRIBUTE";
    case EGL_BAD_CONFIG:
      return "EGL_BAD_CONFIG";
    case EGL_BAD_CONTEXT:
      return "EGL_BAD_CONTEXT";
    case EGL_BAD_CURRENT_SURFACE:
      return "EGL_BAD_CURRENT_SURFACE";
    case EGL_BAD_DISPLAY:
      return "EGL_BAD_DISPLAY";
    case EGL_BAD_MATCH:
      return "EGL_BAD_MATCH";
    case EGL_BAD_PARAMETER:
      return "EGL_BAD_PARAMETER";
    case EGL_BAD_SURFACE:
      return "EGL_BAD_SURFACE";
    case EGL_CONTEXT_LOST:
      return "EGL_CONTEXT_LOST";
    default:
      return "unknown EGL error";
  }
}

bool has_extension(const char* list, const char* name) {
  if (!list) return false;
  const std::size_t n = std::strlen(name);
  for (const char* p = list; (p = std::strstr(p, name)); p += n)
    if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
  return false;
}

// Initializes `d` and picks an OpenGL-capable config; false (display terminated) if it cannot.
bool try_display(EGLDisplay d, const char* platform, Display& out) {
  if (d == EGL_NO_DISPLAY) return false;
  EGLint major = 0, minor = 0;
  if (!eglInitialize(d, &major, &minor)) return false;
  if (!eglBindAPI(EGL_OPENGL_API)) {
    eglTerminate(d);
    return false;
  }
  const EGLint attribs[] = {EGL_SURFACE_TYPE, 0, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT,
                            EGL_RED_SIZE,     8, EGL_GREEN_SIZE,      8,
                            EGL_BLUE_SIZE,    8, EGL_DEPTH_SIZE,      24,
                            EGL_NONE};
  EGLConfig config = nullptr;
  EGLint count = 0;
  if (!eglChooseConfig(d, attribs, &config, 1, &count) || count < 1) {
    eglTerminate(d);
    return false;
  }
  out.display = d;
  out.config = config;
  out.platform = platform;
  out.surfaceless = has_extension(eglQueryString(d, EGL_EXTENSIONS), "EGL_KHR_surfaceless_context");
  return true;
}

std::vector<Display> open_displays() {
  std::vector<Display> out;
  Display d;
  const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  const char* forced = std::getenv("FACECAST_EGL_PLATFORM");
  const std::string force = forced ? forced : "";
  auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
      eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if ((force.empty() || force == "device") && get_platform_display &&
      has_extension(client, "EGL_EXT_platform_device")) {
    auto query_devices =
        reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
    auto device_string = reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(
        eglGetProcAddress("eglQueryDeviceStringEXT"));
    EGLDeviceEXT devices[16];
    EGLint n = 0;
    if (query_devices && query_devices(16, devices, &n)) {
      // A GPU first (an NVIDIA driver and Mesa's software device may both be listed, in either
      // order), then a software device.
      const auto software = [&](EGLDeviceEXT dev) {
        const char* ext = device_string ? device_string(dev, EGL_EXTENSIONS) : nullptr;
        return ext && has_extension(ext, "EGL_MESA_device_software");
      };
      std::stable_partition(devices, devices + n, [&](EGLDeviceEXT dev) { return !software(dev); });
      for (EGLint i = 0; i < n; ++i)
        if (try_display(get_platform_display(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr),
                        "device", d)) {
          out.push_back(d);
          break;
        }
    }
  }
  if ((force.empty() || force == "surfaceless") && get_platform_display &&
      has_extension(client, "EGL_MESA_platform_surfaceless") &&
      try_display(get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr),
                  "surfaceless", d)) {
    // Only the same driver as the device's (a GPU's device display and Mesa's surfaceless
    // llvmpipe would render different pictures in different streams).
    const auto vendor = [](const Display& x) {
      const char* v = eglQueryString(x.display, EGL_VENDOR);
      return std::string(v ? v : "");
    };
    if (out.empty() || vendor(out.front()) == vendor(d))
      out.push_back(d);
    else
      eglTerminate(d.display);
  }
  if (out.empty() && force.empty() && try_display(eglGetDisplay(EGL_DEFAULT_DISPLAY), "default", d))
    out.push_back(d);
  if (out.empty())
    throw Error(egl_error("eglInitialize") + " (no usable EGL display: tried " +
                    (force.empty() ? std::string("device, surfaceless, default") : force) + ")",
                ErrorCode::kInternal);
  return out;
}

}  // namespace

std::string egl_error(const char* call) {
  return std::string(call) + " failed: " + egl_error_name(eglGetError());
}

const std::vector<Display>& displays() {
  // Opened once and kept for the life of the process (terminating under live contexts is unsafe).
  static std::once_flag once;
  static std::vector<Display> all;
  std::call_once(once, [] { all = open_displays(); });
  return all;
}

Context::Context(std::size_t index) : display_(&displays()[index % displays().size()]) {
  const Display& d = *display_;
  if (!eglBindAPI(EGL_OPENGL_API)) throw Error(egl_error("eglBindAPI"), ErrorCode::kInternal);
  const EGLint attribs[] = {EGL_CONTEXT_MAJOR_VERSION,
                            3,
                            EGL_CONTEXT_MINOR_VERSION,
                            3,
                            EGL_CONTEXT_OPENGL_PROFILE_MASK,
                            EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                            EGL_NONE};
  context_ = eglCreateContext(d.display, d.config, EGL_NO_CONTEXT, attribs);
  if (context_ == EGL_NO_CONTEXT)
    throw Error(egl_error("eglCreateContext (OpenGL 3.3 core)"), ErrorCode::kInternal);
  if (!d.surfaceless) {
    const EGLint pb[] = {EGL_WIDTH, 16, EGL_HEIGHT, 16, EGL_NONE};
    surface_ = eglCreatePbufferSurface(d.display, d.config, pb);
    if (surface_ == EGL_NO_SURFACE) {
      eglDestroyContext(d.display, context_);
      throw Error(egl_error("eglCreatePbufferSurface"), ErrorCode::kInternal);
    }
  }
}

Context::~Context() {
  const Display& d = *display_;
  if (surface_ != EGL_NO_SURFACE) eglDestroySurface(d.display, surface_);
  if (context_ != EGL_NO_CONTEXT) eglDestroyContext(d.display, context_);
}

void Context::make_current() const {
  eglBindAPI(EGL_OPENGL_API);  // the bound API is per-thread state
  if (!eglMakeCurrent(display_->display, surface_, surface_, context_))
    throw Error(egl_error("eglMakeCurrent"), ErrorCode::kInternal);
}

void Context::release() const {
  eglBindAPI(EGL_OPENGL_API);
  eglMakeCurrent(display_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
}

}  // namespace facecast::render::detail
