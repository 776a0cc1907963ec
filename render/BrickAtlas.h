// The GPU brick atlas: one 3D float texture cut into (B+2)^3 slots, paged from the host brick cache.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "brickstore/BrickCache.h"
#include "render/AtlasFormat.h"
#include "render/AtlasSlots.h"
#include "render/GlContext.h"
#include "render/GlObjects.h"

namespace voxbrick::render {

/// Slots are laid out in a grid inside one 3D texture of the chosen format (default GL_R32F: see AtlasFormat).
/// The number of slots is the GPU budget divided by the slot size, capped by what the volume can use and by
/// GL_MAX_3D_TEXTURE_SIZE.
///
/// Uploads and drawing: a brick is uploaded with glTexSubImage3D right before the batch that draws it; the
/// driver orders the copy before the draw without a CPU wait, and the next brick's decode (prefetched by the
/// host cache's workers) overlaps the GPU's work on the previous batch. There is no double-buffered staging:
/// llvmpipe copies synchronously anyway.
class BrickAtlas {
 public:
  /// `budgetBytes` of texture memory; `maxUsefulSlots` caps the slots (e.g. the number of bricks of the volume).
  /// Throws RenderInputError when the budget holds less than one slot.
  BrickAtlas(const GlContext& context, store::ValueType type, int brickEdge, size_t budgetBytes, int maxUsefulSlots,
             AtlasFormat format = AtlasFormat::Float);

  /// Bytes of texture one slot takes.
  static size_t slotBytes(store::ValueType type, int brickEdge, AtlasFormat format);

  AtlasSlots& slots() { return mSlots; }
  /// Copies a decoded brick into `slot` (converting it to float first for the Float and Half formats).
  void upload(AtlasSlot slot, const store::Brick& brick);
  /// What a texture fetch returns for a raw value v is v * valueScale() (normalised formats read v / 255 etc.).
  double valueScale() const { return mTexel.valueScale; }
  AtlasFormat format() const { return mFormat; }
  /// The texel origin of a slot (its first border sample).
  glm::ivec3 slotOrigin(AtlasSlot slot) const;
  /// 1 / texture size in texels, for normalising texel coordinates.
  glm::vec3 inverseSize() const { return 1.0f / glm::vec3(mTexels); }
  const Texture& texture() const { return mTexture; }
  int capacity() const { return mSlots.capacity(); }
  /// Bytes of the texture: never above the budget it was built with.
  size_t bytes() const { return size_t(mTexels.x) * size_t(mTexels.y) * size_t(mTexels.z) * mTexel.bytes; }

 private:
  const Gl& mGl;
  /// GL internal format, upload type, bytes per texel and value scale of the chosen format.
  struct TexelFormat {
    GLenum internal, type;
    size_t bytes;
    double valueScale;
  };
  static TexelFormat texelFormat(store::ValueType type, AtlasFormat format);

  AtlasFormat mFormat;
  TexelFormat mTexel;
  int mEdge;
  glm::ivec3 mGrid{1};    // slots per axis
  glm::ivec3 mTexels{1};  // texture size
  Texture mTexture;
  AtlasSlots mSlots;
  std::vector<float> mStaging;
};

}  // namespace voxbrick::render
