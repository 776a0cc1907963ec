// Multi-oriented bricking (Weiskopf, Weiler & Ertl): bricks lie in the atlas with their axes rotated from one brick
// to the next, and every drawing samples them through the rotation. The atlas must really hold rotated bricks, and
// every drawing (ray caster, slabs, each slicer), level of detail, shading, pre-integration, atlas format and upload
// path must give the image of single bricking (within 1/255).
#include <gtest/gtest.h>

#include <cmath>

#include "render/core/RenderErrors.h"
#include "render/gl/Bindings.h"
#include "render/gl/GlFixtures.h"
#include "render/gl/volume/BrickAtlas.h"
#include "render/volume/AtlasFormat.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

using test::expectClose;
using test::meanBrightness;
using test::ScratchDir;

TEST(AtlasBricking, NamesOrientationsAndPayload) {
  EXPECT_EQ(parseAtlasBricking("single"), AtlasBricking::Single);
  EXPECT_EQ(parseAtlasBricking("multi-oriented"), AtlasBricking::MultiOriented);
  EXPECT_STREQ(atlasBrickingName(AtlasBricking::MultiOriented), "multi-oriented");
  EXPECT_STREQ(atlasBrickingName(AtlasBricking::Single), "single");
  try {
    parseAtlasBricking("diagonal");
    FAIL() << "an unknown bricking must be refused";
  } catch (const RenderInputError& e) {
    EXPECT_NE(std::string(e.what()).find("'diagonal'"), std::string::npos) << e.what();
  }
  // Neighbours along every axis differ; single bricking never rotates.
  for (uint32_t i = 0; i < 4; ++i)
    for (uint32_t j = 0; j < 4; ++j)
      for (uint32_t k = 0; k < 4; ++k) {
        const store::BrickKey key{0, i, j, k};
        const int r = brickOrientation(AtlasBricking::MultiOriented, key);
        EXPECT_EQ(brickOrientation(AtlasBricking::Single, key), 0);
        EXPECT_NE(r, brickOrientation(AtlasBricking::MultiOriented, {0, i + 1, j, k}));
        EXPECT_NE(r, brickOrientation(AtlasBricking::MultiOriented, {0, i, j + 1, k}));
        EXPECT_NE(r, brickOrientation(AtlasBricking::MultiOriented, {0, i, j, k + 1}));
      }
  // The three rotations are the cyclic ones: each is a rotation, and rotating by 1 then 2 is the identity.
  const glm::ivec3 v(1, 2, 3);
  EXPECT_EQ(orientVoxel(v, 0), v);
  EXPECT_EQ(orientVoxel(v, 1), glm::ivec3(2, 3, 1));
  EXPECT_EQ(orientVoxel(v, 2), glm::ivec3(3, 1, 2));
  EXPECT_EQ(orientVoxel(orientVoxel(v, 1), 2), v);
  // The payload keeps the level in its low six bits and stays clear of the cell table's negative markers.
  EXPECT_EQ(payloadLevel(5, 0), 5);
  EXPECT_EQ(payloadLevel(5, 2) & 63, 5);
  EXPECT_EQ(payloadLevel(5, 2) >> 6, 2);
  EXPECT_LT(payloadLevel(int(store::kMaxLevels) - 1, 2), 32767);
}

/// A store of distinct values: x + 17 y + 289 z (mod 251), so any rotation of a brick changes its samples.
std::shared_ptr<const store::BrickStore> rampStore(const std::filesystem::path& path) {
  const int n = 40;
  std::vector<uint8_t> values(size_t(n) * n * n);
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        values[(size_t(z) * n + size_t(y)) * n + size_t(x)] = uint8_t((x + 17 * y + 289 * z) % 251);
  return test::prepArray<uint8_t>({n, n, n}, store::ValueType::U8, std::move(values), path, 16);
}

TEST(AtlasBricking, TheAtlasHoldsEachBrickRotated) {
  ScratchDir dir;
  const auto s = rampStore(dir / "ramp");
  auto cache = std::make_shared<store::BrickCache>(s, size_t(64) << 20, 0);
  const GlContext& context = test::context();
  const Gl& gl = context.gl();
  const int e = s->brickEdge();
  for (AtlasFormat format : {AtlasFormat::Float, AtlasFormat::Native}) {
    for (AtlasUploads uploads : {AtlasUploads::Direct, AtlasUploads::Staged}) {
      BrickAtlas atlas(context, s->type(), e, size_t(64) << 20, 4, format, uploads, AtlasBricking::MultiOriented);
      // Bricks (0,0,0), (1,0,0), (1,1,0): rotations 0, 1, 2, in slots 0, 1, 2.
      const store::BrickKey keys[] = {{0, 0, 0, 0}, {0, 1, 0, 0}, {0, 1, 1, 0}};
      for (int slot = 0; slot < 3; ++slot) {
        EXPECT_EQ(atlas.orientation(keys[slot]), slot);
        atlas.upload(AtlasSlot{slot}, *cache->get(keys[slot]));
      }
      // Read the texture back as floats (a normalised format reads v / 255).
      std::vector<float> texels;
      atlas.texture().bind(VB_UNIT_ATLAS);
      const glm::ivec3 size(glm::round(1.0f / atlas.inverseSize()));
      const int w = size.x, h = size.y, d = size.z;
      texels.resize(size_t(w) * size_t(h) * size_t(d));
      gl.glPixelStorei(GL_PACK_ALIGNMENT, 1);
      gl.glGetTexImage(GL_TEXTURE_3D, 0, GL_RED, GL_FLOAT, texels.data());
      ASSERT_EQ(gl.glGetError(), GLenum(GL_NO_ERROR));
      const float scale = format == AtlasFormat::Native ? 255.0f : 1.0f;
      for (int slot = 0; slot < 3; ++slot) {
        const auto brick = cache->get(keys[slot]);
        const auto* values = static_cast<const uint8_t*>(brick->data());
        const glm::ivec3 origin = atlas.slotOrigin(AtlasSlot{slot});
        int wrong = 0;
        for (int z = 0; z < e; ++z)
          for (int y = 0; y < e; ++y)
            for (int x = 0; x < e; ++x) {
              const glm::ivec3 a = origin + orientVoxel({x, y, z}, slot);
              const float got = texels[(size_t(a.z) * size_t(h) + size_t(a.y)) * size_t(w) + size_t(a.x)] * scale;
              const float want = values[(size_t(z) * e + size_t(y)) * e + size_t(x)];
              wrong += std::abs(got - want) > 1e-3f;
            }
        EXPECT_EQ(wrong, 0) << "slot " << slot << " format " << int(format) << " uploads " << atlasUploadsName(uploads);
      }
    }
  }
}

image::ImageF drawWith(const std::shared_ptr<const store::BrickStore>& s, const Scene& scene, AtlasBricking bricking,
                       FrameStats* stats = nullptr, size_t gpuBudget = size_t(256) << 20,
                       AtlasFormat format = AtlasFormat::Float, AtlasUploads uploads = AtlasUploads::Auto) {
  auto cache = std::make_shared<store::BrickCache>(s, size_t(256) << 20, 1);
  VolumeRenderer renderer(test::context(), cache, gpuBudget, format, uploads, bricking);
  EXPECT_EQ(renderer.atlas().bricking(), bricking);
  return renderer.render(scene, stats);
}

TEST(AtlasBricking, EveryDrawingGivesSingleBrickingsImage) {
  ScratchDir dir;
  // Mixed levels of detail: coarser bricks lie rotated too, and their payload keeps their level.
  const auto s = test::prep("synthetic:blobs,n=96", dir / "b", 16);
  struct Case {
    std::string name;
    Scene scene;
  };
  std::vector<Case> cases;
  const Scene base = test::lodScene(1.5);
  auto add = [&](const std::string& name, auto&& edit) {
    Scene scene = base;
    edit(scene);
    cases.push_back({name, scene});
  };
  add("raycast", [](Scene&) {});
  add("raycast-sub8-shaded-preintegrated", [](Scene& sc) {
    sc.subBlock = 8;
    sc.shading = true;
    sc.preIntegration = true;
  });
  add("slab8-sub8", [](Scene& sc) {
    sc.raycast = false;
    sc.slab = 8;
    sc.subBlock = 8;
  });
  for (Slicer slicer : {Slicer::Vertex, Slicer::Geometry, Slicer::VertexGeometry, Slicer::VertexLean, Slicer::Cpu})
    add(std::string("slicing-") + slicerName(slicer), [slicer](Scene& sc) {
      sc.raycast = false;
      sc.slab = 0;
      sc.slicer = slicer;
      sc.shading = slicer == Slicer::Vertex;
    });
  for (const Case& c : cases) {
    FrameStats single, multi;
    const image::ImageF want = drawWith(s, c.scene, AtlasBricking::Single, &single);
    ASSERT_GT(meanBrightness(want), 0.01) << c.name;
    ASSERT_GT(single.bricksCoarse, 0) << c.name << ": the camera must mix levels for this test to mean anything";
    test::expectSameDrawing(drawWith(s, c.scene, AtlasBricking::MultiOriented, &multi), want, 1.0 / 255, *s, c.scene,
                            "bricking-" + c.name);
    EXPECT_EQ(multi.samples, single.samples) << c.name;
  }
  // Out of core (batches), staged uploads and a store that needs converting, in its native format.
  const auto ramp = rampStore(dir / "ramp");
  Scene scene = test::lodScene(0);
  scene.window = std::array<double, 2>{0, 250};
  const size_t brick = size_t(ramp->brickEdge()) * ramp->brickEdge() * ramp->brickEdge() * 4;
  for (AtlasFormat format : {AtlasFormat::Float, AtlasFormat::Native}) {
    const image::ImageF want = drawWith(ramp, scene, AtlasBricking::Single, nullptr, 4 * brick, format);
    ASSERT_GT(meanBrightness(want), 0.01);
    FrameStats stats;
    // llvmpipe filters an 8-bit texture with 8-bit weights, quantised from each axis's texel coordinate: a rotated
    // brick puts a sample's coordinates on other axes of the atlas (other sizes), so the weights round differently,
    // by up to 1/256 of a jump between neighbours (here up to 38 of 250): 2/255 in all.
    const double bound = format == AtlasFormat::Native ? 2.0 / 255 : 1.0 / 255;
    // On a fixed-point filter (a GPU's) the float atlas rounds its weights too: test::expectSameDrawing's slack.
    test::expectSameDrawing(
        drawWith(ramp, scene, AtlasBricking::MultiOriented, &stats, 4 * brick, format, AtlasUploads::Staged), want,
        bound, *ramp, scene, std::string("bricking-ramp-") + (format == AtlasFormat::Native ? "native" : "float"));
    EXPECT_GT(stats.batches, 1);
  }
}

}  // namespace
}  // namespace voxbrick::render
