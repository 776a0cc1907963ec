// Staged uploads (a fenced ring of pixel-unpack buffer regions) give the same frames as direct ones, in and out of
// core, for every atlas format and a store that needs converting; the ring is part of the GPU budget.
#include <gtest/gtest.h>

#include <cmath>

#include "render/core/RenderErrors.h"
#include "render/gl/GlFixtures.h"
#include "render/gl/volume/BrickAtlas.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

using test::ScratchDir;

/// A u8 store of a soft ball with rings: values 0..255, every brick of a 64³ volume in bricks of 16 differs.
std::shared_ptr<const store::BrickStore> ballStore(const std::filesystem::path& path) {
  const int n = 64;
  std::vector<uint8_t> values(size_t(n) * n * n);
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const double r = std::hypot(x - 31.5, y - 31.5, z - 31.5) / 32;
        const double v = r < 1 ? (1 - r) * (0.6 + 0.4 * std::sin(18 * r + 0.2 * x)) : 0;
        values[(size_t(z) * n + size_t(y)) * n + size_t(x)] = uint8_t(std::lround(255 * std::clamp(v, 0.0, 1.0)));
      }
  return test::prepArray<uint8_t>({n, n, n}, store::ValueType::U8, std::move(values), path, 16);
}

struct Frame {
  image::ImageF image;
  FrameStats stats;
  size_t gpuBytes = 0;
  AtlasUploads uploads = AtlasUploads::Auto;
};

Frame draw(const std::shared_ptr<const store::BrickStore>& s, size_t budget, AtlasFormat format, AtlasUploads uploads) {
  auto cache = std::make_shared<store::BrickCache>(s, size_t(64) << 20, 1);
  VolumeRenderer renderer(test::context(), cache, budget, format, uploads);
  Frame f;
  renderer.render(test::lodScene(0));  // a second frame re-pages what the first evicted: the ring comes round
  f.image = renderer.render(test::lodScene(0), &f.stats);
  f.gpuBytes = renderer.gpuBytes();
  f.uploads = renderer.atlas().uploads();
  return f;
}

TEST(AtlasUploads, StagedFramesEqualDirectOnesInAndOutOfCore) {
  ScratchDir dir;
  const auto f32 = test::prep("synthetic:blobs,n=64,seed=3", dir / "f32", 16);
  const auto u8 = ballStore(dir / "u8");
  for (const auto& [name, s] : {std::pair{"f32", f32}, std::pair{"u8", u8}})
    for (AtlasFormat format : {AtlasFormat::Float, AtlasFormat::Native, AtlasFormat::Half}) {
      const std::string what = std::string(name) + ", format " + std::to_string(int(format));
      // In core: the budget holds every brick and the ring.
      const Frame direct = draw(s, size_t(64) << 20, format, AtlasUploads::Direct);
      const Frame staged = draw(s, size_t(64) << 20, format, AtlasUploads::Staged);
      ASSERT_EQ(direct.uploads, AtlasUploads::Direct) << what;
      ASSERT_EQ(staged.uploads, AtlasUploads::Staged) << what;
      ASSERT_GT(test::meanBrightness(direct.image), 0.01) << what;
      test::expectClose(staged.image, direct.image, 0.0, what + ", in core");
      EXPECT_LE(staged.gpuBytes, size_t(64) << 20) << what;

      // Out of core with the same slots: the staged budget (40 slots) is the direct one plus its ring.
      const size_t tight = 40 * BrickAtlas::slotBytes(s->type(), s->brickEdge(), format);
      const size_t staging = BrickAtlas::stagingBytes(s->type(), s->brickEdge(), tight, format);
      ASSERT_GE(staging, 2 * BrickAtlas::uploadBytes(s->type(), s->brickEdge(), format)) << what;
      const Frame outDirect = draw(s, tight - staging, format, AtlasUploads::Direct);
      const Frame outStaged = draw(s, tight, format, AtlasUploads::Staged);
      ASSERT_EQ(outStaged.uploads, AtlasUploads::Staged) << what;
      EXPECT_GT(outStaged.stats.batches, 1) << what << ": out of core";
      EXPECT_GT(outStaged.stats.bricksPagedIn, 0) << what;
      EXPECT_EQ(outStaged.stats.batches, outDirect.stats.batches) << what;
      test::expectClose(outStaged.image, outDirect.image, 0.0, what + ", out of core");
      test::expectClose(outStaged.image, direct.image, 1.0 / 255, what + ", out of core against in core");
      EXPECT_LE(outStaged.gpuBytes, tight) << what << ": the ring is inside the budget";
    }
}

TEST(AtlasUploads, TheRingIsPartOfTheBudgetAndNeverCrowdsTheAtlasOut) {
  const int edge = 18;
  const size_t region = BrickAtlas::uploadBytes(store::ValueType::F32, edge, AtlasFormat::Float);
  const size_t slot = BrickAtlas::slotBytes(store::ValueType::F32, edge, AtlasFormat::Float);
  EXPECT_EQ(BrickAtlas::uploadBytes(store::ValueType::F32, edge, AtlasFormat::Half), region / 2)
      << "halves go up, converted on the CPU: no driver conversion, the same on every path";
  EXPECT_EQ(BrickAtlas::uploadBytes(store::ValueType::U8, edge, AtlasFormat::Native), region / 4);
  // A small budget has no room for two regions: uploads stay direct, and the atlas takes the whole budget.
  const size_t small = 10 * slot;
  EXPECT_EQ(BrickAtlas::stagingBytes(store::ValueType::F32, edge, small, AtlasFormat::Float), 0u);
  BrickAtlas tiny(test::context(), store::ValueType::F32, edge, small, 1 << 20, AtlasFormat::Float,
                  AtlasUploads::Staged);
  EXPECT_EQ(tiny.uploads(), AtlasUploads::Direct);
  EXPECT_EQ(tiny.capacity(), 10);
  // A large one keeps at most kStagingBytes, never more than an eighth of it.
  for (size_t budget : {size_t(40) * slot, size_t(256) << 20}) {
    const size_t staging = BrickAtlas::stagingBytes(store::ValueType::F32, edge, budget, AtlasFormat::Float);
    EXPECT_GE(staging, 2 * region);
    EXPECT_LE(staging, std::min(BrickAtlas::kStagingBytes, budget / 8));
    EXPECT_EQ(staging % region, 0u);
    BrickAtlas atlas(test::context(), store::ValueType::F32, edge, budget, 1 << 20, AtlasFormat::Float,
                     AtlasUploads::Staged);
    EXPECT_EQ(atlas.uploads(), AtlasUploads::Staged);
    EXPECT_LE(atlas.bytes(), budget);
    EXPECT_GE(size_t(atlas.capacity()) * slot, (budget - staging) * 9 / 10);
  }
  // Auto: staged on a GPU, direct on a software rasteriser (where the texture is host memory anyway).
  EXPECT_EQ(BrickAtlas::resolveUploads(test::context(), AtlasUploads::Auto),
            test::context().software() ? AtlasUploads::Direct : AtlasUploads::Staged);
  EXPECT_EQ(parseAtlasUploads("staged"), AtlasUploads::Staged);
  EXPECT_THROW(parseAtlasUploads("pbo"), RenderInputError);
}

}  // namespace
}  // namespace voxbrick::render
