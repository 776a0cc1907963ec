// The exact integral of a linear segment (render/core/SegmentIntegral.h) that the tetrahedral reference composites:
// closed forms, convergence of brute force towards it, and the pre-integration table held to it for the segments tets
// make.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "render/RenderFixtures.h"
#include "render/core/PreIntegration.h"
#include "render/core/SegmentIntegral.h"
#include "render/core/TransferFunction.h"
#include "render/reference/Compositing.h"

namespace voxbrick::render {
namespace {

using test::kPresets;
using test::maxDifference;
using test::preset;

/// The midpoint rule of RenderFixtures.h, at least 4 substeps a piece.
glm::dvec4 midpoint(const TransferFunction& tf, double sf, double sb, double r, int n, int refine = 1) {
  return test::midpointSegment(tf, sf, sb, r, n, 4, refine);
}

using Point = TransferFunction::Point;

TEST(TetReferenceSegment, ClosedFormsAndEdgeCases) {
  const TransferFunction tf = preset("hot");
  // sf == sb: post-classification's closed form.
  for (double s : {0.0, 0.2, 0.35, 0.9, 1.0})
    for (double r : {1e-6, 0.3, 1.0, 7.5}) {
      const glm::dvec4 c = tf.evaluate(s);
      const double a = 1 - std::pow(1 - c.a, r);
      EXPECT_LT(maxDifference(integrateSegment(tf, s, s, r), glm::dvec4(glm::dvec3(c) * a, a)), 1e-15);
    }
  // Constant colour and alpha along a ramp: a segment through a plateau is the closed form whatever the values.
  const TransferFunction flat({{0.0, {0.2, 0.5, 0.7, 0.4}}, {1.0, {0.2, 0.5, 0.7, 0.4}}});
  const double a = 1 - std::pow(0.6, 2.5);
  EXPECT_LT(maxDifference(integrateSegment(flat, 0.1, 0.9, 2.5), {0.2 * a, 0.5 * a, 0.7 * a, a}), 1e-15);
  // Linear colour, constant alpha: C = c_f (1 - m) + c_b (m - T), m = (1 - T) / tau, in closed form.
  const TransferFunction ramp({{0.0, {0, 0, 0, 0.3}}, {1.0, {1, 1, 1, 0.3}}});
  const double tau = -3 * std::log(0.7), t = std::exp(-tau), m = (1 - t) / tau;
  const glm::dvec4 c = integrateSegment(ramp, 0.0, 1.0, 3.0);
  EXPECT_NEAR(c.r, m - t, 1e-15);
  EXPECT_NEAR(c.a, 1 - t, 1e-15);
  // The window's clamp: values beyond [0, 1] read as the ends, so a segment from -1 to 2 is three pieces.
  const glm::dvec4 clamped = integrateSegment(tf, -1.0, 2.0, 3.0);
  auto part = [&](double s0, double s1, double r) {
    const glm::dvec4 p = integrateSegment(tf, s0, s1, r);
    return RaySpan{glm::dvec3(p), 1 - p.a};
  };
  const RaySpan pieces = over(over(part(0, 0, 1.0), part(0, 1, 1.0)), part(1, 1, 1.0));
  EXPECT_LT(maxDifference(clamped, glm::dvec4(pieces.color, 1 - pieces.transmittance)), 1e-14);
  // Degenerate input.
  EXPECT_EQ(integrateSegment(tf, 0.2, 0.8, 0.0), glm::dvec4(0.0));
  EXPECT_EQ(integrateSegment(tf, 0.2, 0.8, -1.0), glm::dvec4(0.0));
  EXPECT_EQ(integrateSegment(tf, 0.2, 0.8, NAN), glm::dvec4(0.0));
  EXPECT_EQ(integrateSegment(tf, NAN, NAN, 1.0), integrateSegment(tf, 0.0, 0.0, 1.0));
  EXPECT_NEAR(integrateSegment(tf, 0.5, 1.0, INFINITY).a, 1.0, 1e-15);
  // Additivity: the model along a ray is a product of its parts.
  std::mt19937 random(5);
  std::uniform_real_distribution<double> unit(0, 1);
  for (int i = 0; i < 200; ++i) {
    const double sf = unit(random), sb = unit(random), r = 8 * unit(random), u = unit(random);
    const double sm = sf + u * (sb - sf);
    const RaySpan halves = over(part(sf, sm, r * u), part(sm, sb, r * (1 - u)));
    ASSERT_LT(maxDifference(integrateSegment(tf, sf, sb, r), glm::dvec4(halves.color, 1 - halves.transmittance)), 1e-13)
        << sf << " " << sm << " " << sb << " " << r;
  }
}

// The midpoint rule converges to integrateSegment as O(n^-2) (the error falls 4x per doubling), and Richardson's
// extrapolation of two of its results (O(n^-4)) meets it to 1e-10: integrateSegment is the limit itself, not an
// approximation of it at some resolution. Values beyond [0, 1] (the window's clamp) and ratios 0.01 to 30.
TEST(TetReferenceSegment, MidpointRuleConvergesToIt) {
  std::vector<std::pair<std::string, TransferFunction>> tfs;
  for (const std::string& name : kPresets) tfs.emplace_back(name, preset(name));
  tfs.emplace_back("steep", TransferFunction({{0.0, {0.0, 0.2, 1.0, 0.0}},
                                              {0.45, {1.0, 0.2, 0.0, 0.9}},
                                              {0.55, {0.1, 1.0, 0.1, 0.05}},
                                              {1.0, {1.0, 1.0, 1.0, 0.7}}}));
  std::mt19937 random(20240607);
  std::uniform_real_distribution<double> value(-0.2, 1.2), logRatio(std::log(0.01), std::log(30.0));
  const int n = 2000;
  for (const auto& [name, tf] : tfs) {
    double worstExtrapolated = 0, worstRatio = 0, bestRatio = 100;
    for (int i = 0; i < 30; ++i) {
      const double sf = value(random), sb = value(random), r = std::exp(logRatio(random));
      const glm::dvec4 exact = integrateSegment(tf, sf, sb, r);
      const glm::dvec4 coarse = midpoint(tf, sf, sb, r, n), fine = midpoint(tf, sf, sb, r, n, 2);
      const double coarseError = maxDifference(coarse, exact), fineError = maxDifference(fine, exact);
      const double extrapolated = maxDifference(fine + (fine - coarse) / 3.0, exact);
      EXPECT_LT(extrapolated, 1e-10) << name << ": sf " << sf << ", sb " << sb << ", r " << r;
      worstExtrapolated = std::max(worstExtrapolated, extrapolated);
      if (coarseError > 1e-9) {
        const double ratio = coarseError / fineError;
        EXPECT_GT(ratio, 3.5) << name << ": sf " << sf << ", sb " << sb << ", r " << r;
        EXPECT_LT(ratio, 4.5) << name << ": sf " << sf << ", sb " << sb << ", r " << r;
        worstRatio = std::max(worstRatio, ratio), bestRatio = std::min(bestRatio, ratio);
      }
    }
    std::printf("[ segment ] %-9s error ratio per doubling %.3f..%.3f, extrapolated midpoint vs exact %.2g\n",
                name.c_str(), bestRatio, worstRatio, worstExtrapolated);
  }
}

// Alphas of 1 (a plateau, a ramp ending at 1, a step to 1): the extinction is infinite or has a logarithmic
// singularity there, which the closed form and the adaptive quadrature handle. The midpoint rule converges to it only
// as O(1/n) there (the first substep in an opaque part takes the colour at its middle, not at its start), so it is
// held to 3e-6 at n = 200000 and to a tenfold drop from n = 20000.
TEST(TetReferenceSegment, OpaqueTransferFunctions) {
  const std::vector<TransferFunction> tfs = {
      TransferFunction({{0.0, {0.1, 0.2, 0.3, 0.0}}, {0.4, {0.5, 0.5, 0.5, 1.0}}, {1.0, {1.0, 0.9, 0.8, 1.0}}}),
      TransferFunction({{0.0, {0.0, 0.0, 0.0, 0.0}}, {0.5, {1.0, 0.0, 0.0, 0.2}}, {1.0, {0.0, 0.0, 1.0, 1.0}}}),
      TransferFunction({{0.0, {0.0, 1.0, 0.0, 0.0}},
                        {0.3, {0.0, 1.0, 0.0, 0.1}},
                        {0.3, {1.0, 1.0, 1.0, 1.0}},
                        {1.0, {1.0, 1.0, 1.0, 1.0}}}),
  };
  double worst = 0;
  for (size_t t = 0; t < tfs.size(); ++t)
    for (const auto& [sf, sb, r] : std::vector<std::tuple<double, double, double>>{{0.0, 1.0, 0.05},
                                                                                   {1.0, 0.0, 0.05},
                                                                                   {0.0, 0.4, 0.5},
                                                                                   {0.4, 0.0, 0.5},
                                                                                   {0.2, 0.35, 2.0},
                                                                                   {0.9, 0.1, 1e-3}}) {
      const glm::dvec4 exact = integrateSegment(tfs[t], sf, sb, r);
      EXPECT_TRUE(std::isfinite(exact.r) && std::isfinite(exact.a));
      EXPECT_LE(std::max({exact.r, exact.g, exact.b}), exact.a + 1e-15);
      const double coarse = maxDifference(exact, midpoint(tfs[t], sf, sb, r, 20000));
      const double fine = maxDifference(exact, midpoint(tfs[t], sf, sb, r, 200000));
      EXPECT_LT(fine, 3e-6) << "function " << t << ": sf " << sf << ", sb " << sb << ", r " << r;
      if (coarse > 1e-8) {
        EXPECT_GT(coarse / fine, 8) << "function " << t << ": sf " << sf << ", sb " << sb;
      }
      worst = std::max(worst, fine);
    }
  std::printf("[ segment ] opaque functions: max |midpoint (n = 200000) - exact| %.2g\n", worst);
  // Opaque from the front: the front colour, whatever follows.
  const glm::dvec4 front = integrateSegment(tfs[0], 0.5, 0.9, 3.0);
  EXPECT_NEAR(front.a, 1.0, 1e-15);
  EXPECT_NEAR(front.r, 0.5 + 0.5 * (0.1 / 0.6), 1e-15);  // rgb(0.5), between the points at 0.4 and 1
}

// The pre-integration table (render/core/PreIntegration.h), looked up as the GPU filters it, against the direct
// integral, for the segments a tetrahedral mesh makes: arbitrary front and back values and any length. The table's own
// build is within 1e-6 of the integral at its texels (test_preintegration.cpp); between texels the lookup interpolates
// (bilinear in the values, linear in ln r between layers), which costs up to the bound below, largest next to the
// diagonal where a kink of the transfer function falls between two texels. A step (the sparse preset's, at 0.02)
// cannot be interpolated: segments next to it are off by up to the step's whole effect, so it is held only on average.
TEST(TetReferenceSegment, PreIntegrationTableMatchesDirectIntegration) {
  const double ratioMin = 0.02, ratioMax = 16;
  const double kBound = 6e-3, kMeanBound = 5e-4;  // max over the continuous presets; mean over all
  PreIntegrationSpec spec;
  spec.resolution = 256;
  spec.ratioMin = ratioMin;
  spec.ratioMax = ratioMax;
  spec.layers = PreIntegrationSpec::layersFor(ratioMin, ratioMax, 1e-3);
  std::mt19937 random(2006);
  std::uniform_real_distribution<double> value(0, 1), logRatio(std::log(ratioMin), std::log(ratioMax));
  const std::vector<double> ratios = {0.02, 0.1, 0.5, 1, 2, 4, 8, 16};
  std::printf("[ preint  ] R %d, %d layers over r in [%g, %g]\n", spec.resolution, spec.layers, ratioMin, ratioMax);
  for (const std::string& name : kPresets) {
    const TransferFunction tf = preset(name);
    const std::vector<glm::vec4> table = buildPreIntegrationTable(tf, spec);
    double worst = 0, sum = 0;
    int count = 0;
    std::vector<double> worstByRatio(ratios.size(), 0.0);
    for (int i = 0; i < 3000; ++i) {
      const double sf = value(random);
      // A third of the segments short in value (small tets, smooth fields), as most of a mesh's are.
      const double sb = i % 3 == 0 ? std::clamp(sf + 0.02 * (value(random) - 0.5), 0.0, 1.0) : value(random);
      const size_t k = size_t(i) % (ratios.size() + 1);
      const double r = k < ratios.size() ? ratios[k] : std::exp(logRatio(random));
      const double error =
          maxDifference(samplePreIntegrationTable(table, spec, sf, sb, r), integrateSegment(tf, sf, sb, r));
      if (name != "sparse") {
        EXPECT_LT(error, kBound) << name << ": sf " << sf << ", sb " << sb << ", r " << r;
      }
      worst = std::max(worst, error);
      sum += error, ++count;
      if (k < ratios.size()) worstByRatio[k] = std::max(worstByRatio[k], error);
    }
    EXPECT_LT(sum / count, kMeanBound) << name;
    std::printf("[ preint  ] %-9s max |table - direct| %.2g, mean %.2g; max by ratio:", name.c_str(), worst,
                sum / count);
    for (size_t k = 0; k < ratios.size(); ++k) std::printf(" %g: %.2g", ratios[k], worstByRatio[k]);
    std::printf("\n");
  }
}

}  // namespace
}  // namespace voxbrick::render
