// Atlas format names.
#include "render/AtlasFormat.h"

#include "render/RenderErrors.h"

namespace voxbrick::render {

AtlasFormat parseAtlasFormat(const std::string& text) {
  if (text == "float") return AtlasFormat::Float;
  if (text == "native") return AtlasFormat::Native;
  if (text == "half") return AtlasFormat::Half;
  throw RenderInputError("atlas format '" + text + "' is not float, native or half");
}

}  // namespace voxbrick::render
