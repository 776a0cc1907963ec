// The GPU brick atlas: one 3D float texture cut into (B+2)^3 slots, paged from the host brick cache.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "brickstore/read/BrickCache.h"
#include "render/gl/GlContext.h"
#include "render/gl/GlObjects.h"
#include "render/gl/UploadRing.h"
#include "render/volume/AtlasFormat.h"
#include "render/volume/AtlasSlots.h"

namespace voxbrick::render {

/// Slots are laid out in a grid inside one 3D texture of the chosen format (default GL_R32F: see AtlasFormat).
/// The number of slots is the GPU budget divided by the slot size, capped by what the volume can use and by
/// GL_MAX_3D_TEXTURE_SIZE.
///
/// Uploads and drawing: a brick is uploaded right before the batch that draws it, and the next brick's decode
/// (prefetched by the host cache's workers) overlaps the GPU's work on the previous batch. With staged uploads
/// (AtlasUploads) the brick is written into a fenced ring of pixel-unpack buffer regions and the texture copy is
/// queued from there, so the CPU does not wait for the copy either; the ring (at most kStagingBytes, an eighth of
/// the budget) is part of the budget. Without a ring of two regions or more in the budget, uploads are direct.
class BrickAtlas {
 public:
  /// The most bytes of pixel-unpack staging an atlas keeps.
  static constexpr size_t kStagingBytes = size_t(8) << 20;

  /// `budgetBytes` of GPU memory for the texture and its upload staging; `maxUsefulSlots` caps the slots (e.g. the
  /// number of bricks of the volume). `uploads` Auto is resolved with the context (resolveUploads). Throws
  /// RenderInputError when the budget holds less than one slot.
  BrickAtlas(const GlContext& context, store::ValueType type, int brickEdge, size_t budgetBytes, int maxUsefulSlots,
             AtlasFormat format = AtlasFormat::Float, AtlasUploads uploads = AtlasUploads::Auto,
             AtlasBricking bricking = AtlasBricking::Single);

  /// Bytes of texture one slot takes.
  static size_t slotBytes(store::ValueType type, int brickEdge, AtlasFormat format);
  /// Bytes one brick takes on its way to a slot: slotBytes, as every upload converts to the slot's texel first.
  static size_t uploadBytes(store::ValueType type, int brickEdge, AtlasFormat format);
  /// The staging bytes an atlas under `budgetBytes` keeps when its uploads are staged: whole regions of
  /// uploadBytes, at most kStagingBytes and an eighth of the budget, and 0 when that is fewer than two.
  static size_t stagingBytes(store::ValueType type, int brickEdge, size_t budgetBytes, AtlasFormat format);
  /// Auto as Staged on a GPU and Direct on a software rasteriser; the others as they are.
  static AtlasUploads resolveUploads(const GlContext& context, AtlasUploads uploads);

  AtlasSlots& slots() { return mSlots; }
  const AtlasSlots& slots() const { return mSlots; }
  /// Copies a decoded brick into `slot` (converted to floats for the Float format and to halves, round to nearest
  /// even by common::Half, for the Half format), its axes rotated by orientation() (orientVoxel).
  void upload(AtlasSlot slot, const store::Brick& brick);
  /// The axis rotation brick `key` has in its slot: brickOrientation(bricking(), key).
  int orientation(const store::BrickKey& key) const { return brickOrientation(mBricking, key); }
  AtlasBricking bricking() const { return mBricking; }
  /// What a texture fetch returns for a raw value v is v * valueScale() (normalised formats read v / 255 etc.).
  double valueScale() const { return mTexel.valueScale; }
  AtlasFormat format() const { return mFormat; }
  /// Direct or Staged, as the atlas uploads (Staged only with a ring in the budget).
  AtlasUploads uploads() const { return mRing ? AtlasUploads::Staged : AtlasUploads::Direct; }
  /// How many staged uploads waited for the GPU to finish with a ring region (0 when direct).
  size_t stagingWaits() const { return mRing ? mRing->waits() : 0; }
  /// The texel origin of a slot (its first border sample).
  glm::ivec3 slotOrigin(AtlasSlot slot) const;
  /// 1 / texture size in texels, for normalising texel coordinates.
  glm::vec3 inverseSize() const { return 1.0f / glm::vec3(mTexels); }
  const Texture& texture() const { return mTexture; }
  int capacity() const { return mSlots.capacity(); }
  /// Bytes of the texture and the upload staging: never above the budget it was built with.
  size_t bytes() const {
    return size_t(mTexels.x) * size_t(mTexels.y) * size_t(mTexels.z) * mTexel.bytes + (mRing ? mRing->bytes() : 0);
  }

 private:
  /// The constructor, with `staging` bytes of the budget for the upload ring (0: direct uploads).
  BrickAtlas(const GlContext& context, store::ValueType type, int brickEdge, size_t staging, size_t budgetBytes,
             int maxUsefulSlots, AtlasFormat format, AtlasBricking bricking);

  const Gl& mGl;
  /// GL internal format, upload type, bytes per texel and value scale of the chosen format.
  struct TexelFormat {
    GLenum internal, type;
    size_t bytes;
    double valueScale;
  };
  static TexelFormat texelFormat(store::ValueType type, AtlasFormat format);
  /// Whether a brick of `type` is converted on the CPU on its way to a slot (into floats or halves).
  bool converts(store::ValueType type) const;

  AtlasFormat mFormat;
  AtlasBricking mBricking;
  TexelFormat mTexel;
  int mEdge;
  glm::ivec3 mGrid{1};    // slots per axis
  glm::ivec3 mTexels{1};  // texture size
  Texture mTexture;
  AtlasSlots mSlots;
  std::vector<uint8_t> mStaging;      // direct uploads converted to float or rotated
  std::unique_ptr<UploadRing> mRing;  // staged uploads
  /// Writes `brick` into `out` as the upload type (converted to float where the format needs it), rotated by
  /// `orientation`.
  void convert(const store::Brick& brick, void* out, int orientation) const;
};

}  // namespace voxbrick::render
