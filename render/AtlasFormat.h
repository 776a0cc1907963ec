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

/// How bricks reach the atlas. Direct: glTexSubImage3D from the host brick (the driver copies it before the call
/// returns). Staged: the brick is written into a ring of pixel-unpack buffer regions and the texture copy is queued
/// from there, fenced, so the CPU goes on to the next brick while the GPU copies and draws (a region is reused
/// once its fence has passed). Auto: Staged on a GPU, Direct on a software rasteriser, whose texture is host memory
/// and where staging only adds a copy (bench/results/uploads.md).
enum class AtlasUploads { Auto, Direct, Staged };

/// "auto", "direct", "staged"; throws RenderInputError for anything else.
AtlasUploads parseAtlasUploads(const std::string& text);
/// The name parseAtlasUploads reads.
const char* atlasUploadsName(AtlasUploads uploads);

}  // namespace voxbrick::render
