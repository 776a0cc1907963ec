// The time-versus-error sweep and its files (quality/): Pareto front and default choice on made-up points,
// the SVG's well-formedness, and a quick `voxbrick bench` run whose files are checked field by field.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>

#include "quality/SettingChoice.h"
#include "quality/SweepPlot.h"
#include "quality/SweepReport.h"
#include "support/TestSupport.h"

namespace voxbrick::quality {
namespace {

Point point(const std::string& dataset, Variant variant, Setting setting, double ms, double psnr) {
  Point p{dataset, std::move(variant), setting};
  p.msMedian = ms;
  p.psnrMin = psnr;
  return p;
}

/// True if every element opened in `xml` is closed in order (enough to catch a malformed writer; attribute values
/// here never contain '>').
bool wellFormed(const std::string& xml, std::string& why) {
  std::vector<std::string> open;
  for (size_t i = xml.find('<'); i != std::string::npos; i = xml.find('<', i + 1)) {
    const size_t end = xml.find('>', i);
    if (end == std::string::npos) return why = "unterminated tag at " + std::to_string(i), false;
    const std::string tag = xml.substr(i + 1, end - i - 1);
    if (tag.empty() || tag[0] == '?' || tag[0] == '!') continue;
    const std::string name = tag.substr(tag[0] == '/', tag.find_first_of(" />", 1) - (tag[0] == '/'));
    if (tag[0] == '/') {
      if (open.empty() || open.back() != name) return why = "</" + name + "> closes nothing open", false;
      open.pop_back();
    } else if (tag.back() != '/') {
      open.push_back(name);
    }
  }
  if (!open.empty()) return why = "<" + open.back() + "> is never closed", false;
  return true;
}

TEST(SweepPareto, KeepsOnlyUndominatedPointsPerDatasetAndVariant) {
  const Variant hot{"hot"}, shaded{"hot", true};
  std::vector<Point> points = {point("a", hot, {0.25}, 40, 50), point("a", hot, {0.5}, 20, 45),
                               point("a", hot, {1}, 25, 40),  // slower and worse than step 0.5
                               point("a", hot, {2}, 10, 30),    point("a", shaded, {2}, 30, 20),  // own variant
                               point("b", hot, {0.5}, 100, 45)};
  markPareto(points);
  EXPECT_TRUE(points[0].pareto);
  EXPECT_TRUE(points[1].pareto);
  EXPECT_FALSE(points[2].pareto);
  EXPECT_TRUE(points[3].pareto);
  EXPECT_TRUE(points[4].pareto);
  EXPECT_TRUE(points[5].pareto);
}

TEST(SweepDefault, FastestSettingAboveTheThresholdOnEveryDataset) {
  const std::vector<Dataset> datasets = {{"a", "", {"hot", "ct-bone"}}, {"b", "", {"mri"}}};
  const Setting cpuAt1{1, 32, true, render::Slicer::Cpu};
  std::vector<Point> points = {
      point("a", {"hot"}, {0.5}, 20, 45),
      point("b", {"mri"}, {0.5}, 30, 44),
      point("a", {"hot"}, {1}, 10, 42),
      point("b", {"mri"}, {1}, 15, 41),
      point("a", {"hot"}, {2}, 5, 35),
      point("b", {"mri"}, {2}, 8, 41),  // step 2 fails on a
      point("a", {"hot"}, cpuAt1, 8, 42),
      point("b", {"mri"}, cpuAt1, 12, 41),
      // Other variants show what they need but do not decide the default.
      point("a", {"hot", true}, {1}, 12, 30),
      point("a", {"ct-bone"}, {0.5}, 25, 41),
      point("a", {"ct-bone"}, {1}, 11, 39),
  };
  std::optional<Setting> chosen = chooseDefault(points, datasets, 40);
  ASSERT_TRUE(chosen);
  EXPECT_EQ(*chosen, cpuAt1);
  EXPECT_EQ(*chooseDefault(points, datasets, 41.5), Setting{0.5});
  EXPECT_FALSE(chooseDefault(points, datasets, 50));
  // A setting not measured on every dataset is never chosen.
  points.push_back(point("a", {"hot"}, {0.75}, 1, 60));
  EXPECT_EQ(*chooseDefault(points, datasets, 40), cpuAt1);

  EXPECT_EQ(coarsestStep(points, "a", {"hot"}, 40), 1.0) << "the CPU slicer's point is not the baseline renderer";
  EXPECT_EQ(coarsestStep(points, "a", {"ct-bone"}, 40), 0.5);
  EXPECT_FALSE(coarsestStep(points, "a", {"hot", true}, 40));
}

Setting slab(double step, int size, double ert = 0, bool preIntegration = false) {
  Setting s{step};
  s.slab = size;
  s.ert = ert;
  s.preIntegration = preIntegration;
  return s;
}

Setting raycast(double step, double ert = 0, int subBlock = 0, bool preIntegration = false) {
  Setting s{step};
  s.raycast = true;
  s.ert = ert;
  s.subBlock = subBlock;
  s.preIntegration = preIntegration;
  return s;
}

TEST(SweepSetting, LabelShowsSlabSettingsOnlyWhenNotDefault) {
  // The labels of the settings that existed before the slabs are unchanged, so old tables stay comparable.
  EXPECT_EQ(Setting{0.5}.label(), "step 0.5, B=32, skip, vertex");
  EXPECT_EQ((Setting{1, 16, false, render::Slicer::Cpu}.label()), "step 1, B=16, no skip, cpu slicer");
  EXPECT_EQ(slab(1, 16).label(), "step 1, B=32, skip, vertex, slab 16");
  EXPECT_EQ(slab(1, 16, 0.99, true).label(), "step 1, B=32, skip, vertex, slab 16, ert 0.99, pre-int");
  EXPECT_EQ(slab(0.75, 4, 0.995).label(), "step 0.75, B=32, skip, vertex, slab 4, ert 0.995");
  EXPECT_EQ(slab(2, render::Scene::kMaxSlab).label(), "step 2, B=32, skip, vertex, slab whole brick");
  EXPECT_EQ(slab(2, 16, 0, true).label(), "step 2, B=32, skip, vertex, slab 16, pre-int");
  EXPECT_FALSE(slab(1, 16) == slab(1, 16, 0.99)) << "settings differing only in ERT are different points";
  EXPECT_FALSE(slab(1, 16) == slab(1, 16, 0, true));
  Setting skipping = slab(1, 32, 0.999);
  skipping.subBlock = 8;
  EXPECT_EQ(skipping.label(), "step 1, B=32, skip, vertex, slab 32, ert 0.999, sub-block 8");
  EXPECT_FALSE(skipping == slab(1, 32, 0.999));
  EXPECT_EQ(marchingLabel(skipping), "slab 32, ert 0.999, sub-block 8");
  EXPECT_EQ(marchingLabel(Setting{1}), "slicing");
}

TEST(SweepSetting, RayCasterLabelsNameItWithoutASlab) {
  EXPECT_EQ(raycast(0.5).label(), "step 0.5, B=32, skip, vertex, raycast");
  EXPECT_EQ(raycast(0.5, 0.999, 8).label(), "step 0.5, B=32, skip, vertex, raycast, ert 0.999, sub-block 8");
  EXPECT_EQ(raycast(1, 0.99, 0, true).label(), "step 1, B=32, skip, vertex, raycast, ert 0.99, pre-int");
  Setting coarse = raycast(1, 0.999, 8);
  coarse.lod = 2;
  EXPECT_EQ(coarse.label(), "step 1, B=32, skip, vertex, raycast, ert 0.999, sub-block 8, lod 2");
  EXPECT_EQ(marchingLabel(raycast(0.5, 0.999, 8)), "raycast, ert 0.999, sub-block 8");
  Setting slicing{0.5};
  slicing.ert = 0.999;
  slicing.subBlock = 8;
  EXPECT_FALSE(raycast(0.5, 0.999, 8) == slicing) << "the ray caster is its own setting";
  EXPECT_NE(raycast(0.5, 0.999, 8).label(), slicing.label());
}

TEST(SweepSpecs, FullAndQuickSweepTheSlabSettingsOnAnOpaqueVariantToo) {
  const SweepSpec full = SweepSpec::full("/x/mri.nii.gz");
  EXPECT_EQ(full.slabs, (std::vector<int>{1, 4, 16, 32, render::Scene::kMaxSlab}));
  EXPECT_EQ(full.erts, (std::vector<double>{0.99, 0.999, 1}));
  EXPECT_EQ(full.ertSlab, 32);
  EXPECT_EQ(full.slabSubBlocks, (std::vector<int>{8}));
  EXPECT_TRUE(full.preIntegration);
  EXPECT_DOUBLE_EQ(full.psnrThreshold, 40);
  EXPECT_DOUBLE_EQ(full.psnrHighThreshold, 50);
  for (const Dataset& d : full.datasets)
    if (d.name == "ml" || d.name == "mri") {
      EXPECT_EQ(d.opaque, "ct-bone") << d.name;
      EXPECT_EQ(slabVariants(d, true), (std::vector<Variant>{defaultVariant(d), {"ct-bone"}})) << d.name;
    }
  EXPECT_TRUE(full.rayCast);
  // 144 points as before the slabs; per slab variant 16 settings a step (5 sizes; 3 thresholds at 32, each also
  // with sub-blocks of 8; 3 at the best other size; 2 pre-integrated), 13 at step 0.25 (no slabs of 1, 4 and 16,
  // the sizes below the ERT slab), over 5 slab variants; the ray caster 10 a step on each (ERT off and 3
  // thresholds, each with whole-brick cells and sub-blocks of 8; 2 pre-integrated).
  EXPECT_EQ(full.plannedPoints(), 144u + 5 * (5 * 16 + 13) + 5 * 6 * 10);
  SweepSpec slabsOnly = full;
  slabsOnly.rayCast = false;
  EXPECT_EQ(slabsOnly.plannedPoints(), 144u + 5 * (5 * 16 + 13));
  SweepSpec rayCastOnly = full;
  rayCastOnly.slabs.clear();
  EXPECT_EQ(rayCastOnly.plannedPoints(), 144u + 5 * 6 * 10) << "the ray caster does not need the slab sizes";
  rayCastOnly.lods = {1, 2};
  EXPECT_EQ(rayCastOnly.plannedPoints(), 144u + 5 * 6 * (10 + 3 * 2)) << "each level with each threshold";

  const SweepSpec quick = SweepSpec::quick("/x/mri.nii.gz");
  ASSERT_FALSE(quick.slabs.empty());
  ASSERT_FALSE(quick.erts.empty());
  EXPECT_TRUE(quick.preIntegration);
  EXPECT_TRUE(quick.rayCast);
  EXPECT_TRUE(std::any_of(quick.datasets.begin(), quick.datasets.end(), [](const Dataset& d) {
    return slabVariants(d, true).size() == 2;
  })) << "an opaque variant";
}

TEST(SweepDefault, ChoosesAmongSlabSettingsAndAtTheHigherThreshold) {
  const std::vector<Dataset> datasets = {{"a", "", {"hot", "ct-bone"}, "ct-bone"}, {"b", "", {"mri"}}};
  const Setting ert99 = slab(1, 16, 0.99), ert999 = slab(1, 16, 0.999), preInt = slab(0.5, 16, 0.999, true);
  std::vector<Point> points = {
      point("a", {"hot"}, {1}, 30, 42),
      point("b", {"mri"}, {1}, 40, 52),
      point("a", {"hot"}, {0.5}, 60, 51),
      point("b", {"mri"}, {0.5}, 80, 58),
      point("a", {"hot"}, slab(1, 16), 32, 42),
      point("b", {"mri"}, slab(1, 16), 41, 52),
      point("a", {"hot"}, ert99, 12, 41.5),
      point("b", {"mri"}, ert99, 15, 45),  // fastest at 40 dB
      point("a", {"hot"}, ert999, 14, 42),
      point("b", {"mri"}, ert999, 18, 51.9),  // fails 50 dB on a
      point("a", {"hot"}, preInt, 25, 50.5),
      point("b", {"mri"}, preInt, 35, 57),  // fastest at 50 dB
      // The opaque variant does not decide the defaults, but has its own fastest points.
      point("a", {"ct-bone"}, ert99, 5, 60),
      point("a", {"ct-bone"}, {1}, 20, 61),
  };
  EXPECT_EQ(chooseDefault(points, datasets, 40), ert99);
  EXPECT_EQ(chooseDefault(points, datasets, 50), preInt);
  EXPECT_FALSE(chooseDefault(points, datasets, 52));

  const std::optional<Point> fastA = fastestPoint(points, "a", {"hot"}, 50);
  ASSERT_TRUE(fastA);
  EXPECT_EQ(fastA->setting, preInt);
  const std::optional<Point> fastB = fastestPoint(points, "b", {"mri"}, 50);
  ASSERT_TRUE(fastB);
  EXPECT_EQ(fastB->setting, ert999) << "per dataset, the fastest at 50 dB may differ from the common answer";
  EXPECT_EQ(fastestPoint(points, "a", {"ct-bone"}, 50)->setting, ert99);
  EXPECT_FALSE(fastestPoint(points, "a", {"hot"}, 60));
  EXPECT_EQ(coarsestStep(points, "a", {"hot"}, 40), 1.0) << "slab points are not the baseline renderer";

  // The ray caster competes like any setting, compared with itself on every dataset.
  const Setting rc = raycast(1, 0.99, 8);
  points.push_back(point("a", {"hot"}, rc, 8, 41));
  points.push_back(point("b", {"mri"}, rc, 11, 44));
  EXPECT_EQ(chooseDefault(points, datasets, 40), rc);
  EXPECT_EQ(chooseDefault(points, datasets, 50), preInt);
  Setting notRc = rc;
  notRc.raycast = false;
  points.push_back(point("a", {"hot"}, raycast(1), 1, 45));  // not measured on b: never chosen
  points.push_back(point("b", {"mri"}, notRc, 1, 45));       // not the ray caster: does not complete it
  EXPECT_EQ(chooseDefault(points, datasets, 40), rc);
  EXPECT_EQ(coarsestStep(points, "a", {"hot"}, 40), 1.0) << "ray-caster points are not the baseline renderer";
}

TEST(SweepSlabs, BestSlabSizeAndBestThreshold) {
  const int whole = render::Scene::kMaxSlab;
  std::vector<Point> points = {
      point("a", {"hot"}, slab(1, 4), 50, 40), point("a", {"hot"}, slab(2, 4), 20, 35),
      point("a", {"hot"}, slab(1, 16), 30, 40), point("a", {"hot"}, slab(2, 16), 15, 35),
      point("a", {"hot"}, slab(1, whole), 32, 40), point("a", {"hot"}, slab(2, whole), 16, 35),
      point("a", {"hot"}, slab(1, 1), 80, 40), point("a", {"hot"}, slab(2, 1), 40, 35),
      point("b", {"mri"}, slab(1, 4), 100, 60), point("b", {"mri"}, slab(1, 16), 90, 60),
      point("b", {"mri"}, slab(1, whole), 70, 60), point("b", {"mri"}, slab(1, 1), 150, 60),
      // Where not every size was measured, no size counts: whole bricks 118 against slab 4's 170 and slab 1's 270.
      point("a", {"hot"}, slab(0.5, 1), 1, 60), point("a", {"hot"}, slab(0.25, whole), 1000, 60),
      point("a", {"hot"}, slab(1, 16, 0, true), 1, 40),  // pre-integrated: not a plain slab size
  };
  EXPECT_EQ(bestSlabSize(points, 16), whole);
  EXPECT_EQ(bestSlabSize(points, whole), 16);
  EXPECT_FALSE(bestSlabSize({}, 16));
  EXPECT_FALSE(bestSlabSize({point("a", {"hot"}, slab(1, 4), 1, 40), point("a", {"hot"}, slab(2, 1), 1, 40)}, 16))
      << "no (dataset, variant, step) measured with every size";

  // Thresholds at slab 16: 0.99 costs 3 dB on b at step 1 (60 -> 45 would be below 50 and more than 1 dB off);
  // 0.995 costs 0.5 dB on a (within the tolerance) and 5 dB on b but stays above 50 dB there.
  points.push_back(point("a", {"hot"}, slab(1, 16, 0.99), 20, 39.5));
  points.push_back(point("b", {"mri"}, slab(1, 16, 0.99), 60, 45));
  points.push_back(point("a", {"hot"}, slab(1, 16, 0.995), 22, 39.5));
  points.push_back(point("b", {"mri"}, slab(1, 16, 0.995), 62, 55));
  points.push_back(point("a", {"hot"}, slab(1, 16, 0.999), 25, 40));
  points.push_back(point("b", {"mri"}, slab(1, 16, 0.999), 65, 59));
  EXPECT_EQ(bestErt(points, 16, 1, 50), 0.995);
  EXPECT_EQ(bestErt(points, 16, 0.1, 50), 0.999);
  EXPECT_EQ(bestErt(points, 16, 20, 50), 0.99);
  EXPECT_EQ(bestErt(points, 16, 0, 60), 0.999) << "none keeps it: the most accurate";
  EXPECT_FALSE(bestErt(points, whole, 1, 50)) << "no threshold measured at that size";
  EXPECT_FALSE(bestRayCastErt(points, 1, 50)) << "no ray-caster point";

  // The ray caster's thresholds, against the ray caster without ERT: 0.99 costs 5 dB on a. They change neither the
  // slab answers nor the best slab size (the ray caster is fastest, but is no slab size).
  points.push_back(point("a", {"hot"}, raycast(1), 10, 40));
  points.push_back(point("b", {"mri"}, raycast(1), 10, 60));
  points.push_back(point("a", {"hot"}, raycast(1, 0.99), 5, 35));
  points.push_back(point("b", {"mri"}, raycast(1, 0.99), 5, 60));
  points.push_back(point("a", {"hot"}, raycast(1, 0.999), 6, 40));
  points.push_back(point("b", {"mri"}, raycast(1, 0.999), 6, 59.5));
  points.push_back(point("a", {"hot"}, raycast(2), 1, 40));
  EXPECT_EQ(bestRayCastErt(points, 1, 50), 0.999);
  EXPECT_EQ(bestRayCastErt(points, 6, 50), 0.99);
  EXPECT_EQ(bestErt(points, 16, 1, 50), 0.995);
  EXPECT_EQ(bestSlabSize(points, 16), whole);
  points.push_back(point("a", {"hot"}, raycast(1, 0.9, 0, true), 1, 10));  // pre-integrated: not counted
  EXPECT_EQ(bestRayCastErt(points, 1, 50), 0.999);
}

std::vector<std::string> fields(const std::string& line);

TEST(SweepFiles, CsvAppendsTheSlabColumnsAndMarkdownHasTheSlabTable) {
  SweepResult result;
  result.device = "test";
  result.spec.datasets = {{"ml", "synthetic:marschner-lobb", {"hot", "ct-bone"}, "ct-bone"}};
  result.spec.steps = {1};
  result.spec.slabs = {16};
  result.spec.erts = {0.99};
  result.spec.views = 2;
  result.spec.size = 16;
  Point slicing = point("ml", {"hot"}, {1}, 40, 45);
  slicing.samplesMedian = slicing.fragmentsMedian = 4e6;
  Point slab16 = point("ml", {"hot"}, slab(1, 16), 50, 45);
  slab16.samplesMedian = 4e6;
  slab16.fragmentsMedian = 0.5e6;
  slab16.slabPassesMedian = 12;
  Point ert = point("ml", {"hot"}, slab(1, 16, 0.99), 20, 44);
  ert.samplesMedian = 1e6;
  ert.fragmentsMedian = 0.25e6;
  ert.samplesTerminatedMedian = 0.1e6;
  ert.slabPassesMedian = 12;
  ert.msMin = 16;  // the orbit's fastest and slowest views
  ert.msMax = 24;
  Point opaque = point("ml", {"ct-bone"}, slab(1, 16, 0.99, true), 10, 50);
  Point rayCast = point("ml", {"hot"}, raycast(1, 0, 8), 30, 45);
  rayCast.samplesMedian = 4e6;
  rayCast.fragmentsMedian = 256;
  Point rayCastErt = point("ml", {"hot"}, raycast(1, 0.99, 8), 8, 44);
  rayCastErt.samplesMedian = 0.6e6;
  rayCastErt.fragmentsMedian = 256;
  result.spec.rayCast = true;
  result.points = {slicing, slab16, ert, opaque, rayCast, rayCastErt};
  markPareto(result.points);
  result.chosen = slab(1, 16, 0.99);
  result.chosenHigh = std::nullopt;
  test::ScratchDir dir;
  writeResults(result, dir.path());

  std::ifstream csv(dir / "sweep.csv");
  std::string line;
  ASSERT_TRUE(std::getline(csv, line));
  const std::vector<std::string> header = fields(line);
  const std::vector<std::string> expected = {
      "dataset", "transfer_function", "shading", "step", "brick", "skip", "slicer", "views", "size", "median_ms",
      "min_ms", "max_ms", "median_samples", "psnr_worst_db", "psnr_pooled_db", "rmse_pooled", "max_abs", "pareto",
      // appended after the columns of the sweep before slabs, so that old readers keep working
      "slab", "ert", "pre_integration", "samples_median", "fragments_median", "samples_terminated_median",
      "slab_passes_median", "sub_block", "lod", "raycast"};
  EXPECT_EQ(header, expected);
  std::vector<std::vector<std::string>> rows;
  while (std::getline(csv, line)) rows.push_back(fields(line));
  ASSERT_EQ(rows.size(), 6u);
  for (const auto& row : rows) ASSERT_EQ(row.size(), header.size());
  EXPECT_EQ((std::vector<std::string>(rows[0].begin() + 18, rows[0].end())),
            (std::vector<std::string>{"0", "0", "0", "4000000", "4000000", "0", "0", "0", "0", "0"}));
  EXPECT_EQ((std::vector<std::string>(rows[2].begin() + 18, rows[2].end())),
            (std::vector<std::string>{"16", "0.99", "0", "1000000", "250000", "100000", "12", "0", "0", "0"}));
  EXPECT_EQ(rows[2][12], "1000000") << "median_samples: samples taken";
  EXPECT_EQ(rows[3][20], "1");
  EXPECT_EQ((std::vector<std::string>(rows[5].begin() + 18, rows[5].end())),
            (std::vector<std::string>{"0", "0.99", "0", "600000", "256", "0", "0", "8", "0", "1"}))
      << "the ray caster: slab 0, and raycast 1 where slicing has 0";

  const auto bytes = test::readFile(dir / "sweep.md");
  const std::string md(bytes.begin(), bytes.end());
  for (const char* part :
       {"## Texture slabs and the frame ray caster at step 1", "### ml, hot", "### ml, ct-bone",
        "| slicing | 40.0 | 1.00× |", "| slab 16, ert 0.99 | 20.0 | 2.00× | 0.25 | 1 | 25 % | 44.0 |",
        "| raycast, sub-block 8 | 30.0 | 1.33× | 0.000256 | 4 | — | 45.0 |",
        "| raycast, ert 0.99, sub-block 8 | 8.0 | 5.00× | 0.000256 | 0.6 | 15 % | 44.0 |",
        "| ml | hot | step 1, B=32, skip, vertex, raycast, ert 0.99, sub-block 8 | 8.0 / 44.0 |", "| 50 dB | none |",
        "**step 1, B=32, skip, vertex, slab 16, ert 0.99**", "| ml | hot | 20.0 | 24.0 | 1:1.50 | 44.0 | 0.0 |"})
    EXPECT_NE(md.find(part), std::string::npos) << part << "\n" << md;
  EXPECT_LT(md.find("| slab 16, ert 0.99 |"), md.find("| raycast, sub-block 8 |")) << "the ray caster after the slabs";

  // Without the ray caster the section keeps its name.
  result.spec.rayCast = false;
  result.points.resize(4);
  writeResults(result, dir.path());
  const auto slabBytes = test::readFile(dir / "sweep.md");
  const std::string slabMd(slabBytes.begin(), slabBytes.end());
  EXPECT_NE(slabMd.find("## Texture slabs at step 1"), std::string::npos) << slabMd;
  EXPECT_EQ(slabMd.find("raycast"), std::string::npos) << slabMd;
}

TEST(SweepPlot, IsWellFormedSvgWithAPanelPerDataset) {
  SweepResult result;
  result.device = "a <device> & co";
  result.spec.datasets = {{"ml", "synthetic:marschner-lobb", {"hot"}}, {"mri", "/x/ch2.nii.gz", {"mri"}}};
  result.points = {point("ml", {"hot"}, {0.5}, 20, 45),
                   point("ml", {"hot"}, {2, 16}, 5, 30),
                   point("ml", {"hot", true}, {1, 32, false}, 7, 33),
                   point("mri", {"mri"}, {1, 32, true, render::Slicer::Cpu}, 300, 41),
                   point("mri", {"mri"}, {0.5}, 500, std::numeric_limits<double>::infinity()),
                   point("mri", {"mri"}, slab(0.5, 16), 450, 60),
                   point("mri", {"mri"}, slab(0.5, 16, 0.99), 200, 55),
                   point("mri", {"mri"}, slab(0.5, render::Scene::kMaxSlab), 300, 60),
                   point("mri", {"mri"}, slab(0.5, 1), 900, 60),
                   point("mri", {"mri"}, slab(0.5, 4), 700, 60),
                   point("mri", {"mri"}, slab(0.5, 16, 0.99, true), 250, 57),
                   point("mri", {"mri"}, raycast(0.5, 0.99, 8), 150, 55),
                   point("mri", {"mri"}, raycast(0.5, 0, 0, true), 260, 57)};
  markPareto(result.points);
  result.chosen = Setting{0.5};
  result.chosenHigh = slab(0.5, 16, 0.99);
  const std::string svg = sweepSvg(result);
  std::string why;
  EXPECT_TRUE(wellFormed(svg, why)) << why;
  EXPECT_NE(svg.find("<svg xmlns=\"http://www.w3.org/2000/svg\""), std::string::npos);
  EXPECT_NE(svg.find("ml (synthetic:marschner-lobb)"), std::string::npos);
  EXPECT_NE(svg.find("mri (ch2.nii.gz)"), std::string::npos);
  EXPECT_NE(svg.find("a &lt;device&gt; &amp; co"), std::string::npos);
  EXPECT_NE(svg.find("polyline"), std::string::npos) << "the Pareto fronts";
  EXPECT_EQ(svg.find("nan"), std::string::npos) << "an infinite PSNR must not reach a coordinate";
  EXPECT_EQ(svg.find("inf"), std::string::npos);
  for (const char* key : {"slab 1", "slab 4", "slab 16", "slab whole brick", "slab 16, pre-integration", "raycast<",
                          "raycast, pre-integration<", "dot: early ray termination", "fastest at 50 dB"})
    EXPECT_NE(svg.find(std::string(">") + key), std::string::npos) << key;
  EXPECT_NE(svg.find("r=\"1.8\" fill=\"black\""), std::string::npos) << "the ERT dot";
  // The ray caster's markers, a plus (12 corners) and a pentagon (5): each in the key and at its point, in the
  // variant's colour; the ray caster with ERT, the fastest point, is filled (on the front) with the dot.
  std::map<size_t, std::vector<std::string>> polygons;  // corners -> fill of each
  const std::string polygon = "<polygon points=\"";
  for (size_t i = svg.find(polygon); i != std::string::npos; i = svg.find(polygon, i + 1)) {
    const size_t from = i + polygon.size(), to = svg.find('"', from);
    const std::string corners = svg.substr(from, to - from);
    const size_t fill = svg.find("fill=\"", to) + 6;
    polygons[size_t(std::count(corners.begin(), corners.end(), ','))].push_back(
        svg.substr(fill, svg.find('"', fill) - fill));
  }
  EXPECT_EQ(polygons[12], (std::vector<std::string>{"#1f77b4", "white"})) << "the point, then the key";
  EXPECT_EQ(polygons[5], (std::vector<std::string>{"white", "white"}));
  EXPECT_NE(svg.find("stroke-dasharray=\"3 2\""), std::string::npos) << "the ring of the 50 dB answer";
}

std::vector<std::string> fields(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream in(line);
  for (std::string f; std::getline(in, f, ',');) out.push_back(f);
  return out;
}

TEST(BenchCli, QuickSweepWritesWellFormedFilesAndReusesItsReferences) {
  test::ScratchDir dir;
  const std::string args = "bench --quick -q --out " + (dir / "out").string() + " --work " + (dir / "work").string();
  auto r = test::runVoxbrick(args);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("bench: 84 points"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("every dataset at >= 50 dB"), std::string::npos) << "the second answer: " << r.output;

  std::ifstream csv(dir / "out" / "sweep.csv");
  std::string line;
  ASSERT_TRUE(std::getline(csv, line));
  const std::vector<std::string> header = fields(line);
  ASSERT_EQ(header.size(), 28u);
  EXPECT_EQ(header[9], "median_ms");
  EXPECT_EQ(header[13], "psnr_worst_db");
  EXPECT_EQ(header[18], "slab");
  EXPECT_EQ(header[27], "raycast");
  int rows = 0, pareto = 0, slabErt = 0, preInt = 0, ertSavedSamples = 0, rayCast = 0, rayCastErt = 0,
      rayCastPreInt = 0, rayCastSubBlocks = 0;
  std::map<std::string, double> samplesWithoutErt;
  for (; std::getline(csv, line); ++rows) {
    const std::vector<std::string> f = fields(line);
    ASSERT_EQ(f.size(), header.size()) << line;
    for (size_t c = 3; c < f.size(); ++c) {
      if (c == 6) continue;  // the slicer's name
      char* end = nullptr;
      const double v = std::strtod(f[c].c_str(), &end);
      EXPECT_TRUE(end == f[c].c_str() + f[c].size() && std::isfinite(v) && v >= 0)
          << header[c] << " = '" << f[c] << "' in " << line;
    }
    EXPECT_GT(std::stod(f[9]), 0) << line;
    // Measured: 25.4 dB at worst (ml), 28.4 (mri), 34.0 (sparse); a black frame in one view scores at most 15.1.
    EXPECT_GT(std::stod(f[13]), 23) << "an error this large means the sweep compared the wrong frames: " << line;
    EXPECT_GT(std::stod(f[21]), 0) << "samples taken: " << line;
    EXPECT_GT(std::stod(f[22]), 0) << "fragments started: " << line;
    if (f[27] == "1") {
      // Had the ray caster not reached the scene, these would be slicing's frames: a fragment per sample.
      ++rayCast;
      EXPECT_EQ(f[18], "0") << "the ray caster keeps no slab size: " << line;
      EXPECT_LE(std::stod(f[22]), 4 * 48 * 48) << "the ray caster: a fragment per pixel and batch: " << line;
      EXPECT_LT(std::stod(f[22]), std::stod(f[21])) << line;
      EXPECT_EQ(f[24], "0") << "no slab passes: " << line;
      rayCastErt += f[19] != "0" && f[20] == "0";
      rayCastPreInt += f[20] == "1";
      rayCastSubBlocks += f[25] == "8";
    } else if (f[18] == "0") {
      EXPECT_EQ(f[21], f[22]) << "slicing: a sample per fragment: " << line;
    } else {
      EXPECT_LT(std::stod(f[22]), std::stod(f[21])) << "slabs: several samples per fragment: " << line;
      EXPECT_GT(std::stod(f[24]), 0) << "slab passes: " << line;
    }
    const std::string where = f[0] + "," + f[1] + "," + f[3] + "," + f[18] + "," + f[25] + "," + f[27];
    const bool marching = f[18] != "0" || f[27] == "1";
    if (marching && f[19] == "0" && f[20] == "0") samplesWithoutErt[where] = std::stod(f[21]);
    if (marching && f[19] != "0" && f[20] == "0") {
      slabErt += f[27] == "0";
      if (f[25] == "0" || f[27] == "1") {
        ASSERT_TRUE(samplesWithoutErt.count(where)) << "measured after the same setting without ERT: " << line;
        ertSavedSamples += std::stod(f[21]) < samplesWithoutErt[where];
      }
    }
    preInt += f[20] == "1" && f[27] == "0";
    pareto += f[17] == "1";
  }
  EXPECT_EQ(rows, 84);
  EXPECT_EQ(slabErt, 12) << "ERT at slab 16 (also with sub-blocks) and at whole bricks, on 4 slab variants";
  EXPECT_EQ(preInt, 8) << "pre-integration with ERT off and at 0.99, on 4 slab variants";
  EXPECT_EQ(rayCast, 24) << "the ray caster on 4 slab variants: ERT off and 0.99, each also with sub-blocks; "
                            "pre-integrated with ERT off and at 0.99";
  EXPECT_EQ(rayCastErt, 8);
  EXPECT_EQ(rayCastPreInt, 8);
  EXPECT_EQ(rayCastSubBlocks, 8);
  EXPECT_GE(ertSavedSamples, 2) << "early ray termination left samples out somewhere, with slabs and ray casting";
  EXPECT_GE(pareto, 6) << "at least two points per dataset and variant on the front";

  const auto md = test::readFile(dir / "out" / "sweep.md");
  const std::string text(md.begin(), md.end());
  for (const char* part : {"## Chosen default", "## The reference", "## ml", "## sparse", "## mri", "sweep.svg",
                           "## Texture slabs and the frame ray caster at step 2", "### mri, mri", "### ml, ct-bone",
                           "slab whole brick, ert 0.99", "| raycast, ert 0.99, sub-block 8 |", "| raycast, pre-int |"})
    EXPECT_NE(text.find(part), std::string::npos) << part;
  const auto svg = test::readFile(dir / "out" / "sweep.svg");
  std::string why;
  EXPECT_TRUE(wellFormed(std::string(svg.begin(), svg.end()), why)) << why;

  // A rerun renders no reference frame: every one is read back from the work directory.
  r = test::runVoxbrick(args);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const auto again = test::readFile(dir / "out" / "sweep.md");
  const std::string rerun(again.begin(), again.end());
  const size_t from = rerun.find("## The reference"), to = rerun.find("\n## ", from + 1);
  const std::string table = rerun.substr(from, to - from);
  size_t cached = 0;
  for (size_t i = table.find("| cached |"); i != std::string::npos; i = table.find("| cached |", i + 1)) ++cached;
  EXPECT_EQ(cached, 7u) << table;

  r = test::runVoxbrick("bench --quick -q --datasets ml,nosuch --out " + (dir / "x").string());
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_NE(r.output.find("nosuch"), std::string::npos) << r.output;
}

// `bench --frames8`: each frame timed as a server sends it (8 bits finished on the GPU), its error measured on the
// float frame of the same view: the same samples, so every point's error is the float sweep's to the last digit.
TEST(BenchCli, Frames8TimesTheServedFrameAndJudgesTheSameSamples) {
  test::ScratchDir dir;
  const std::string common = "bench --quick -q --datasets ml --work " + (dir / "work").string();
  auto floats = test::runVoxbrick(common + " --out " + (dir / "f").string());
  ASSERT_EQ(floats.exitCode, 0) << floats.output;
  auto bytes = test::runVoxbrick(common + " --frames8 --out " + (dir / "b").string());
  ASSERT_EQ(bytes.exitCode, 0) << bytes.output;
  std::ifstream a(dir / "f" / "sweep.csv"), b(dir / "b" / "sweep.csv");
  std::string la, lb;
  ASSERT_TRUE(std::getline(a, la) && std::getline(b, lb));
  EXPECT_EQ(la, lb) << "the same columns";
  int rows = 0;
  while (std::getline(a, la)) {
    ASSERT_TRUE(std::getline(b, lb)) << "a point missing with --frames8";
    const std::vector<std::string> fa = fields(la), fb = fields(lb);
    ASSERT_EQ(fa.size(), fb.size());
    for (size_t c : {size_t(0), size_t(1), size_t(3), size_t(13), size_t(21), size_t(22)})
      EXPECT_EQ(fa[c], fb[c]) << "column " << c << ": " << la << " / " << lb;
    EXPECT_GT(std::stod(fb[9]), 0) << "timed: " << lb;
    ++rows;
  }
  EXPECT_GT(rows, 10);
  EXPECT_FALSE(std::getline(b, lb)) << "a point only with --frames8";
}

// `bench --mesh`: a synthetic mesh (non-convex: the staircase ball) and a mesh store, two transfer functions, every
// setting against the exact reference, the files written with one row per point, the front and the default, and
// bad input refused by name.
TEST(BenchCli, MeshSweepMeasuresEverySettingAgainstTheExactReference) {
  test::ScratchDir dir;
  auto r = test::runVoxbrick("prep synthetic-mesh:box,n=4 -q -o " + (dir / "box.vms").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  r = test::runVoxbrick("bench -q --mesh synthetic-mesh:ball,n=6 --mesh " + (dir / "box.vms").string() +
                        " --tf hot,ct-bone --views 2 --size 40 --out " + (dir / "out").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("bench: default at >= 40 dB: "), std::string::npos) << r.output;
  std::ifstream csv(dir / "out" / "mesh-sweep.csv");
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line.rfind("mesh,tets,transfer_function,visibility,skip_empty,ert,", 0), 0u) << line;
  std::map<std::string, int> rows, fronts, rayCast;
  while (std::getline(csv, line)) {
    // Fields split at commas outside quotes (a synthetic spec is quoted).
    std::vector<std::string> f(1);
    bool quoted = false;
    for (char c : line) {
      if (c == '"')
        quoted = !quoted;
      else if (c == ',' && !quoted)
        f.emplace_back();
      else
        f.back() += c;
    }
    ASSERT_EQ(f.size(), 18u) << line;
    const std::string key = f[0] + "/" + f[2];
    rows[key] += 1;
    fronts[key] += f[17] == "1" ? 1 : 0;
    rayCast[key] += f[3] == "raycast" ? 1 : 0;
    EXPECT_GT(std::stod(f[14]), 40.0) << "worst view against the exact reference: " << line;
    EXPECT_GT(std::stod(f[8]), 0.0) << line;
    EXPECT_GT(std::stod(f[12]), 0.0) << "segments classified: " << line;
  }
  ASSERT_EQ(rows.size(), 4u);  // two meshes, two transfer functions
  for (const auto& [key, n] : rows) {
    EXPECT_EQ(n, 6) << key;  // mpvo and centroid, with and without skipping; the ray caster with and without ert
    EXPECT_EQ(rayCast[key], 2) << key;
    EXPECT_GE(fronts[key], 1) << key;
  }
  for (const char* name : {"mesh-sweep.md", "mesh-sweep.svg"})
    EXPECT_TRUE(std::filesystem::is_regular_file(dir / "out" / name)) << name;
  const std::vector<char> svgBytes = test::readFile(dir / "out" / "mesh-sweep.svg");
  const std::string svg(svgBytes.begin(), svgBytes.end());
  EXPECT_EQ(svg.rfind("<svg ", 0), 0u);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  EXPECT_EQ(std::count(svg.begin(), svg.end(), '<') - std::count(svg.begin(), svg.end(), '>'), 0);
  auto occurrences = [&](const std::string& what) {
    size_t n = 0;
    for (size_t at = svg.find(what); at != std::string::npos; at = svg.find(what, at + 1)) ++n;
    return n;
  };
  EXPECT_EQ(occurrences("font-weight=\"bold\""), 4u);  // a panel per mesh and transfer function
  EXPECT_EQ(occurrences("<circle "), 24u);             // a point per row
  // Refusals name what is wrong.
  r = test::runVoxbrick("bench -q --mesh " + (dir / "missing.vtk").string());
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.output.find("missing.vtk' does not exist"), std::string::npos) << r.output;
  r = test::runVoxbrick("bench -q --quick --mesh synthetic-mesh:ball,n=4");
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.output.find("not with --quick"), std::string::npos) << r.output;
  r = test::runVoxbrick("bench -q --mesh synthetic-mesh:ball,n=4 --tf nosuch --size 16 --views 1 --out " +
                        (dir / "x").string());
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.output.find("nosuch"), std::string::npos) << r.output;
}

TEST(BenchCli, PlansTheSweepItIsAskedForAndRefusesBadLists) {
  auto r = test::runVoxbrick("bench --dry-run");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("at most 909 points, 8 views"), std::string::npos) << r.output;
  r = test::runVoxbrick("bench --dry-run --no-raycast");
  EXPECT_NE(r.output.find("at most 609 points, 8 views"), std::string::npos)
      << "the sweep before the ray caster: " << r.output;
  r = test::runVoxbrick("bench --quick --dry-run");
  EXPECT_NE(r.output.find("at most 84 points"), std::string::npos) << r.output;
  r = test::runVoxbrick("bench --dry-run --slabs none --no-raycast");
  EXPECT_NE(r.output.find("at most 144 points"), std::string::npos) << "the sweep before slabs: " << r.output;
  r = test::runVoxbrick("bench --dry-run --slabs none");
  EXPECT_NE(r.output.find("at most 444 points"), std::string::npos) << "the ray caster without slabs: " << r.output;
  // One dataset (2 slab variants), 2 steps, no shading, no slicing alternatives: 2 variants x 2 steps of slicing;
  // per slab variant and step slab 16 and 4096, ERT 0.9 at 16 and at the best other size (4096), pre-int twice;
  // with --raycast also the ray caster with ERT off and 0.9, pre-integrated twice.
  const std::string focused =
      "bench --dry-run --datasets mri --steps 0.5,1 --no-shading --alternatives none "
      "--slabs 16,4096 --ert-slab 16 --erts 0.9 --slab-sub-blocks none --size 512";
  r = test::runVoxbrick(focused + " --no-raycast");
  EXPECT_NE(r.output.find("at most 28 points, 8 views each (and a warm-up frame), 512x512"), std::string::npos)
      << r.output;
  r = test::runVoxbrick(focused + " --raycast");
  EXPECT_NE(r.output.find("at most 44 points"), std::string::npos) << r.output;
  r = test::runVoxbrick(
      "bench --dry-run --datasets mri --steps 1 --no-shading --alternatives b16,no-skip "
      "--slabs 4,16 --erts none --no-pre-integration --no-opaque --no-raycast");
  EXPECT_NE(r.output.find("at most 6 points"), std::string::npos)
      << "2 slicing, b16, no skip, slab 4, slab 16: " << r.output;
  r = test::runVoxbrick(
      "bench --dry-run --datasets mri --steps 1 --no-shading --alternatives b16,no-skip "
      "--slabs 4,16 --erts none --no-pre-integration --no-opaque");
  EXPECT_NE(r.output.find("at most 8 points"), std::string::npos)
      << "and the ray caster without ERT, with whole-brick cells and sub-blocks of 8: " << r.output;

  for (const char* bad : {"--erts 0.3", "--slabs 0", "--slabs 5000", "--slabs 4.5", "--steps 1 --slab-steps 2",
                          "--alternatives b33", "--alternatives gpu", "--steps ,"}) {
    r = test::runVoxbrick(std::string("bench --dry-run ") + bad);
    EXPECT_EQ(r.exitCode, 1) << bad << ": " << r.output;
  }
  r = test::runVoxbrick("bench --dry-run --raycast --no-raycast");  // refused by the option parser
  EXPECT_NE(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("--raycast excludes --no-raycast"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace voxbrick::quality
