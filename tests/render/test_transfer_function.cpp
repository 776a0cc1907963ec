// Transfer functions: parse errors, evaluation, GPU tables, the exact range test, opacity correction, presets.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "render/core/BuiltInPresets.h"
#include "render/core/RenderErrors.h"
#include "render/core/Scene.h"
#include "render/core/TransferFunction.h"
#include "render/core/TransferFunctionPresets.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

using Point = TransferFunction::Point;

std::filesystem::path sourceDir() {
#ifdef VOXBRICK_SOURCE_DIR
  return VOXBRICK_SOURCE_DIR;
#else
  return std::filesystem::path(__FILE__).parent_path().parent_path().parent_path();
#endif
}

// Sets an environment variable for the lifetime of the guard, restoring the old value afterwards.
class EnvGuard {
 public:
  EnvGuard(const char* name, const std::string& value) : mName(name) {
    if (const char* old = std::getenv(name)) mOld = old;
    setenv(name, value.c_str(), 1);
  }
  ~EnvGuard() {
    if (mOld)
      setenv(mName, mOld->c_str(), 1);
    else
      unsetenv(mName);
  }
  EnvGuard(const EnvGuard&) = delete;
  EnvGuard& operator=(const EnvGuard&) = delete;

 private:
  const char* mName;
  std::optional<std::string> mOld;
};

// Expects parse() to throw RenderInputError whose message contains every one of `parts`.
void expectParseError(const std::string& text, const std::vector<std::string>& parts) {
  try {
    TransferFunction::parse(text, "tf.json");
    ADD_FAILURE() << "accepted " << text;
  } catch (const RenderInputError& e) {
    std::string message = e.what();
    EXPECT_NE(message.find("tf.json"), std::string::npos) << message;
    for (const std::string& part : parts) EXPECT_NE(message.find(part), std::string::npos) << message;
  }
}

// The largest alpha over [lo, hi] by brute force: ends, control points inside, and dense samples.
double bruteMaxAlpha(const TransferFunction& tf, double lo, double hi) {
  lo = std::clamp(lo, 0.0, 1.0);
  hi = std::clamp(hi, 0.0, 1.0);
  double best = std::max(tf.evaluate(lo).a, tf.evaluate(hi).a);
  for (const Point& p : tf.points())
    if (p.x >= lo && p.x <= hi) best = std::max(best, p.rgba.a);
  for (int s = 1; s < 64; ++s) best = std::max(best, tf.evaluate(lo + (hi - lo) * s / 64).a);
  return best;
}

TEST(TransferFunctionParse, AcceptsValidInputWithStepsAndReferenceLength) {
  TransferFunction tf = TransferFunction::parse(
      R"({"name": "t", "description": "d", "points": [[0, 0, 0, 0, 0], [0.5, 1, 0, 0, 0], [0.5, 0, 1, 0, 1],
          [1, 0, 0, 1, 0.5]], "reference_length": 0.25})",
      "tf.json");
  EXPECT_EQ(tf.points().size(), 4u);
  ASSERT_TRUE(tf.referenceLength().has_value());
  EXPECT_EQ(*tf.referenceLength(), 0.25);
  EXPECT_FALSE(TransferFunction::parse(R"({"points": [[0.3, 1, 1, 1, 1]]})", "x").referenceLength().has_value());
}

TEST(TransferFunctionParse, EveryRuleHasItsOwnError) {
  expectParseError("{", {"not valid JSON"});
  expectParseError("[]", {"JSON object"});
  expectParseError("{}", {"missing key 'points'"});
  expectParseError(R"({"points": 3})", {"not an array"});
  expectParseError(R"({"points": []})", {"empty"});
  expectParseError(R"({"points": [[0, 0, 0, 0, 0], [1, 0, 0, 0]]})", {"points[1]", "5 numbers"});
  expectParseError(R"({"points": [[0, 0, 0, 0, 0], 7]})", {"points[1]", "5 numbers"});
  expectParseError(R"({"points": [[0, 0, "red", 0, 0]]})", {"points[0]", "g is not a number"});
  expectParseError(R"({"points": [[0, 0, 0, 0, 0], [1.5, 0, 0, 0, 0]]})", {"points[1]", "x = 1.5", "[0, 1]"});
  expectParseError(R"({"points": [[-0.1, 0, 0, 0, 0]]})", {"points[0]", "x = -0.1"});
  expectParseError(R"({"points": [[0, 0, 0, 0, 0], [0.5, 0, 0, 1.25, 0]]})", {"points[1]", "b = 1.25"});
  expectParseError(R"({"points": [[0, 0, 0, 0, 0], [0.5, 0, 0, 0, -0.5]]})", {"points[1]", "a = -0.5"});
  expectParseError(R"({"points": [[0, 2, 0, 0, 0]]})", {"points[0]", "r = 2"});
  expectParseError(R"({"points": [[0, 0, 0, 0, 0], [0.6, 0, 0, 0, 0], [0.4, 0, 0, 0, 0]]})",
                   {"points[2]", "x = 0.4", "previous", "non-decreasing"});
  expectParseError(R"({"points": [[0, 0, 0, 0, 0]], "reference_length": 0})", {"reference_length = 0"});
  expectParseError(R"({"points": [[0, 0, 0, 0, 0]], "reference_length": -2})", {"reference_length = -2"});
  expectParseError(R"({"points": [[0, 0, 0, 0, 0]], "reference_length": "1"})", {"reference_length", "number"});
  expectParseError(R"({"points": [[0, 0, 0, 0, 0]], "referenceLength": 1})", {"unknown key 'referenceLength'"});
  expectParseError(R"({"points": [[0, 0, 0, 0, 0]], "name": 3})", {"'name'", "string"});
}

TEST(TransferFunctionParse, ConstructorChecksTheSameRules) {
  EXPECT_THROW(TransferFunction({}), RenderInputError);
  EXPECT_THROW(TransferFunction({{0.5, {0, 0, 0, std::nan("")}}}), RenderInputError);
  EXPECT_THROW(TransferFunction({{0.5, {0, 0, 0, 0}}}, 0.0), RenderInputError);
  EXPECT_NO_THROW(TransferFunction({{0.5, {0, 0, 0, 0}}}, 2.0));
}

TEST(TransferFunctionEvaluate, InterpolatesClampsAndSteps) {
  TransferFunction tf({{0.2, {0, 0, 0, 0}}, {0.6, {1, 0.5, 0, 0.4}}, {0.6, {0, 1, 0, 0.8}}, {0.8, {0, 0, 1, 0}}});
  EXPECT_EQ(tf.evaluate(0.0), glm::dvec4(0, 0, 0, 0));
  EXPECT_EQ(tf.evaluate(0.2), glm::dvec4(0, 0, 0, 0));
  glm::dvec4 mid = tf.evaluate(0.4);
  EXPECT_NEAR(mid.r, 0.5, 1e-12);
  EXPECT_NEAR(mid.g, 0.25, 1e-12);
  EXPECT_NEAR(mid.a, 0.2, 1e-12);
  EXPECT_NEAR(tf.evaluate(0.6 - 1e-12).a, 0.4, 1e-9);     // left of the step
  EXPECT_EQ(tf.evaluate(0.6), glm::dvec4(0, 1, 0, 0.8));  // at the step: the later point
  EXPECT_NEAR(tf.evaluate(0.7).a, 0.4, 1e-12);
  EXPECT_EQ(tf.evaluate(0.9), glm::dvec4(0, 0, 1, 0));
  EXPECT_EQ(tf.evaluate(7.0), glm::dvec4(0, 0, 1, 0));
  EXPECT_EQ(tf.evaluate(-3.0), glm::dvec4(0, 0, 0, 0));
  EXPECT_EQ(tf.evaluate(std::nan("")), tf.evaluate(0.0));
  TransferFunction single({{0.3, {0.1, 0.2, 0.3, 0.4}}});
  EXPECT_EQ(single.evaluate(0.0), glm::dvec4(0.1, 0.2, 0.3, 0.4));
  EXPECT_EQ(single.evaluate(1.0), glm::dvec4(0.1, 0.2, 0.3, 0.4));
}

TEST(TransferFunctionTable, TheRangeTestCoversWhatALookupReads) {
  const TransferFunction ramp({{0, {0, 0, 0, 0}}, {1, {1, 1, 1, 1}}});
  EXPECT_FALSE(ramp.tableContributes(0, 0, 4096)) << "the low end reads tf(0) alone";
  EXPECT_TRUE(ramp.tableContributes(0, 1e-6, 4096)) << "just above it reads the next entry too";
  const TransferFunction foot({{0, {0, 0, 0, 0}}, {0.5, {0, 0, 0, 0}}, {1, {1, 1, 1, 1}}});
  EXPECT_FALSE(foot.tableContributes(0.1, 0.49, 4096));
  EXPECT_TRUE(foot.tableContributes(0.1, 0.5, 4096)) << "0.5 reads entries up to the first opaque one";
  EXPECT_TRUE(foot.tableContributes(std::nan(""), 0.2, 4096));
}

TEST(TransferFunctionTable, SamplesBothEndsAndEvenlyBetween) {
  TransferFunction tf({{0, {0, 0, 0, 0}}, {1, {1, 0.5, 0.25, 1}}});
  std::vector<glm::vec4> t = tf.table(4);
  ASSERT_EQ(t.size(), 4u);
  EXPECT_EQ(t.front().a, 0.0f) << "the low end is tf(0) exactly: transparent background stays transparent";
  EXPECT_EQ(t.back().a, 1.0f);
  for (int i = 0; i < 4; ++i) {
    double x = i / 3.0;
    EXPECT_FLOAT_EQ(t[static_cast<size_t>(i)].r, static_cast<float>(x));
    EXPECT_FLOAT_EQ(t[static_cast<size_t>(i)].g, static_cast<float>(0.5 * x));
    EXPECT_FLOAT_EQ(t[static_cast<size_t>(i)].a, static_cast<float>(x));
  }
  EXPECT_EQ(tf.table(1).at(0), glm::vec4(0.0f, 0.0f, 0.0f, 0.0f));
  EXPECT_THROW(tf.table(0), RenderInputError);
}

TEST(TransferFunctionContributes, FindsASpikeNarrowerThanOneBin) {
  double bin = 1.0 / TransferFunction::kRangeBins;
  TransferFunction tf({{0, {0, 0, 0, 0}}, {0.5003, {1, 1, 1, 0}}, {0.50031, {1, 1, 1, 0.3}}, {0.50032, {1, 1, 1, 0}}});
  EXPECT_TRUE(tf.contributes(0.49, 0.51));
  EXPECT_TRUE(tf.contributes(0.500305, 0.500315));
  EXPECT_TRUE(tf.contributes(0.50031, 0.50031));
  EXPECT_TRUE(tf.contributes(0.51, 0.49));  // either order
  EXPECT_FALSE(tf.contributes(0.0, 0.49));
  EXPECT_FALSE(tf.contributes(0.5003 - 2 * bin, 0.5003 - bin));
  EXPECT_FALSE(tf.contributes(0.51, 1.0));
  EXPECT_FALSE(tf.contributes(-5.0, 0.1));
  EXPECT_FALSE(tf.contributes(2.0, 3.0));
  EXPECT_TRUE(tf.contributes(std::nan(""), 0.1));
  // A spike peaking exactly on a bin boundary belongs to both bins.
  TransferFunction edge({{0.25 - bin / 4, {0, 0, 0, 0}}, {0.25, {0, 0, 0, 0.2}}, {0.25 + bin / 4, {0, 0, 0, 0}}});
  EXPECT_TRUE(edge.contributes(0.25, 0.25));
  EXPECT_TRUE(edge.contributes(0.25 - bin / 2, 0.25 - bin / 2));  // same bin: conservative
  EXPECT_FALSE(edge.contributes(0.1, 0.2));
  EXPECT_FALSE(edge.contributes(0.3, 1.0));
}

TEST(TransferFunctionContributes, StepsAtTheEdgeOfTheRange) {
  TransferFunction step({{0, {0, 0, 0, 0}}, {0.02, {0, 0, 0, 0}}, {0.02, {1, 1, 1, 0.3}}, {1, {1, 1, 1, 0.3}}});
  EXPECT_FALSE(step.contributes(0.0, 0.019));
  EXPECT_TRUE(step.contributes(0.0, 0.021));
  EXPECT_TRUE(step.contributes(0.5, 0.5));
  TransferFunction opaqueEnds({{0, {0, 0, 0, 0.5}}, {0.1, {0, 0, 0, 0}}, {0.9, {0, 0, 0, 0}}, {1, {0, 0, 0, 0.5}}});
  EXPECT_TRUE(opaqueEnds.contributes(-1.0, 0.0));
  EXPECT_TRUE(opaqueEnds.contributes(1.0, 4.0));
  EXPECT_FALSE(opaqueEnds.contributes(0.2, 0.8));
}

TEST(TransferFunctionContributes, NeverMissesOpacityFoundByBruteForce) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> unit(0, 1);
  double bin = 1.0 / TransferFunction::kRangeBins;
  int positives = 0, negatives = 0;
  for (int trial = 0; trial < 60; ++trial) {
    std::vector<Point> points;
    int n = 1 + static_cast<int>(rng() % 8);
    std::vector<double> xs;
    for (int i = 0; i < n; ++i) xs.push_back(unit(rng) < 0.2 ? std::floor(unit(rng) * 64) / 64 : unit(rng));
    std::sort(xs.begin(), xs.end());
    for (double x : xs) points.push_back({x, {unit(rng), unit(rng), unit(rng), unit(rng) < 0.6 ? 0.0 : unit(rng)}});
    TransferFunction tf(points);
    for (int q = 0; q < 100; ++q) {
      double lo = unit(rng) * 1.2 - 0.1, width = unit(rng) < 0.5 ? unit(rng) * 1e-3 : unit(rng) * 0.3;
      double hi = lo + width;
      bool says = tf.contributes(lo, hi);
      double truth = bruteMaxAlpha(tf, lo, hi);
      if (truth > 0) {
        EXPECT_TRUE(says) << "trial " << trial << " [" << lo << ", " << hi << "]";
      }
      // Tightness: a positive answer means opacity within one bin of the range.
      if (says) {
        EXPECT_GT(bruteMaxAlpha(tf, lo - bin, hi + bin), 0) << "trial " << trial;
      }
      (says ? positives : negatives)++;
    }
  }
  EXPECT_GT(positives, 100);
  EXPECT_GT(negatives, 100);
}

TEST(TransferFunctionOpacity, CorrectionIsFiniteBoundedAndMonotonicAtTheExtremes) {
  const std::vector<double> alphas = {0.0, 1e-7, 0.01, 0.5, 0.99, 1 - 1e-7, 1.0};
  std::vector<double> ratios;
  for (double r = 1e-4; r <= 1e3 * (1 + 1e-9); r *= std::sqrt(10.0)) ratios.push_back(r);
  std::vector<double> previousRow;
  for (double r : ratios) {
    std::vector<double> row;
    double previous = -1;
    for (double a : alphas) {
      double c = TransferFunction::correctOpacity(a, r);
      EXPECT_TRUE(std::isfinite(c)) << a << " " << r;
      EXPECT_GE(c, 0.0);
      EXPECT_LE(c, 1.0);
      EXPECT_GE(c, previous) << "not monotonic in alpha at " << a << " " << r;
      previous = c;
      row.push_back(c);
    }
    for (size_t i = 0; i < previousRow.size(); ++i) EXPECT_GE(row[i], previousRow[i]) << "not monotonic in r";
    previousRow = row;
    EXPECT_EQ(TransferFunction::correctOpacity(0.0, r), 0.0);
    EXPECT_FALSE(std::signbit(TransferFunction::correctOpacity(0.0, r)));
    EXPECT_EQ(TransferFunction::correctOpacity(1.0, r), 1.0);
    // For tiny alpha the answer is r * alpha to first order: no cancellation.
    EXPECT_NEAR(TransferFunction::correctOpacity(1e-7, r) / (r * 1e-7), 1.0, 1e-3 * std::max(1.0, r));
  }
  EXPECT_NEAR(TransferFunction::correctOpacity(0.5, 2), 0.75, 1e-15);
  EXPECT_NEAR(TransferFunction::correctOpacity(0.3, 1), 0.3, 1e-15);
  // 1 - (1 - a)^r = r a + r (1 - r) a^2 / 2 + ...
  EXPECT_NEAR(TransferFunction::correctOpacity(1e-7, 1e-4), 1e-11 + 0.5e-4 * (1 - 1e-4) * 1e-14, 1e-24);
  EXPECT_EQ(TransferFunction::correctOpacity(0.5, 0), 0.0);
  EXPECT_EQ(TransferFunction::correctOpacity(-0.2, 1), 0.0);
  EXPECT_EQ(TransferFunction::correctOpacity(1.5, 1), 1.0);
}

TEST(TransferFunctionPresets, EveryPresetLoadsWithModerateOpacity) {
  EnvGuard env("VOXBRICK_CONFIG_DIR", (sourceDir() / "config").string());
  EXPECT_EQ(TransferFunction::configDirectory(), sourceDir() / "config");
  std::vector<std::string> names = TransferFunction::presetNames();
  for (const char* expected : {"ct-bone", "grayscale", "hot", "mri", "sparse"})
    EXPECT_NE(std::find(names.begin(), names.end(), expected), names.end()) << expected;
  for (const std::string& name : names) {
    TransferFunction tf = TransferFunction::load(name);
    double maxAlpha = 0;
    for (const Point& p : tf.points()) maxAlpha = std::max(maxAlpha, p.rgba.a);
    EXPECT_GE(maxAlpha, 0.05) << name;
    EXPECT_LE(maxAlpha, 0.6) << name;
  }
  TransferFunction sparse = TransferFunction::load("sparse");
  EXPECT_EQ(sparse.evaluate(0.0).a, 0.0);
  EXPECT_FALSE(sparse.contributes(0.0, 0.019));
  EXPECT_TRUE(sparse.contributes(0.0, 0.03));
  TransferFunction mri = TransferFunction::load("mri");
  EXPECT_FALSE(mri.contributes(0.0, 0.14));
  TransferFunction bone = TransferFunction::load("ct-bone");
  EXPECT_FALSE(bone.contributes(0.0, 0.25));
  EXPECT_GT(bone.evaluate(1.0).a, 0.5);
}

TEST(TransferFunctionPresets, LoadsPathsAndReportsMissingFiles) {
  test::ScratchDir dir;
  test::writeFile(dir / "mine.json", std::string(R"({"points": [[0, 1, 0, 0, 0.5]]})"));
  EXPECT_EQ(TransferFunction::load((dir / "mine.json").string()).evaluate(0.5).a, 0.5);
  test::writeFile(dir / "bad.json", std::string(R"({"points": [[0, 1, 0, 0, 1.5]]})"));
  try {
    TransferFunction::load((dir / "bad.json").string());
    ADD_FAILURE() << "loaded a bad file";
  } catch (const RenderInputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.json: points[0]: a = 1.5"), std::string::npos) << e.what();
  }
  EXPECT_THROW(TransferFunction::load((dir / "absent.json").string()), RenderInputError);
  EXPECT_THROW(TransferFunction::load(dir.path().string() + "/"), RenderInputError);
  EXPECT_THROW(TransferFunction::load("no such name"), RenderInputError);
  EXPECT_THROW(TransferFunction::load(""), RenderInputError);
  std::filesystem::create_directories(dir / "tf");
  test::writeFile(dir / "tf" / "custom.json", std::string(R"({"points": [[0, 0, 0, 1, 0.25]]})"));
  EnvGuard env("VOXBRICK_CONFIG_DIR", dir.path().string());
  EXPECT_EQ(TransferFunction::load("custom").evaluate(0).b, 1.0);
  // A name the directory lacks falls back to the built-in preset; one that is neither is refused, listing both.
  EXPECT_EQ(TransferFunction::load("grayscale").points().size(), 3u);
  try {
    TransferFunction::load("nosuch");
    ADD_FAILURE() << "found a preset that is neither built in nor in the directory";
  } catch (const RenderInputError& e) {
    EXPECT_NE(std::string(e.what()).find("presets: ct-bone, custom, grayscale, hot, mri, sparse"), std::string::npos)
        << e.what();
  }
}

TEST(TransferFunctionPresets, BuiltInPresetsAreTheShippedFilesAndFilesOverrideThem) {
  // The embedded text is the file's: every shipped file, nothing else, equal point for point.
  const std::filesystem::path shipped = sourceDir() / "config" / "tf";
  std::vector<std::string> builtIn;
  for (const BuiltInPreset& p : builtInPresets()) {
    builtIn.emplace_back(p.name);
    const TransferFunction file = TransferFunction::load((shipped / (builtIn.back() + ".json")).string());
    const TransferFunction embedded = TransferFunction::parse(std::string(p.json), "built-in");
    ASSERT_EQ(embedded.points().size(), file.points().size()) << p.name;
    for (size_t i = 0; i < file.points().size(); ++i) {
      EXPECT_EQ(embedded.points()[i].x, file.points()[i].x) << p.name;
      EXPECT_EQ(embedded.points()[i].rgba, file.points()[i].rgba) << p.name;
    }
  }
  EXPECT_EQ(builtIn, TransferFunction::presetNames(shipped));
  EXPECT_NE(findBuiltInPreset("mri"), nullptr);
  EXPECT_EQ(findBuiltInPreset("nosuch"), nullptr);

  test::ScratchDir dir;
  test::writeFile(dir / "mri.json", std::string(R"({"points": [[0, 1, 0, 0, 0.25]]})"));
  const TransferFunctionPresets presets = TransferFunctionPresets::load(dir.path());
  EXPECT_TRUE(presets.file("mri") == dir / "mri.json");
  EXPECT_EQ(presets.get("mri").evaluate(0.5).a, 0.25);
  EXPECT_FALSE(presets.file("hot").has_value()) << "built in";
  EnvGuard env("VOXBRICK_CONFIG_DIR", (dir / "absent").string());
  EXPECT_EQ(TransferFunction::presetNames(), builtIn);
  EXPECT_EQ(TransferFunction::load("mri").points().size(), 6u);
}

TEST(TransferFunctionPresets, TheDefaultIsTheGrayscalePresetAndSkipsTheBottomOfTheWindow) {
  EnvGuard env("VOXBRICK_CONFIG_DIR", (sourceDir() / "config").string());
  const TransferFunction preset = TransferFunction::load("grayscale");
  const TransferFunction builtIn = Scene{}.transferFunction;
  ASSERT_EQ(builtIn.points().size(), preset.points().size());
  for (size_t i = 0; i < preset.points().size(); ++i) {
    EXPECT_EQ(builtIn.points()[i].x, preset.points()[i].x) << i;
    EXPECT_EQ(builtIn.points()[i].rgba, preset.points()[i].rgba) << i;
  }
  // Empty space at the window's low end, and noise a little above it, is transparent, so the plan skips it.
  EXPECT_FALSE(builtIn.contributes(0.0, 0.04));
  EXPECT_FALSE(builtIn.tableContributes(0.0, 0.04, 256));
  EXPECT_TRUE(builtIn.contributes(0.0, 0.06));
  EXPECT_DOUBLE_EQ(builtIn.evaluate(1.0).a, 0.5);
}

TEST(PresetsReadOnce, ResolvesNamesWithoutReadingFilesAgain) {
  test::ScratchDir dir;
  test::writeFile(dir / "warm.json", std::string(R"({"points": [[0, 1, 0.5, 0, 0], [1, 1, 0.5, 0, 0.4]]})"));
  test::writeFile(dir / "cool.json", std::string(R"({"points": [[0, 0, 0, 1, 0.1]]})"));
  test::writeFile(dir / "notes.txt", std::string("not a preset"));
  test::writeFile(dir / "bad name.json", std::string(R"({"points": [[0, 0, 0, 1, 0.1]]})"));
  const TransferFunctionPresets presets = TransferFunctionPresets::load(dir.path());
  EXPECT_EQ(presets.names(),
            (std::vector<std::string>{"cool", "ct-bone", "grayscale", "hot", "mri", "sparse", "warm"}));
  std::filesystem::remove_all(dir.path() / "warm.json");  // resolved from memory from now on
  EXPECT_DOUBLE_EQ(presets.get("warm").evaluate(1.0).a, 0.4);
  const Scene scene = Scene::fromJson(R"({"transfer_function": "warm"})", "request", presets);
  EXPECT_DOUBLE_EQ(scene.transferFunction.evaluate(1.0).a, 0.4);
  EXPECT_EQ(scene.transferFunctionName, "warm");
}

TEST(PresetsReadOnce, UnknownNamesPathsAndBadFilesAreRefusedByName) {
  test::ScratchDir dir;
  test::writeFile(dir / "only.json", std::string(R"({"points": [[0, 0, 0, 1, 0.1]]})"));
  const TransferFunctionPresets presets = TransferFunctionPresets::load(dir.path());
  try {
    presets.get("nosuch");
    ADD_FAILURE() << "found a preset that was not loaded";
  } catch (const RenderInputError& e) {
    EXPECT_NE(std::string(e.what()).find("'nosuch'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("presets: ct-bone, grayscale, hot, mri, only, sparse"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(Scene::fromJson(R"({"transfer_function": "nosuch"})", "request", presets), RenderInputError);
  EXPECT_THROW(Scene::fromJson(R"({"transfer_function": "/etc/passwd"})", "request", presets), RenderInputError);
  EXPECT_THROW(Scene::fromJson(R"({"transfer_function": "x.json"})", "request", presets), RenderInputError);

  test::writeFile(dir / "broken.json", std::string(R"({"points": [[0, 0, 0, 1, 7]]})"));
  try {
    TransferFunctionPresets::load(dir.path());
    ADD_FAILURE() << "loaded a broken preset";
  } catch (const RenderInputError& e) {
    EXPECT_NE(std::string(e.what()).find("broken.json"), std::string::npos) << e.what();
  }
  EXPECT_EQ(TransferFunctionPresets::load(dir / "absent").names(),
            (std::vector<std::string>{"ct-bone", "grayscale", "hot", "mri", "sparse"}));
}

}  // namespace
}  // namespace voxbrick::render
