// GlContext on OSMesa: Mesa's off-screen software renderer, the fallback when no EGL path works.
// glcorearb.h (through GlContext.h) must come before osmesa.h: osmesa.h pulls in gl.h, whose GL_VERSION_1_1 guard
// would otherwise hide the 1.1 function-pointer types that GlFunctions.h names.
#include "render/core/RenderErrors.h"
#include "render/gl/GlContext.h"

#include <GL/osmesa.h>
#include <dlfcn.h>

#include <array>
#include <cstdint>
#include <string>

namespace voxbrick::render {

namespace {

/// Mesa's libOSMesa, opened at the first OSMesa context rather than linked: it pulls in LLVM (about 100 MB, some 70 ms
/// of a core to load and relocate), which a process that never draws through OSMesa (prep, info, request, the EGL
/// path) should not pay at every start. The name is the soname of Debian's Mesa, whose ABI osmesa.h describes.
constexpr const char* kOsMesaLibrary = "libOSMesa.so.8";

struct OsMesaLibrary {
  decltype(&::OSMesaCreateContextAttribs) createContextAttribs = nullptr;
  decltype(&::OSMesaDestroyContext) destroyContext = nullptr;
  decltype(&::OSMesaMakeCurrent) makeCurrent = nullptr;
  decltype(&::OSMesaGetCurrentContext) getCurrentContext = nullptr;
  decltype(&::OSMesaGetProcAddress) getProcAddress = nullptr;
  const char* (*standIn)() = nullptr;  ///< voxbrick_osmesa_stand_in: defined by the GPU kit's stand-in only
  std::string failure;                 ///< why the library or one of its entry points could not be loaded

  bool loaded() const { return failure.empty(); }
};

template <typename Function>
void resolve(void* handle, const char* name, Function& function, std::string& failure) {
  function = reinterpret_cast<Function>(dlsym(handle, name));
  if (function == nullptr && failure.empty()) failure = std::string(kOsMesaLibrary) + " has no " + name;
}

/// The library, opened once per process (never closed: its contexts may live until exit).
const OsMesaLibrary& osMesa() {
  static const OsMesaLibrary library = [] {
    OsMesaLibrary l;
    void* handle = dlopen(kOsMesaLibrary, RTLD_NOW | RTLD_LOCAL);
    if (handle == nullptr) {
      const char* error = dlerror();
      l.failure = error != nullptr ? error : std::string(kOsMesaLibrary) + " could not be loaded";
      return l;
    }
    resolve(handle, "OSMesaCreateContextAttribs", l.createContextAttribs, l.failure);
    resolve(handle, "OSMesaDestroyContext", l.destroyContext, l.failure);
    resolve(handle, "OSMesaMakeCurrent", l.makeCurrent, l.failure);
    resolve(handle, "OSMesaGetCurrentContext", l.getCurrentContext, l.failure);
    resolve(handle, "OSMesaGetProcAddress", l.getProcAddress, l.failure);
    l.standIn = reinterpret_cast<const char* (*)()>(dlsym(handle, "voxbrick_osmesa_stand_in"));
    return l;
  }();
  return library;
}

class OsMesaContext final : public GlContext {
 public:
  explicit OsMesaContext(OSMesaContext context) : mContext(context) {}

  ~OsMesaContext() override {
    releaseCurrent();
    osMesa().destroyContext(mContext);
  }

  void makeCurrent() override {
    // OSMesa cannot be made current without a colour buffer; this 1x1 one is never drawn to (FBOs are).
    if (!osMesa().makeCurrent(mContext, mDummyBuffer.data(), GL_UNSIGNED_BYTE, 1, 1)) {
      throw RenderError("OsMesaContext::makeCurrent: OSMesaMakeCurrent failed");
    }
  }

  void releaseCurrent() override {
    if (osMesa().getCurrentContext() == mContext) osMesa().makeCurrent(nullptr, nullptr, 0, 0, 0);
  }

  Backend backend() const override { return Backend::OsMesa; }

  using GlContext::initialise;

 private:
  OSMesaContext mContext;
  std::array<uint8_t, 4> mDummyBuffer{};
};

}  // namespace

std::unique_ptr<GlContext> createOsMesaContext(std::string& failures) {
  const int attribs[] = {OSMESA_FORMAT,
                         OSMESA_RGBA,
                         OSMESA_DEPTH_BITS,
                         0,
                         OSMESA_STENCIL_BITS,
                         0,
                         OSMESA_ACCUM_BITS,
                         0,
                         OSMESA_PROFILE,
                         OSMESA_CORE_PROFILE,
                         OSMESA_CONTEXT_MAJOR_VERSION,
                         4,
                         OSMESA_CONTEXT_MINOR_VERSION,
                         3,
                         0};
  const OsMesaLibrary& library = osMesa();
  if (!library.loaded()) {
    failures += "\n  OSMesa: " + library.failure;
    return nullptr;
  }
  OSMesaContext handle = library.createContextAttribs(attribs, nullptr);
  if (handle == nullptr) {
    const std::string standIn = osMesaStandIn();
    failures += "\n  OSMesa: OSMesaCreateContextAttribs(OpenGL 4.3 core) returned no context" +
                (standIn.empty() ? std::string() : " (the library is " + standIn + ")");
    return nullptr;
  }
  auto context = std::make_unique<OsMesaContext>(handle);
  try {
    context->makeCurrent();
    context->initialise(library.getProcAddress, "OSMesaGetProcAddress", "OSMesa");
  } catch (const RenderError& error) {
    failures += std::string("\n  OSMesa: ") + error.what();
    return nullptr;
  }
  return context;
}

std::string osMesaStandIn() {
  // The stand-in defines this function; Mesa's libOSMesa does not.
  const OsMesaLibrary& library = osMesa();
  return library.standIn != nullptr ? std::string(library.standIn()) : std::string();
}

}  // namespace voxbrick::render
