// Atlas format names.
#include "render/volume/AtlasFormat.h"

#include "render/core/RenderErrors.h"

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

AtlasBricking parseAtlasBricking(const std::string& text) {
  if (text == "single") return AtlasBricking::Single;
  if (text == "multi-oriented") return AtlasBricking::MultiOriented;
  throw RenderInputError("atlas bricking '" + text + "' is not single or multi-oriented");
}

const char* atlasBrickingName(AtlasBricking bricking) {
  return bricking == AtlasBricking::MultiOriented ? "multi-oriented" : "single";
}

int brickOrientation(AtlasBricking bricking, const store::BrickKey& key) {
  if (bricking == AtlasBricking::Single) return 0;
  return int((uint64_t(key.i) + key.j + key.k) % 3);
}

}  // namespace voxbrick::render
