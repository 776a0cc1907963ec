// Backend names.
#include "render/core/Backend.h"

#include "render/core/RenderErrors.h"

namespace voxbrick::render {

const char* backendName(Backend backend) {
  switch (backend) {
    case Backend::Auto: return "auto";
    case Backend::Egl: return "egl";
    case Backend::OsMesa: return "osmesa";
  }
  return "unknown";
}

Backend parseBackend(const std::string& text) {
  if (text == "auto") return Backend::Auto;
  if (text == "egl") return Backend::Egl;
  if (text == "osmesa") return Backend::OsMesa;
  throw RenderInputError("parseBackend: unknown GL backend \"" + text + "\" (expected auto, egl or osmesa)");
}

}  // namespace voxbrick::render
