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

class OsMesaContext final : public GlContext {
 public:
  explicit OsMesaContext(OSMesaContext context) : mContext(context) {}

  ~OsMesaContext() override {
    releaseCurrent();
    OSMesaDestroyContext(mContext);
  }

  void makeCurrent() override {
    // OSMesa cannot be made current without a colour buffer; this 1x1 one is never drawn to (FBOs are).
    if (!OSMesaMakeCurrent(mContext, mDummyBuffer.data(), GL_UNSIGNED_BYTE, 1, 1)) {
      throw RenderError("OsMesaContext::makeCurrent: OSMesaMakeCurrent failed");
    }
  }

  void releaseCurrent() override {
    if (OSMesaGetCurrentContext() == mContext) OSMesaMakeCurrent(nullptr, nullptr, 0, 0, 0);
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
  OSMesaContext handle = OSMesaCreateContextAttribs(attribs, nullptr);
  if (handle == nullptr) {
    const std::string standIn = osMesaStandIn();
    failures += "\n  OSMesa: OSMesaCreateContextAttribs(OpenGL 4.3 core) returned no context" +
                (standIn.empty() ? std::string() : " (the library is " + standIn + ")");
    return nullptr;
  }
  auto context = std::make_unique<OsMesaContext>(handle);
  try {
    context->makeCurrent();
    context->initialise(OSMesaGetProcAddress, "OSMesaGetProcAddress", "OSMesa");
  } catch (const RenderError& error) {
    failures += std::string("\n  OSMesa: ") + error.what();
    return nullptr;
  }
  return context;
}

std::string osMesaStandIn() {
  // The stand-in defines this function; Mesa's libOSMesa does not.
  using Describe = const char* (*)();
  const auto describe = reinterpret_cast<Describe>(dlsym(RTLD_DEFAULT, "voxbrick_osmesa_stand_in"));
  return describe != nullptr ? std::string(describe()) : std::string();
}

}  // namespace voxbrick::render
