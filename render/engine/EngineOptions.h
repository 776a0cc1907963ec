// How a RenderEngine makes its context and its renderers. GL-free.
#pragma once

#include <cstddef>

#include "render/core/Backend.h"
#include "render/volume/AtlasFormat.h"

namespace voxbrick::render {

struct RenderEngineOptions {
  Backend backend = Backend::Auto;
  /// The atlases of all its renderers together (one per dataset drawn): a renderer not used for the longest is
  /// released to make room for another dataset's atlas.
  size_t gpuBudgetBytes = size_t(1) << 30;
  AtlasFormat atlasFormat = AtlasFormat::Float;         ///< how atlases store samples
  AtlasUploads atlasUploads = AtlasUploads::Auto;       ///< how bricks reach the atlases
  AtlasBricking atlasBricking = AtlasBricking::Single;  ///< how bricks lie in the atlases
};

}  // namespace voxbrick::render
