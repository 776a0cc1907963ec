// The time-budget planner of interactive frames (render/core/Interactive.h), without GL: the choice by predicted cost,
// the measured rate, and the bilinear scale-up.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <tuple>
#include <vector>

#include "render/core/Interactive.h"
#include "render/core/RenderErrors.h"

namespace voxbrick::render {
namespace {

/// A cost like a ray caster's: pixels times samples along a ray, the ray's samples 400 / step, a coarser level of
/// detail halving them per doubling of its pixels.
double modelSamples(const Scene& s) {
  const double lodFactor = s.lod > 1 ? 1 / s.lod : 1;
  return double(s.width) * s.height * (400 / s.step) * lodFactor;
}

Scene scene512(double budgetMs) {
  Scene s;
  s.width = s.height = 512;
  s.interactive = true;
  s.timeBudgetMs = budgetMs;
  return s;
}

TEST(Interactive, HalvingTheBudgetKeepsThePredictionWithinIt) {
  const double rate = 5e5;  // samples per ms: the exact frame takes about 280 ms
  for (double budget : {200.0, 100.0, 50.0, 25.0, 12.5}) {
    const InteractiveChoice c = chooseInteractive(scene512(budget), rate, 2, modelSamples);
    EXPECT_LE(c.predictedMs, budget) << budget;
    EXPECT_NEAR(c.predictedMs,
                2 + modelSamples(interactiveScene(scene512(budget), interactiveLadder()[size_t(c.rung)])) / rate, 1e-9);
    // The next rung up would not have fitted: the choice is the best that fits.
    if (c.rung > 0) {
      const Scene better = interactiveScene(scene512(budget), interactiveLadder()[size_t(c.rung - 1)]);
      EXPECT_GT(2 + modelSamples(better) / rate, budget) << budget;
    }
  }
  // A smaller budget never chooses a dearer drawing.
  EXPECT_GE(chooseInteractive(scene512(50), rate, 0, modelSamples).rung,
            chooseInteractive(scene512(100), rate, 0, modelSamples).rung);
}

TEST(Interactive, AFastRateKeepsFullQuality) {
  const InteractiveChoice c = chooseInteractive(scene512(100), 1e9, 0, modelSamples);
  EXPECT_EQ(c.rung, 0);
  EXPECT_EQ(c.width, 512);
  EXPECT_EQ(c.height, 512);
  EXPECT_DOUBLE_EQ(c.scale, 1);
  EXPECT_DOUBLE_EQ(c.step, Scene{}.step);
  EXPECT_DOUBLE_EQ(c.lod, Scene{}.lod);
}

TEST(Interactive, TheDrawingNeverShrinksBelowTheFloor) {
  // A hopeless budget: the last rung, each side at least the floor.
  const InteractiveChoice c = chooseInteractive(scene512(10), 1, 0, modelSamples);
  EXPECT_EQ(c.rung, int(interactiveLadder().size()) - 1);
  EXPECT_GE(c.width, kMinInteractiveSide);
  EXPECT_GE(c.height, kMinInteractiveSide);
  // A requested image below the floor keeps its own size; a tall one keeps its aspect (its shorter side at the
  // floor, the longer one by the same factor: the drawing's camera sees what the scene's does).
  Scene small = scene512(10);
  small.width = 40, small.height = 30;
  const InteractiveChoice s = chooseInteractive(small, 1, 0, modelSamples);
  EXPECT_EQ(s.width, 40);
  EXPECT_EQ(s.height, 30);
  Scene tall = scene512(10);
  tall.width = 300, tall.height = 1200;
  const Scene drawn = interactiveScene(tall, interactiveLadder().back());
  EXPECT_EQ(drawn.width, kMinInteractiveSide);
  EXPECT_EQ(drawn.height, 256);
  Scene wide = scene512(10);
  wide.width = 1000, wide.height = 50;  // shorter than the floor: never reduced
  EXPECT_EQ(interactiveScene(wide, interactiveLadder().back()).width, 1000);
}

TEST(Interactive, AFrameReturnedSmallerIsNeverDrawnLarger) {
  // A frame returned at 0.375 of its sides (a video stream sent smaller): at a rate that fits everything the first
  // rung is drawn at that size, not at the scene's; a tight budget still reaches the smaller rungs.
  const InteractiveChoice wide = chooseInteractive(scene512(100), 1e12, 0, modelSamples, 0.375);
  EXPECT_EQ(wide.rung, 0);
  EXPECT_EQ(wide.width, scaledSide(512, 0.375));
  EXPECT_EQ(wide.width, 192);
  EXPECT_EQ(wide.step, scene512(100).step) << "the exact step, drawn smaller";
  EXPECT_DOUBLE_EQ(wide.lod, scene512(100).lod * 0.375) << "the level of detail of the scene's size";
  // A rung below the cap is the ladder's own: its level of detail in its drawing's pixels.
  const Scene below = interactiveScene(scene512(100), interactiveLadder().back(), 0.375);
  EXPECT_EQ(below.lod, interactiveScene(scene512(100), interactiveLadder().back()).lod);
  const double rate = 5e5;
  for (double budget : {200.0, 50.0, 12.5, 3.0}) {
    const InteractiveChoice c = chooseInteractive(scene512(budget), rate, 0, modelSamples, 0.375);
    const InteractiveChoice plain = chooseInteractive(scene512(budget), rate, 0, modelSamples);
    EXPECT_LE(c.width, 192) << budget;
    EXPECT_LE(c.rung, plain.rung) << budget << ": capped rungs cost no more, so none coarser is needed";
    if (plain.predictedMs <= budget) {
      EXPECT_LE(c.predictedMs, budget) << budget;
    }
  }
  EXPECT_EQ(scaledSide(7, 0.1), 1) << "at least a pixel";
  EXPECT_EQ(scaledSide(1023, 0.5), 512) << "rounded half away from zero";
}

// What a frame returned smaller would have been drawn at without its cap (a video stream may follow its drawing
// down, server/VideoStream.h): the uncapped choice's scale, whatever the cap, found with a few more estimates only
// where the cap bound.
TEST(Interactive, TheWantedScaleIsTheChoiceWithoutTheCap) {
  int estimates = 0;
  std::vector<std::tuple<int, int, double, double>> seen;  // the drawings estimated for one choice
  const SampleEstimate counted = [&](const Scene& s) {
    ++estimates;
    const std::tuple<int, int, double, double> drawing{s.width, s.height, s.step, s.lod};
    EXPECT_EQ(std::count(seen.begin(), seen.end(), drawing), 0) << "a drawing estimated twice: " << s.width << "x"
                                                                << s.height << ", step " << s.step << ", lod " << s.lod;
    seen.push_back(drawing);
    return modelSamples(s);
  };
  const double rate = 5e5;
  for (double budget : {400.0, 200.0, 100.0, 50.0, 25.0, 12.5, 3.0, 0.5})
    for (double cap : {1.0, 0.75, 0.5, 0.375, 0.25}) {
      estimates = 0, seen.clear();
      const InteractiveChoice plain = chooseInteractive(scene512(budget), rate, 1, counted);
      const int plainEstimates = estimates;
      estimates = 0, seen.clear();
      const InteractiveChoice c = chooseInteractive(scene512(budget), rate, 1, counted, cap);
      EXPECT_DOUBLE_EQ(c.wantedScale, plain.scale) << budget << " ms, capped at " << cap;
      EXPECT_DOUBLE_EQ(plain.wantedScale, plain.scale) << budget << " ms";
      EXPECT_LE(c.scale, cap + 1e-9) << budget << " ms, capped at " << cap;
      // (A bisection of the 17 rungs is about 7 estimates; the rungs from a capped one to the first the cap leaves
      // alone are at most 8, 4 more.)
      EXPECT_LE(estimates, plainEstimates + 4) << budget << " ms, capped at " << cap;
      if (cap == 1) {
        EXPECT_EQ(estimates, plainEstimates) << "no cap: no more estimates";
      }
    }
  // A scene the floor keeps from shrinking: wanted and drawn at the floor's scale.
  Scene small = scene512(0.5);
  small.width = small.height = 96;
  const InteractiveChoice s = chooseInteractive(small, rate, 1, modelSamples, 0.25);
  EXPECT_EQ(s.width, kMinInteractiveSide);
  EXPECT_NEAR(s.wantedScale, double(kMinInteractiveSide) / 96, 1e-12);
  EXPECT_EQ(chooseInteractive(scene512(100), 0, 0, modelSamples, 0.5).wantedScale, 0) << "no rate: nothing wanted";
  EXPECT_EQ(chooseInteractive(scene512(100), rate, 0, modelSamples).toJson()["scale_wanted"],
            chooseInteractive(scene512(100), rate, 0, modelSamples).wantedScale);
}

TEST(Interactive, WithoutARateTheCheapestDrawingMeasuresTheDevice) {
  const InteractiveChoice c = chooseInteractive(scene512(100), 0, 0, modelSamples);
  EXPECT_EQ(c.rung, int(interactiveLadder().size()) - 1);
  EXPECT_EQ(c.predictedMs, 0);
}

TEST(Interactive, TheChoiceIsDeterministic) {
  for (double rate : {1e3, 3e4, 5e5, 2e7}) {
    const InteractiveChoice a = chooseInteractive(scene512(80), rate, 5, modelSamples);
    const InteractiveChoice b = chooseInteractive(scene512(80), rate, 5, modelSamples);
    EXPECT_EQ(a.toJson(), b.toJson());
  }
}

TEST(Interactive, EveryRungIsNoDearerThanTheOneBefore) {
  const auto& ladder = interactiveLadder();
  ASSERT_GE(ladder.size(), 2u);
  for (size_t i = 1; i < ladder.size(); ++i) {
    EXPECT_LE(ladder[i].scale, ladder[i - 1].scale) << i;
    EXPECT_GE(ladder[i].stepFactor, ladder[i - 1].stepFactor) << i;
    EXPECT_GE(ladder[i].lodFactor, ladder[i - 1].lodFactor) << i;
    // Strictly cheaper where no rung meets the 64-pixel floor (1024²); at 512² the last ones are the floor's drawing.
    Scene large = scene512(100);
    large.width = large.height = 1024;
    EXPECT_LT(modelSamples(interactiveScene(large, ladder[i])), modelSamples(interactiveScene(large, ladder[i - 1])))
        << i;
    EXPECT_LE(modelSamples(interactiveScene(scene512(100), ladder[i])),
              modelSamples(interactiveScene(scene512(100), ladder[i - 1])))
        << i;
  }
}

TEST(Interactive, TheGaugeFitsAFixedTimeAndARate) {
  RateGauge g;
  EXPECT_EQ(g.rate(), 0);
  g.add(1e6, 0);  // ignored
  EXPECT_EQ(g.rate(), 0);
  // Frames that take 4 ms plus 1 ms per 1e5 samples.
  for (double s : {1e6, 4e6, 2e7, 8e6, 3e7}) g.add(s, 4 + s / 1e5);
  EXPECT_NEAR(g.rate(), 1e5, 1);
  EXPECT_NEAR(g.fixedMs(), 4, 1e-6);
  // A noisy frame cannot make the fixed time more than half the quickest frame's.
  RateGauge noisy;
  for (double s : {1e5, 2e5, 4e5}) noisy.add(s, 10);
  noisy.add(8e5, 400);
  EXPECT_LE(noisy.fixedMs(), 5);
  EXPECT_GT(noisy.rate(), 0);
  // One size only: the ratio, no fixed time.
  RateGauge one;
  one.add(1e6, 20);
  one.add(1e6, 30);
  EXPECT_NEAR(one.rate(), 2e6 / 50, 1e-9);
  EXPECT_EQ(one.fixedMs(), 0);
}

TEST(Interactive, ScaleBilinearKeepsConstantsAndInterpolates) {
  image::ImageF in;
  in.width = 2, in.height = 1;
  in.rgba = {0, 0, 0, 1, 1, 1, 1, 1};
  const image::ImageF out = scaleBilinear(in, 4, 2);
  ASSERT_EQ(out.width, 4);
  ASSERT_EQ(out.height, 2);
  // Pixel centres 0.5..3.5 map to -0.25, 0.25, 0.75, 1.25 of the input: clamped at the edges.
  const float expect[4] = {0, 0.25f, 0.75f, 1};
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 4; ++x) {
      EXPECT_FLOAT_EQ(out.pixel(x, y)[0], expect[x]) << x;
      EXPECT_FLOAT_EQ(out.pixel(x, y)[3], 1);
    }
}

TEST(Interactive, SceneKeysAreReadAndChecked) {
  const Scene s = Scene::fromJson(R"({"interactive": true, "time_budget_ms": 40})", "scene");
  EXPECT_TRUE(s.interactive);
  EXPECT_DOUBLE_EQ(s.timeBudgetMs, 40);
  EXPECT_FALSE(Scene::fromJson("{}", "scene").interactive);
  EXPECT_DOUBLE_EQ(Scene::fromJson("{}", "scene").timeBudgetMs, 100);
  EXPECT_THROW(Scene::fromJson(R"({"time_budget_ms": 5})", "scene"), RenderInputError);
  EXPECT_THROW(Scene::fromJson(R"({"time_budget_ms": 20000})", "scene"), RenderInputError);
  EXPECT_THROW(Scene::fromJson(R"({"interactive": 1})", "scene"), RenderInputError);
  const Scene back = Scene::fromJson(s.toJson(), "scene");
  EXPECT_TRUE(back.interactive);
  EXPECT_DOUBLE_EQ(back.timeBudgetMs, 40);
}

}  // namespace
}  // namespace voxbrick::render
