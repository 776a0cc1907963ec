// The filter precision probe (render/gl/FilterProbe.h) measures what the texture unit does: llvmpipe filters a float
// texture in float and an 8-bit one with 8-bit weights; a GPU's weights are fixed-point for every format.
#include <gtest/gtest.h>

#include <cmath>

#include "render/gl/FilterProbe.h"
#include "render/gl/GlFixtures.h"

namespace voxbrick::render {
namespace {

TEST(FilterProbe, MeasuresTheWeightStepOfEachFormat) {
  const FilterPrecision f32 = measureFilterPrecision(test::context(), GL_R32F);
  const FilterPrecision r8 = measureFilterPrecision(test::context(), GL_R8);
  std::printf("[ info ] %s: R32F weight step %.3g (error %.3g), R8 weight step %.3g (error %.3g)\n",
              test::context().describe().c_str(), f32.weightStep, f32.maxWeightError, r8.weightStep, r8.maxWeightError);
  for (const FilterPrecision& p : {f32, r8}) {
    // Whatever the filter, a weight is within one step of the exact one, and a step is a power of two.
    EXPECT_LE(p.maxWeightError, p.weightStep > 0 ? p.weightStep : 1e-5);
  }
  // An 8-bit texture's values are 1/255 apart: no filter resolves them finer than 12 bits here.
  EXPECT_GT(r8.weightStep, 0.0);
  if (test::context().software()) {
    EXPECT_EQ(f32.weightStep, 0.0) << "llvmpipe filters floats in float";
    EXPECT_LT(f32.maxWeightError, 1e-6);
    EXPECT_EQ(r8.subTexelBits(), 8) << "and 8-bit textures with 8-bit weights";
  }
  // The fixture's value is the float atlas's.
  EXPECT_EQ(test::filterPrecision().weightStep, f32.weightStep);
}

}  // namespace
}  // namespace voxbrick::render
