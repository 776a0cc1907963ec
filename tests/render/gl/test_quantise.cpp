// A quantised store renders like the f32 store of the same input: the default window (each store's own range) and
// a window given in the input's values both normalise the same, so the transfer function sees the same values up
// to half a quantisation step.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "brickstore/ingest/Sources.h"
#include "image/Image.h"
#include "render/gl/GlFixtures.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

using test::meanBrightness;
using test::renderStore;
using test::ScratchDir;

std::shared_ptr<const store::BrickStore> prepQuantised(const std::string& spec, const std::filesystem::path& out,
                                                       std::optional<store::ValueType> type) {
  store::PrepOptions options;
  options.brickSize = 16;
  options.writeVdb = false;
  if (type) {
    auto first = store::openSource(spec, {});
    const store::Level0Stats range = store::scanLevel0(*first, 0.0, store::NonFinitePolicy::Background);
    options.quantise = store::Quantisation{*type, range.min, range.max};
  }
  auto source = store::openSource(spec, {});
  store::prepStore(*source, out, options);
  return store::BrickStore::open(out);
}

TEST(QuantisedStore, RendersLikeTheFloatStore) {
  ScratchDir dir;
  const std::string spec = "synthetic:blobs,n=64";
  const auto f32 = prepQuantised(spec, dir / "f32", std::nullopt);
  const auto u8 = prepQuantised(spec, dir / "u8", store::ValueType::U8);
  const auto u16 = prepQuantised(spec, dir / "u16", store::ValueType::U16);
  ASSERT_EQ(u8->meta().type, store::ValueType::U8);
  for (const bool window : {false, true}) {
    Scene scene;
    scene.width = 96;
    scene.height = 96;
    scene.camera.azimuth = 30;
    scene.camera.elevation = 20;
    scene.camera.distance = 2.5;  // the view these bounds were set for (before the fitted, +z-up default)
    scene.camera.upAxis = UpAxis::PosY;
    scene.transferFunction = TransferFunction::load("hot");
    if (window) scene.window = std::array<double, 2>{0.2, 0.9};  // in the input's values
    const image::ImageF reference = renderStore(f32, scene);
    ASSERT_GT(meanBrightness(reference), 0.02);
    // Measured: 60-70 dB for u8 (a value moves by at most half of 1/255 of the window), more for u16.
    const double psnr8 = image::compareImages(renderStore(u8, scene), reference).psnr;
    const double psnr16 = image::compareImages(renderStore(u16, scene), reference).psnr;
    EXPECT_GE(psnr8, 50.0) << "window " << window;
    std::printf("window %d: u8 %.1f dB, u16 %.1f dB against f32\n", int(window), psnr8, psnr16);
    EXPECT_GE(psnr16, psnr8) << "window " << window;
  }
}

}  // namespace
}  // namespace voxbrick::render
