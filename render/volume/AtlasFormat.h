// How the GPU atlas stores samples: a choice made by users and configuration, so GL-free.
#pragma once

#include <span>
#include <string>

#include <glm/glm.hpp>

#include "brickstore/format/Types.h"
#include "common/EnumNames.h"

namespace voxbrick::render {

/// How the atlas stores samples. Float keeps full precision through trilinear filtering on every driver; Native
/// keeps the store's type (8/16-bit normalised, 32-bit float), a quarter or half the memory for integer stores,
/// but llvmpipe filters 8-bit textures in 8-bit fixed point; Half is 16-bit float for any store.
enum class AtlasFormat { Float, Native, Half };
inline constexpr common::EnumName<AtlasFormat> kAtlasFormatNames[] = {
    {AtlasFormat::Float, "float"}, {AtlasFormat::Native, "native"}, {AtlasFormat::Half, "half"}};
constexpr std::span<const common::EnumName<AtlasFormat>> enumNames(AtlasFormat) { return kAtlasFormatNames; }

/// "float", "native", "half"; throws RenderInputError for anything else.
AtlasFormat parseAtlasFormat(const std::string& text);

/// How bricks reach the atlas. Direct: glTexSubImage3D from the host brick (the driver copies it before the call
/// returns). Staged: the brick is written into a ring of pixel-unpack buffer regions and the texture copy is queued
/// from there, fenced, so the CPU goes on to the next brick while the GPU copies and draws (a region is reused
/// once its fence has passed). Auto: Staged on a GPU, Direct on a software rasteriser, whose texture is host memory
/// and where staging only adds a copy (nothing to overlap it with).
enum class AtlasUploads { Auto, Direct, Staged };
inline constexpr common::EnumName<AtlasUploads> kAtlasUploadsNames[] = {
    {AtlasUploads::Auto, "auto"}, {AtlasUploads::Direct, "direct"}, {AtlasUploads::Staged, "staged"}};
constexpr std::span<const common::EnumName<AtlasUploads>> enumNames(AtlasUploads) { return kAtlasUploadsNames; }

/// "auto", "direct", "staged"; throws RenderInputError for anything else.
AtlasUploads parseAtlasUploads(const std::string& text);
/// The name parseAtlasUploads reads.
inline const char* atlasUploadsName(AtlasUploads uploads) { return common::nameOf(uploads); }

/// How bricks lie in the atlas (Weiskopf, Weiler & Ertl: multi-oriented bricking). Single: every brick in the
/// volume's axis order (x fastest). MultiOriented: brick (i, j, k) is stored with its axes rotated by
/// brickOrientation(), so the texture's fast axis alternates between x, y and z from one brick to the next and a
/// texture cache that favours one walking direction sees all three in any view. Sampling accounts for each
/// brick's rotation (volume_sample.glsl, MULTI_ORIENTED); the images are the same.
enum class AtlasBricking { Single, MultiOriented };
inline constexpr common::EnumName<AtlasBricking> kAtlasBrickingNames[] = {
    {AtlasBricking::Single, "single"}, {AtlasBricking::MultiOriented, "multi-oriented"}};
constexpr std::span<const common::EnumName<AtlasBricking>> enumNames(AtlasBricking) { return kAtlasBrickingNames; }

/// "single", "multi-oriented"; throws RenderInputError for anything else.
AtlasBricking parseAtlasBricking(const std::string& text);
/// The name parseAtlasBricking reads.
inline const char* atlasBrickingName(AtlasBricking bricking) { return common::nameOf(bricking); }

/// The axis rotation brick `key` is stored with: 0 under Single; (i + j + k) mod 3 under MultiOriented, so that
/// neighbours along every axis differ.
int brickOrientation(AtlasBricking bricking, const store::BrickKey& key);

/// Where voxel v of a brick lies in its slot under rotation r: v (r = 0), v.yzx (r = 1), v.zxy (r = 2). The slot's
/// texel (a.x, a.y, a.z) holds the brick's voxel whose rotation is a; volume_sample.glsl's orient() is the mirror.
inline glm::ivec3 orientVoxel(const glm::ivec3& v, int r) {
  return r == 1 ? glm::ivec3(v.y, v.z, v.x) : r == 2 ? glm::ivec3(v.z, v.x, v.y) : v;
}

/// The payload's w for a brick of pyramid `level` stored with rotation r: level + 64 r (a store has fewer than 64
/// levels, store::kMaxLevels; negative w are the cell table's "nothing" markers). The shader reads level w & 63
/// and rotation w >> 6.
inline int payloadLevel(int level, int r) { return level + 64 * r; }

}  // namespace voxbrick::render
