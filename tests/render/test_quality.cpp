// Quality by target: parsing targets, the table's JSON, the choice rule on made-up tables, the scene key, and end to
// end: `voxbrick bench --calibrate` writes a table, `voxbrick render --quality psnr:X` at a calibrated view returns a
// frame whose PSNR against the reference is at least X.
#include <gtest/gtest.h>

#include <map>

#include <nlohmann/json.hpp>

#include "image/Image.h"
#include "render/core/Quality.h"
#include "render/core/RenderErrors.h"
#include "render/core/Scene.h"
#include "support/TestSupport.h"

namespace voxbrick::render {
namespace {

using nlohmann::json;

QualityEntry entry(const std::string& tf, double step, double ms, double psnr, bool raycast = true) {
  QualityEntry e;
  e.transferFunction = tf;
  e.setting.step = step;
  e.setting.raycast = raycast;
  e.msMedian = ms;
  e.psnrMin = psnr;
  return e;
}

/// A 100x100 table of "hot": step 0.5 slow and accurate, step 1 in between, step 2 fast and coarse; and "mri", where
/// step 1 is worse than on "hot" and step 2 slower.
QualityTable table() {
  QualityTable t;
  t.device = "test";
  t.width = t.height = 100;
  t.views = 4;
  t.entries = {entry("hot", 0.5, 40, 52), entry("hot", 1, 20, 44), entry("hot", 2, 10, 35),
               entry("mri", 0.5, 42, 50), entry("mri", 1, 18, 38), entry("mri", 2, 12, 36)};
  return t;
}

Scene scene(const std::string& tf, int side = 100) {
  Scene s;
  s.transferFunctionName = tf;
  s.width = s.height = side;
  return s;
}

TEST(QualityTarget, ParsesBothFormsAndRefusesTheRestWithTheFormsNamed) {
  EXPECT_EQ(QualityTarget::parse("psnr:40", "--quality"), (QualityTarget{QualityTarget::Kind::Psnr, 40}));
  EXPECT_EQ(QualityTarget::parse("ms:200", "--quality"), (QualityTarget{QualityTarget::Kind::Ms, 200}));
  EXPECT_EQ(QualityTarget::parse("psnr:42.5", "x").text(), "psnr:42.5");
  for (const char* bad : {"", "psnr", "psnr:", "psnr:abc", "psnr:40dB", "psnr:5", "psnr:101", "ms:0", "ms:-3", "ms:nan",
                          "ms:inf", "fps:30", "40"}) {
    try {
      QualityTarget::parse(bad, "--quality");
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const RenderInputError& e) {
      EXPECT_NE(std::string(e.what()).find("psnr:DB"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("--quality"), std::string::npos) << e.what();
    }
  }
}

TEST(QualityTable, ChoosesTheFastestSettingMeetingAPsnrTargetWithItsMargin) {
  const QualityChoice c = table().choose(QualityTarget::parse("psnr:40", "q"), scene("hot"));
  EXPECT_TRUE(c.met);
  EXPECT_EQ(c.setting.step, 1);
  EXPECT_EQ(c.expectedPsnr, 44);
  EXPECT_EQ(c.expectedMs, 20);
  EXPECT_EQ(c.basis, "hot, unshaded");
  // 44 dB is not a decibel above 43.5: the more accurate step 0.5 is needed.
  EXPECT_EQ(table().choose(QualityTarget::parse("psnr:43.5", "q"), scene("hot")).setting.step, 0.5);
  // The same target on another transfer function's entries.
  EXPECT_EQ(table().choose(QualityTarget::parse("psnr:40", "q"), scene("mri")).setting.step, 0.5);
}

TEST(QualityTable, ChoosesTheMostAccurateSettingWithinATimeScaledToTheImage) {
  EXPECT_EQ(table().choose(QualityTarget::parse("ms:25", "q"), scene("hot")).setting.step, 1);
  // 40 ms is not within 90 % of 40 ms (the margin), but is of 45.
  EXPECT_EQ(table().choose(QualityTarget::parse("ms:40", "q"), scene("hot")).setting.step, 1);
  EXPECT_EQ(table().choose(QualityTarget::parse("ms:45", "q"), scene("hot")).setting.step, 0.5);
  // Four times the pixels: four times the time, so 90 ms buys what 22.5 ms bought at 100².
  const QualityChoice c = table().choose(QualityTarget::parse("ms:90", "q"), scene("hot", 200));
  EXPECT_EQ(c.setting.step, 1);
  EXPECT_EQ(c.expectedMs, 80);
}

TEST(QualityTable, FallsBackToTheClosestSettingAndSaysTheTargetIsNotMet) {
  QualityChoice c = table().choose(QualityTarget::parse("psnr:60", "q"), scene("hot"));
  EXPECT_FALSE(c.met);
  EXPECT_EQ(c.setting.step, 0.5);  // the most accurate
  c = table().choose(QualityTarget::parse("ms:5", "q"), scene("hot"));
  EXPECT_FALSE(c.met);
  EXPECT_EQ(c.setting.step, 2);  // the fastest
}

TEST(QualityTable, WithoutEntriesForTheTransferFunctionEachSettingCountsAtItsWorst) {
  // Step 1: 44 dB on hot, 38 on mri: its worst misses 40, so step 0.5 (worst 50 dB, slowest 42 ms) is chosen.
  const QualityChoice c = table().choose(QualityTarget::parse("psnr:40", "q"), scene("grayscale"));
  EXPECT_EQ(c.setting.step, 0.5);
  EXPECT_EQ(c.expectedPsnr, 50);
  EXPECT_EQ(c.expectedMs, 42);
  EXPECT_NE(c.basis.find("no entry for grayscale"), std::string::npos) << c.basis;
  // Shading is part of the match.
  Scene shaded = scene("hot");
  shaded.shading = true;
  EXPECT_NE(table().choose(QualityTarget::parse("psnr:40", "q"), shaded).basis.find("no entry"), std::string::npos);
}

TEST(QualityTable, ReadsBackWhatItWritesAndRefusesMalformedTables) {
  QualityTable t = table();
  t.entries[1].setting = {1, false, 16, 0.99, true, 8, 2};
  const QualityTable back = QualityTable::fromJson(t.toJson(), "t");
  EXPECT_EQ(back.device, "test");
  EXPECT_EQ(back.width, 100);
  EXPECT_EQ(back.views, 4);
  ASSERT_EQ(back.entries.size(), t.entries.size());
  EXPECT_EQ(back.entries[1].setting, t.entries[1].setting);
  EXPECT_EQ(back.entries[2].psnrMin, 35);

  const json good = json::parse(t.toJson());
  auto refused = [&](json j, const std::string& expected) {
    try {
      QualityTable::fromJson(j.dump(), "q.json");
      ADD_FAILURE() << "accepted " << j.dump();
    } catch (const RenderInputError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("q.json"), std::string::npos) << e.what();
    }
  };
  json j = good;
  j["format"] = "other";
  refused(j, "not a voxbrick quality table");
  j = good;
  j["version"] = 9;
  refused(j, "version 9");
  j = good;
  j["entries"][0].erase("step");
  refused(j, "'step'");
  j = good;
  j["entries"][0]["step"] = 0;  // a setting no scene accepts
  refused(j, "setting is invalid");
  j = good;
  j["entries"][0]["sub_block"] = 12;
  refused(j, "setting is invalid");
  j = good;
  j["entries"][0]["psnr_min"] = "high";
  refused(j, "'psnr_min'");
  refused(json::array(), "not a voxbrick quality table");
  EXPECT_THROW(QualityTable::fromJson("{", "q.json"), RenderInputError);
  EXPECT_THROW(QualityTable{}.choose(QualityTarget{}, scene("hot")), RenderInputError);
}

TEST(QualityScene, TheSceneKeyReadsBackAndExcludesTheSettingsItChooses) {
  const Scene s = Scene::fromJson(R"({"quality": "psnr:45", "size": [64, 32]})", "scene");
  ASSERT_TRUE(s.quality);
  EXPECT_EQ(s.quality->text(), "psnr:45");
  const json written = json::parse(s.toJson());
  EXPECT_EQ(written["quality"], "psnr:45");
  EXPECT_FALSE(written.contains("step"));
  EXPECT_EQ(Scene::fromJson(s.toJson(), "again").quality, s.quality);
  for (const char* key : kQualityChosenKeys) {
    json j = {{"quality", "ms:100"}};
    j[key] = json::parse(std::string(key) == "raycast" || std::string(key) == "pre_integration" ? "true" : "1");
    EXPECT_THROW(Scene::fromJson(j.dump(), "scene"), RenderInputError) << key;
  }
  EXPECT_THROW(Scene::fromJson(R"({"quality": 40})", "scene"), RenderInputError);
  EXPECT_THROW(Scene::fromJson(R"({"quality": "psnr:400"})", "scene"), RenderInputError);
}

// End to end: a small store calibrated by the real command; at one of the calibration's views a target's frame is at
// least as accurate as asked, measured here against the reference renderer.
TEST(QualityEndToEnd, APsnrTargetGivesAFrameThatReachesItAgainstTheReference) {
  test::ScratchDir dir;
  const std::string store = (dir / "ml.vbs").string();
  auto r = test::runVoxbrick("prep synthetic:marschner-lobb,n=40 --no-vdb -q -o " + store);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  r = test::runVoxbrick("render " + store + " --tf hot --quality psnr:40 -q -o " + (dir / "x.png").string());
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.output.find("bench --calibrate"), std::string::npos) << r.output;

  r = test::runVoxbrick("bench --calibrate " + store + " --tf hot --size 48 --views 2 --steps 0.5,1,3 -q");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const QualityTable table = *QualityTable::load(store);
  EXPECT_EQ(table.width, 48);
  EXPECT_EQ(table.views, 2);
  EXPECT_GE(table.entries.size(), 9u);  // 3 steps x (slicing, ray caster with and without ERT, ...)

  // The calibration's view 0: azimuth 0, elevation 20, 2.2 radii (quality::viewScene).
  const std::string view = " --tf hot --size 48x48 --orbit 0,20,2.2 -q";
  r = test::runVoxbrick("render " + store + view + " --backend reference -o " + (dir / "ref.png").string());
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const image::ImageF reference = image::toImageF(image::readPng(dir / "ref.png"));
  int met = 0;
  std::map<std::string, std::vector<uint8_t>> frames;  // by chosen setting
  for (double target : {30.0, 40.0, 45.0}) {
    const std::string png = (dir / "q.png").string(), stats = (dir / "q.json").string();
    r = test::runVoxbrick("render " + store + view + " --quality psnr:" + std::to_string(target) + " -o " + png +
                          " --stats " + stats);
    ASSERT_EQ(r.exitCode, 0) << r.output;
    const std::vector<char> text = test::readFile(stats);
    const json q = json::parse(std::string(text.begin(), text.end()))["quality"];
    SCOPED_TRACE(q.dump());
    const image::Image8 frame = image::readPng(png);
    frames[q["setting"].get<std::string>()] = frame.rgba;
    if (!q["met"].get<bool>()) continue;  // the table says no setting reaches it: nothing is promised
    ++met;
    EXPECT_GE(q["expected_psnr"].get<double>(), target + QualityTable::kPsnrMargin);
    const double psnr = image::compareImages(image::toImageF(frame), reference).psnr;
    // The frame is 8-bit like the reference's PNG: allow the rounding of both (< 0.5 dB at these levels).
    EXPECT_GE(psnr, target - 0.5);
  }
  EXPECT_GE(met, 2);
  // The targets chose different settings, and the settings were applied: their frames differ.
  ASSERT_GE(frames.size(), 2u);
  EXPECT_NE(frames.begin()->second, frames.rbegin()->second);
}

}  // namespace
}  // namespace voxbrick::render
