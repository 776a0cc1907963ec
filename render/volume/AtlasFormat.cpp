// Atlas format names.
#include "render/volume/AtlasFormat.h"

#include "render/core/RenderErrors.h"

namespace voxbrick::render {

AtlasFormat parseAtlasFormat(const std::string& text) {
  return common::parseName<AtlasFormat, RenderInputError>(text, "atlas format");
}

AtlasUploads parseAtlasUploads(const std::string& text) {
  return common::parseName<AtlasUploads, RenderInputError>(text, "atlas uploads");
}

AtlasBricking parseAtlasBricking(const std::string& text) {
  return common::parseName<AtlasBricking, RenderInputError>(text, "atlas bricking");
}

int brickOrientation(AtlasBricking bricking, const store::BrickKey& key) {
  if (bricking == AtlasBricking::Single) return 0;
  return int((uint64_t(key.i) + key.j + key.k) % 3);
}

}  // namespace voxbrick::render
