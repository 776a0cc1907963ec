// The time-versus-error sweep: Pareto front and default choice on made-up points, the SVG's well-formedness, and a
// quick `voxbrick bench` run whose files are checked field by field.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "bench/Sweep.h"
#include "bench/SweepPlot.h"
#include "support/TestSupport.h"

namespace voxbrick::bench {
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
                               point("a", hot, {2}, 10, 30),     point("a", shaded, {2}, 30, 20),  // own variant
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
      point("a", {"hot"}, {0.5}, 20, 45), point("b", {"mri"}, {0.5}, 30, 44),
      point("a", {"hot"}, {1}, 10, 42),   point("b", {"mri"}, {1}, 15, 41),
      point("a", {"hot"}, {2}, 5, 35),    point("b", {"mri"}, {2}, 8, 41),  // step 2 fails on a
      point("a", {"hot"}, cpuAt1, 8, 42), point("b", {"mri"}, cpuAt1, 12, 41),
      // Other variants show what they need but do not decide the default.
      point("a", {"hot", true}, {1}, 12, 30), point("a", {"ct-bone"}, {0.5}, 25, 41),
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

TEST(SweepPlot, IsWellFormedSvgWithAPanelPerDataset) {
  SweepResult result;
  result.device = "a <device> & co";
  result.spec.datasets = {{"ml", "synthetic:marschner-lobb", {"hot"}}, {"mri", "/x/ch2.nii.gz", {"mri"}}};
  result.points = {point("ml", {"hot"}, {0.5}, 20, 45), point("ml", {"hot"}, {2, 16}, 5, 30),
                   point("ml", {"hot", true}, {1, 32, false}, 7, 33),
                   point("mri", {"mri"}, {1, 32, true, render::Slicer::Cpu}, 300, 41),
                   point("mri", {"mri"}, {0.5}, 500, std::numeric_limits<double>::infinity())};
  markPareto(result.points);
  result.chosen = Setting{0.5};
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
  EXPECT_NE(r.output.find("bench: 30 points"), std::string::npos) << r.output;

  std::ifstream csv(dir / "out" / "sweep.csv");
  std::string line;
  ASSERT_TRUE(std::getline(csv, line));
  const std::vector<std::string> header = fields(line);
  ASSERT_EQ(header.size(), 18u);
  EXPECT_EQ(header[9], "median_ms");
  EXPECT_EQ(header[13], "psnr_worst_db");
  int rows = 0, pareto = 0;
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
    EXPECT_GT(std::stod(f[13]), 15) << "an error this large means the sweep compared the wrong frames: " << line;
    pareto += f[17] == "1";
  }
  EXPECT_EQ(rows, 30);
  EXPECT_GE(pareto, 6) << "at least two points per dataset and variant on the front";

  const auto md = test::readFile(dir / "out" / "sweep.md");
  const std::string text(md.begin(), md.end());
  for (const char* part : {"## Chosen default", "## The reference", "## ml", "## sparse", "## mri", "sweep.svg"})
    EXPECT_NE(text.find(part), std::string::npos) << part;
  const auto svg = test::readFile(dir / "out" / "sweep.svg");
  std::string why;
  EXPECT_TRUE(wellFormed(std::string(svg.begin(), svg.end()), why)) << why;

  // A rerun renders no reference frame: every one is read back from the work directory.
  r = test::runVoxbrick(args);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const auto again = test::readFile(dir / "out" / "sweep.md");
  const std::string rerun(again.begin(), again.end());
  const size_t from = rerun.find("## The reference"), to = rerun.find("## ml");
  const std::string table = rerun.substr(from, to - from);
  size_t cached = 0;
  for (size_t i = table.find("| cached |"); i != std::string::npos; i = table.find("| cached |", i + 1)) ++cached;
  EXPECT_EQ(cached, 6u) << table;

  r = test::runVoxbrick("bench --quick -q --datasets ml,nosuch --out " + (dir / "x").string());
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_NE(r.output.find("nosuch"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace voxbrick::bench
