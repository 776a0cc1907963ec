// The GPU brick atlas: texture allocation and brick upload.
#include "render/gl/volume/BrickAtlas.h"

#include <algorithm>
#include <cstring>

#include "common/Half.h"
#include "render/core/RenderErrors.h"
#include "render/gl/Bindings.h"

namespace voxbrick::render {

BrickAtlas::TexelFormat BrickAtlas::texelFormat(store::ValueType type, AtlasFormat format) {
  if (format == AtlasFormat::Float) return {GL_R32F, GL_FLOAT, 4, 1.0};
  // Half: converted here (common::Half, round to nearest even as Mesa's conversion), so the driver copies texels on
  // every upload path; converting floats itself, one path may round differently from another (NVIDIA's did: staged
  // frames differed from direct ones by 5e-4).
  if (format == AtlasFormat::Half) return {GL_R16F, GL_HALF_FLOAT, 2, 1.0};
  switch (type) {
    case store::ValueType::U8: return {GL_R8, GL_UNSIGNED_BYTE, 1, 1.0 / 255};
    case store::ValueType::U16: return {GL_R16, GL_UNSIGNED_SHORT, 2, 1.0 / 65535};
    case store::ValueType::I16: return {GL_R16_SNORM, GL_SHORT, 2, 1.0 / 32767};
    case store::ValueType::F32: break;
  }
  return {GL_R32F, GL_FLOAT, 4, 1.0};
}

namespace {

int slotCapacity(int edge, size_t texelBytes, size_t budgetBytes, int maxUsefulSlots) {
  const size_t slotBytes = size_t(edge) * size_t(edge) * size_t(edge) * texelBytes;
  const size_t bySlots = budgetBytes / slotBytes;
  if (bySlots < 1)
    throw RenderInputError("GPU budget of " + std::to_string(budgetBytes) + " bytes holds no brick (one brick takes " +
                           std::to_string(slotBytes) + " bytes)");
  return static_cast<int>(std::min<size_t>(bySlots, size_t(std::max(1, maxUsefulSlots))));
}

}  // namespace

size_t BrickAtlas::uploadBytes(store::ValueType type, int brickEdge, AtlasFormat format) {
  return slotBytes(type, brickEdge, format);
}

bool BrickAtlas::converts(store::ValueType type) const {
  return mTexel.type == GL_HALF_FLOAT || (type != store::ValueType::F32 && mTexel.type == GL_FLOAT);
}

size_t BrickAtlas::stagingBytes(store::ValueType type, int brickEdge, size_t budgetBytes, AtlasFormat format) {
  const size_t region = uploadBytes(type, brickEdge, format);
  const size_t regions = std::min(kStagingBytes, budgetBytes / 8) / region;
  return regions >= 2 ? regions * region : 0;
}

AtlasUploads BrickAtlas::resolveUploads(const GlContext& context, AtlasUploads uploads) {
  if (uploads != AtlasUploads::Auto) return uploads;
  return context.software() ? AtlasUploads::Direct : AtlasUploads::Staged;
}

BrickAtlas::BrickAtlas(const GlContext& context, store::ValueType type, int brickEdge, size_t budgetBytes,
                       int maxUsefulSlots, AtlasFormat format, AtlasUploads uploads, AtlasBricking bricking)
    : BrickAtlas(context, type, brickEdge,
                 resolveUploads(context, uploads) == AtlasUploads::Staged
                     ? stagingBytes(type, brickEdge, budgetBytes, format)
                     : 0,
                 budgetBytes, maxUsefulSlots, format, bricking) {}

BrickAtlas::BrickAtlas(const GlContext& context, store::ValueType type, int brickEdge, size_t staging,
                       size_t budgetBytes, int maxUsefulSlots, AtlasFormat format, AtlasBricking bricking)
    : mGl(context.gl()),
      mFormat(format),
      mBricking(bricking),
      mTexel(texelFormat(type, format)),
      mEdge(brickEdge),
      mSlots(slotCapacity(brickEdge, mTexel.bytes, budgetBytes - staging, maxUsefulSlots)) {
  budgetBytes -= staging;
  const int perAxis = std::max(1, context.limits().max3DTextureSize / brickEdge);
  const int want = mSlots.capacity();
  mGrid.x = std::min(want, perAxis);
  mGrid.y = std::min((want + mGrid.x - 1) / mGrid.x, perAxis);
  mGrid.z = std::min((want + mGrid.x * mGrid.y - 1) / (mGrid.x * mGrid.y), perAxis);
  // Rounding up to whole rows and layers may leave spare slots in the texture: fine within the budget, but where
  // the budget is what limits the slots, the texture must not outgrow it. Then rows are balanced (as long as the
  // slots need rows, no longer) and only whole rows and layers are taken: a few slots go unused instead.
  const size_t slotBytes = BrickAtlas::slotBytes(type, brickEdge, format);
  if (size_t(mGrid.x) * size_t(mGrid.y) * size_t(mGrid.z) * slotBytes > budgetBytes) {
    mGrid.x = want / ((want + perAxis - 1) / perAxis);
    const int rows = want / mGrid.x;
    mGrid.z = std::min((rows + perAxis - 1) / perAxis, perAxis);
    mGrid.y = std::min(rows / mGrid.z, perAxis);
  }
  if (mGrid.x * mGrid.y * mGrid.z != want) mSlots = AtlasSlots(std::min(want, mGrid.x * mGrid.y * mGrid.z));
  mTexels = mGrid * brickEdge;

  mTexture = Texture(mGl, GL_TEXTURE_3D);
  mTexture.bind(VB_UNIT_ATLAS);
  mGl.glTexStorage3D(GL_TEXTURE_3D, 1, mTexel.internal, mTexels.x, mTexels.y, mTexels.z);
  mGl.glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  mGl.glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  for (GLenum wrap : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R})
    mGl.glTexParameteri(GL_TEXTURE_3D, wrap, GL_CLAMP_TO_EDGE);
  if (GLenum error = mGl.glGetError(); error != GL_NO_ERROR)
    throw RenderError("BrickAtlas: cannot allocate a " + std::to_string(mTexels.x) + "x" + std::to_string(mTexels.y) +
                      "x" + std::to_string(mTexels.z) + " texture (GL error " + std::to_string(error) + ")");
  if (staging > 0) {
    const size_t region = uploadBytes(type, brickEdge, format);
    mRing = std::make_unique<UploadRing>(mGl, region, int(staging / region));
  } else if (converts(type) || bricking != AtlasBricking::Single) {
    mStaging.resize(uploadBytes(type, brickEdge, format));
  }
}

size_t BrickAtlas::slotBytes(store::ValueType type, int brickEdge, AtlasFormat format) {
  return size_t(brickEdge) * size_t(brickEdge) * size_t(brickEdge) * texelFormat(type, format).bytes;
}

glm::ivec3 BrickAtlas::slotOrigin(AtlasSlot slot) const {
  const int i = slot.index;
  return glm::ivec3(i % mGrid.x, (i / mGrid.x) % mGrid.y, i / (mGrid.x * mGrid.y)) * mEdge;
}

namespace {

/// Copies an edge^3 brick `in` to `out` with its axes rotated by r (orientVoxel): out's texel a holds in's voxel v
/// with a = orientVoxel(v, r); each value converted by Out(value) (common::Half: to the nearest half).
template <typename In, typename Out>
void rotateBrick(const In* in, Out* out, int edge, int r) {
  const size_t e = size_t(edge);
  if (r == 0) {
    for (size_t i = 0; i < e * e * e; ++i) out[i] = Out(in[i]);
    return;
  }
  // Strides in `out` of a step along the brick's x, y and z: r = 1 puts x at a.z, y at a.x, z at a.y; r = 2 puts
  // x at a.y, y at a.z, z at a.x.
  const size_t sx = r == 1 ? e * e : e, sy = r == 1 ? 1 : e * e, sz = r == 1 ? e : 1;
  for (size_t z = 0; z < e; ++z)
    for (size_t y = 0; y < e; ++y) {
      const In* row = in + (z * e + y) * e;
      Out* to = out + z * sz + y * sy;
      for (size_t x = 0; x < e; ++x) to[x * sx] = Out(row[x]);
    }
}

}  // namespace

void BrickAtlas::convert(const store::Brick& brick, void* out, int orientation) const {
  const size_t n = size_t(mEdge) * size_t(mEdge) * size_t(mEdge);
  if (mTexel.type == GL_HALF_FLOAT) {
    store::dispatchType(brick.type(), [&](auto tag) {
      rotateBrick(static_cast<const decltype(tag)*>(brick.data()), static_cast<common::Half*>(out), mEdge, orientation);
    });
  } else if (brick.type() != store::ValueType::F32 && mTexel.type == GL_FLOAT) {
    store::dispatchType(brick.type(), [&](auto tag) {
      rotateBrick(static_cast<const decltype(tag)*>(brick.data()), static_cast<float*>(out), mEdge, orientation);
    });
  } else if (orientation != 0) {
    store::dispatchType(brick.type(), [&](auto tag) {
      using T = decltype(tag);
      rotateBrick(static_cast<const T*>(brick.data()), static_cast<T*>(out), mEdge, orientation);
    });
  } else {
    std::memcpy(out, brick.data(), n * store::valueSize(brick.type()));
  }
}

void BrickAtlas::upload(AtlasSlot slot, const store::Brick& brick) {
  const glm::ivec3 o = slotOrigin(slot);
  const int orientation = this->orientation(brick.key());
  mTexture.bind(VB_UNIT_ATLAS);
  mGl.glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  if (mRing) {
    convert(brick, mRing->map(), orientation);
    const size_t offset = mRing->unmap();
    mGl.glTexSubImage3D(GL_TEXTURE_3D, 0, o.x, o.y, o.z, mEdge, mEdge, mEdge, GL_RED, mTexel.type,
                        reinterpret_cast<const void*>(offset));
    mRing->fence();
    return;
  }
  const void* data = brick.data();
  if (!mStaging.empty() && (orientation != 0 || converts(brick.type()))) {
    convert(brick, mStaging.data(), orientation);
    data = mStaging.data();
  }
  mGl.glTexSubImage3D(GL_TEXTURE_3D, 0, o.x, o.y, o.z, mEdge, mEdge, mEdge, GL_RED, mTexel.type, data);
}

}  // namespace voxbrick::render
