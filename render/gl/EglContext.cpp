// GlContext on EGL without a window: the device platform (a GPU), Mesa's surfaceless platform, the software device.
#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <cstring>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "render/core/RenderErrors.h"
#include "render/gl/GlContext.h"

namespace voxbrick::render {

namespace {

std::string eglErrorText() {
  EGLint code = eglGetError();
  switch (code) {
    case EGL_SUCCESS: return "no EGL error recorded";
    case EGL_NOT_INITIALIZED: return "EGL_NOT_INITIALIZED";
    case EGL_BAD_ACCESS: return "EGL_BAD_ACCESS";
    case EGL_BAD_ALLOC: return "EGL_BAD_ALLOC";
    case EGL_BAD_ATTRIBUTE: return "EGL_BAD_ATTRIBUTE";
    case EGL_BAD_CONFIG: return "EGL_BAD_CONFIG";
    case EGL_BAD_CONTEXT: return "EGL_BAD_CONTEXT";
    case EGL_BAD_DISPLAY: return "EGL_BAD_DISPLAY";
    case EGL_BAD_MATCH: return "EGL_BAD_MATCH";
    case EGL_BAD_PARAMETER: return "EGL_BAD_PARAMETER";
    case EGL_BAD_SURFACE: return "EGL_BAD_SURFACE";
    default: return "EGL error 0x" + std::to_string(code);
  }
}

bool hasExtension(const char* list, const char* name) {
  if (list == nullptr) return false;
  const size_t length = std::strlen(name);
  for (const char* p = list; (p = std::strstr(p, name)) != nullptr; p += length) {
    const bool startsWord = p == list || p[-1] == ' ';
    const bool endsWord = p[length] == '\0' || p[length] == ' ';
    if (startsWord && endsWord) return true;
  }
  return false;
}

// eglTerminate is not reference counted: terminating a display kills every context on it, and the device and
// surfaceless platforms hand the same EGLDisplay to every caller. Contexts in other threads share displays, so
// initialise/terminate are counted here, under one lock.
std::mutex gDisplayMutex;
std::map<EGLDisplay, int> gDisplayUsers;

bool acquireDisplay(EGLDisplay display, std::string& why) {
  std::lock_guard lock(gDisplayMutex);
  EGLint major = 0, minor = 0;
  if (!eglInitialize(display, &major, &minor)) {
    why = "eglInitialize failed (" + eglErrorText() + ")";
    return false;
  }
  ++gDisplayUsers[display];
  return true;
}

void releaseDisplay(EGLDisplay display) {
  std::lock_guard lock(gDisplayMutex);
  auto it = gDisplayUsers.find(display);
  if (it == gDisplayUsers.end() || --it->second > 0) return;
  gDisplayUsers.erase(it);
  eglTerminate(display);
}

class EglContext final : public GlContext {
 public:
  EglContext(EGLDisplay display, EGLContext context, EGLSurface surface)
      : mDisplay(display), mContext(context), mSurface(surface) {}

  ~EglContext() override {
    if (eglGetCurrentContext() == mContext) {
      eglMakeCurrent(mDisplay, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    }
    eglDestroyContext(mDisplay, mContext);
    if (mSurface != EGL_NO_SURFACE) eglDestroySurface(mDisplay, mSurface);
    releaseDisplay(mDisplay);
  }

  void makeCurrent() override {
    // The bound API is per thread, and a thread that never called eglBindAPI is on OpenGL ES.
    if (!eglBindAPI(EGL_OPENGL_API) || !eglMakeCurrent(mDisplay, mSurface, mSurface, mContext)) {
      throw RenderError("EglContext::makeCurrent: " + eglErrorText());
    }
  }

  void releaseCurrent() override {
    if (eglGetCurrentContext() == mContext) eglMakeCurrent(mDisplay, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  }

  Backend backend() const override { return Backend::Egl; }

  using GlContext::initialise;

 private:
  EGLDisplay mDisplay;
  EGLContext mContext;
  EGLSurface mSurface;
};

// Makes an OpenGL 4.3 core context on an already obtained display, current on this thread. `label` names the path;
// with `addVendor` the display's EGL_VENDOR is appended in parentheses once known. On failure returns nullptr with
// the reason in `why`, leaving nothing behind.
std::unique_ptr<GlContext> contextOnDisplay(EGLDisplay display, std::string& label, bool addVendor, std::string& why) {
  if (display == EGL_NO_DISPLAY) {
    why = "no display (" + eglErrorText() + ")";
    return nullptr;
  }
  if (!acquireDisplay(display, why)) return nullptr;
  if (addVendor) {
    const char* vendor = eglQueryString(display, EGL_VENDOR);
    label += std::string(" (") + (vendor ? vendor : "unknown vendor") + ")";
  }
  EGLContext context = EGL_NO_CONTEXT;
  EGLSurface surface = EGL_NO_SURFACE;
  auto fail = [&](std::string reason) -> std::unique_ptr<GlContext> {
    why = std::move(reason);
    if (context != EGL_NO_CONTEXT) eglDestroyContext(display, context);
    if (surface != EGL_NO_SURFACE) eglDestroySurface(display, surface);
    releaseDisplay(display);
    return nullptr;
  };
  if (!eglBindAPI(EGL_OPENGL_API)) return fail("eglBindAPI(EGL_OPENGL_API) failed (" + eglErrorText() + ")");

  const char* extensions = eglQueryString(display, EGL_EXTENSIONS);
  const bool configless =
      hasExtension(extensions, "EGL_KHR_no_config_context") || hasExtension(extensions, "EGL_MESA_configless_context");
  const bool surfaceless = hasExtension(extensions, "EGL_KHR_surfaceless_context");
  EGLConfig config = EGL_NO_CONFIG_KHR;
  if (!configless || !surfaceless) {
    // Drivers without configless/surfaceless contexts need a config and a 1x1 pbuffer to be made current.
    const EGLint configAttribs[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
    EGLint count = 0;
    if (!eglChooseConfig(display, configAttribs, &config, 1, &count) || count < 1) {
      return fail("no EGL config with EGL_OPENGL_BIT and EGL_PBUFFER_BIT (" + eglErrorText() + ")");
    }
  }
  const EGLint contextAttribs[] = {
      EGL_CONTEXT_MAJOR_VERSION,           4,       EGL_CONTEXT_MINOR_VERSION, 3, EGL_CONTEXT_OPENGL_PROFILE_MASK,
      EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
  context = eglCreateContext(display, config, EGL_NO_CONTEXT, contextAttribs);
  if (context == EGL_NO_CONTEXT) return fail("eglCreateContext(OpenGL 4.3 core) failed (" + eglErrorText() + ")");
  if (!surfaceless) {
    const EGLint pbufferAttribs[] = {EGL_WIDTH, 1, EGL_HEIGHT, 1, EGL_NONE};
    surface = eglCreatePbufferSurface(display, config, pbufferAttribs);
    if (surface == EGL_NO_SURFACE) return fail("eglCreatePbufferSurface failed (" + eglErrorText() + ")");
  }
  if (!eglMakeCurrent(display, surface, surface, context)) {
    return fail("eglMakeCurrent failed (" + eglErrorText() + ")");
  }
  auto result = std::make_unique<EglContext>(display, context, surface);
  try {
    result->initialise(eglGetProcAddress, "eglGetProcAddress", label);
  } catch (const RenderError& error) {
    why = error.what();
    return nullptr;  // ~EglContext releases everything
  }
  return result;
}

struct EglDevice {
  EGLDeviceEXT handle;
  int index;
  bool software;
  std::string drmFile;
};

}  // namespace

std::unique_ptr<GlContext> createEglContext(std::string& failures) {
  const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  auto getPlatformDisplay =
      reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (!hasExtension(client, "EGL_EXT_platform_base") || getPlatformDisplay == nullptr) {
    failures += "\n  EGL: no EGL_EXT_platform_base, so neither the device nor the surfaceless platform";
    return nullptr;
  }

  std::vector<EglDevice> devices;
  if (hasExtension(client, "EGL_EXT_device_enumeration") && hasExtension(client, "EGL_EXT_platform_device")) {
    auto queryDevices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
    auto queryDeviceString =
        reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(eglGetProcAddress("eglQueryDeviceStringEXT"));
    EGLDeviceEXT handles[32];
    EGLint count = 0;
    if (queryDevices && queryDeviceString && queryDevices(32, handles, &count)) {
      for (EGLint i = 0; i < count; ++i) {
        const char* extensions = queryDeviceString(handles[i], EGL_EXTENSIONS);
        const char* drm = hasExtension(extensions, "EGL_EXT_device_drm")
                              ? queryDeviceString(handles[i], EGL_DRM_DEVICE_FILE_EXT)
                              : nullptr;
        devices.push_back({handles[i], int(i), hasExtension(extensions, "EGL_MESA_device_software"),
                           drm ? std::string(drm) : std::string()});
      }
    } else {
      failures += "\n  EGL device platform: eglQueryDevicesEXT failed (" + eglErrorText() + ")";
    }
  } else {
    failures += "\n  EGL device platform: no EGL_EXT_device_enumeration/EGL_EXT_platform_device";
  }

  auto tryDevice = [&](const EglDevice& device) -> std::unique_ptr<GlContext> {
    EGLDisplay display = getPlatformDisplay(EGL_PLATFORM_DEVICE_EXT, device.handle, nullptr);
    std::string label = "EGL device " + std::to_string(device.index);
    if (device.software) label += " (Mesa software)";
    if (!device.drmFile.empty()) label += " " + device.drmFile;
    std::string why;
    if (auto context = contextOnDisplay(display, label, !device.software, why)) return context;
    failures += "\n  " + label + ": " + why;
    return nullptr;
  };

  // A GPU first. Mesa's software device runs the same llvmpipe as the surfaceless platform, which is the named,
  // tested software path, so the software device comes only after it.
  for (const EglDevice& device : devices) {
    if (device.software) continue;
    if (auto context = tryDevice(device)) return context;
  }
  if (hasExtension(client, "EGL_MESA_platform_surfaceless")) {
    std::string why;
    EGLDisplay display = getPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    std::string label = "EGL surfaceless";
    if (auto context = contextOnDisplay(display, label, false, why)) return context;
    failures += "\n  EGL surfaceless: " + why;
  } else {
    failures += "\n  EGL surfaceless: no EGL_MESA_platform_surfaceless";
  }
  for (const EglDevice& device : devices) {
    if (!device.software) continue;
    if (auto context = tryDevice(device)) return context;
  }
  return nullptr;
}

}  // namespace voxbrick::render
