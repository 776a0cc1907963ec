// Backend names.
#include "render/core/Backend.h"

#include "render/core/RenderErrors.h"

namespace voxbrick::render {

Backend parseBackend(const std::string& text) {
  return common::parseName<Backend, RenderInputError>(text, "GL backend");
}

}  // namespace voxbrick::render
