// How the GPU atlas stores samples: a choice made by users and configuration, so GL-free.
#pragma once

#include <string>

namespace voxbrick::render {

/// How the atlas stores samples. Float keeps full precision through trilinear filtering on every driver; Native
/// keeps the store's type (8/16-bit normalised, 32-bit float), a quarter or half the memory for integer stores,
/// but llvmpipe filters 8-bit textures in 8-bit fixed point; Half is 16-bit float for any store.
enum class AtlasFormat { Float, Native, Half };

/// "float", "native", "half"; throws RenderInputError for anything else.
AtlasFormat parseAtlasFormat(const std::string& text);

}  // namespace voxbrick::render
