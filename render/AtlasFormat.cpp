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

AtlasUploads parseAtlasUploads(const std::string& text) {
  if (text == "auto") return AtlasUploads::Auto;
  if (text == "direct") return AtlasUploads::Direct;
  if (text == "staged") return AtlasUploads::Staged;
  throw RenderInputError("atlas uploads '" + text + "' is not auto, direct or staged");
}

const char* atlasUploadsName(AtlasUploads uploads) {
  switch (uploads) {
    case AtlasUploads::Auto: return "auto";
    case AtlasUploads::Direct: return "direct";
    case AtlasUploads::Staged: return "staged";
  }
  return "auto";
}

}  // namespace voxbrick::render
