// The scene options as a user meets them, against the scene's schema (`voxbrick scene --schema`): every key has its
// option in the help of every command that draws or asks for a scene, with the schema's default, or is one the
// command line deliberately leaves to scene files; each option sets its key; options lie over a scene file by the
// schema's rules.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli/CliRun.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

using nlohmann::json;
using test::runSplit;

/// The scene keys with no command-line option, each for a reason: the group itself; the keys of a moving camera,
/// which the viewer sets per frame and `orbit --interactive MS` per view; the encodings of a server's frames, which
/// `request` sets from its own --jpeg-quality and --encoding; the restart of a video stream, which a client asks
/// for when its decoder lost the stream; and what a client's decoders take (`load --vp9-444` sets one).
const std::set<std::string> kSceneOnly = {"camera",       "interactive", "time_budget_ms",
                                          "jpeg_quality", "provisional_encoding", "keyframe",
                                          "accepts_webp", "accepts_vp9_444"};

/// The commands with the scene options.
const std::vector<std::string> kCommands = {"render", "orbit", "request", "scene"};

const json& schema() {
  static const json s = [] {
    const test::SplitResult r = runSplit("scene --schema");
    EXPECT_EQ(r.exitCode, 0) << r.err;
    return json::parse(r.out);
  }();
  return s;
}

/// The JSON `voxbrick scene ARGS` prints; fails the test if it does not succeed.
json sceneOf(const std::string& args) {
  const test::SplitResult r = runSplit("scene " + args);
  EXPECT_EQ(r.exitCode, 0) << "voxbrick scene " << args << "\n" << r.err;
  return r.exitCode == 0 ? json::parse(r.out) : json();
}

/// `key` ("camera.fov") of a scene object, or null.
json at(const json& scene, const std::string& key) {
  std::string pointer = "/" + key;
  std::replace(pointer.begin(), pointer.end(), '.', '/');
  return scene.contains(json::json_pointer(pointer)) ? scene[json::json_pointer(pointer)] : json();
}

/// The help of `option` in `help`: from its line to the next option's.
std::string helpOf(const std::string& help, const std::string& option) {
  size_t start = help.find("\n  " + option + " ");
  if (start == std::string::npos) start = help.find("\n  " + option + "\n");
  if (start == std::string::npos) return "";
  const size_t end = help.find("\n  -", start + 1);
  return help.substr(start, end == std::string::npos ? std::string::npos : end - start);
}

TEST(SceneOptions, EveryKeyHasItsOptionWithItsDefaultInEveryCommandsHelp) {
  std::vector<std::string> helps;
  for (const std::string& command : kCommands) {
    const test::SplitResult r = runSplit(command + " --help");
    ASSERT_EQ(r.exitCode, 0) << command << "\n" << r.err;
    helps.push_back(r.out);
  }
  int options = 0;
  for (const json& k : schema()["keys"]) {
    const std::string key = k["key"];
    if (k["option"].is_null()) {
      EXPECT_TRUE(kSceneOnly.count(key)) << "the scene key '" << key << "' has no command-line option";
      continue;
    }
    EXPECT_FALSE(kSceneOnly.count(key)) << key << " has an option now: take it off kSceneOnly";
    const std::string option = k["option"];
    for (size_t c = 0; c < kCommands.size(); ++c) {
      const std::string help = helpOf(helps[c], option);
      ASSERT_FALSE(help.empty()) << kCommands[c] << " --help lacks " << option << " (scene key '" << key << "')";
      EXPECT_NE(help.find("'" + key + "'"), std::string::npos) << help;
      EXPECT_NE(help.find("(default " + k["default_text"].get<std::string>() + ")"), std::string::npos) << help;
      if (k.contains("option_allowed")) {
        EXPECT_NE(help.find(k["option_allowed"].get<std::string>()), std::string::npos) << help;
      }
    }
    ++options;
  }
  EXPECT_GE(options, 25);
  for (const std::string& key : kSceneOnly) {
    bool found = false;
    for (const json& k : schema()["keys"]) found = found || k["key"] == key;
    EXPECT_TRUE(found) << key << " is no scene key: take it off kSceneOnly";
  }
}

TEST(SceneOptions, TheSchemasDefaultsAreTheDefaultScenes) {
  const json plain = sceneOf("");
  int compared = 0;
  for (const json& k : schema()["keys"]) {
    const json value = at(plain, k["key"]);
    if (value.is_null() || k["default"].is_null()) continue;
    EXPECT_EQ(value, k["default"]) << k["key"];
    ++compared;
  }
  EXPECT_GE(compared, 20);
}

TEST(SceneOptions, EachOptionSetsItsKey) {
  const json plain = sceneOf("");
  int set = 0;
  for (const json& k : schema()["keys"]) {
    if (k["option"].is_null() || k["example"].is_null()) continue;
    const std::string key = k["key"];
    SCOPED_TRACE(key);
    const bool flag = k.contains("flag_value");
    std::string args = flag ? k["option"].get<std::string>()
                            : k["option"].get<std::string>() + "='" + k["option_example"].get<std::string>() + "'";
    // What the key needs comes with it (center and up need an eye).
    for (const json& r : schema()["rules"])
      if (r["kind"] == "needs" && r["keys"][0] == key)
        for (const json& other : schema()["keys"])
          if (other["key"] == r["keys"][1])
            args += " " + other["option"].get<std::string>() + "='" + other["option_example"].get<std::string>() + "'";
    const json scene = sceneOf(args);
    if (k["written"] == "never") {
      EXPECT_NE(scene, plain) << args;  // a view: another orbit
    } else if (k["type"] == "transfer_function") {
      EXPECT_NE(at(scene, key), at(plain, key)) << args;
    } else {
      EXPECT_EQ(at(scene, key), flag ? k["flag_value"] : k["example"]) << args;
    }
    ++set;
  }
  EXPECT_GE(set, 25);
}

TEST(SceneOptions, OptionsLieOverASceneFileByTheSchemasRules) {
  test::ScratchDir dir;
  const auto file = [&](const std::string& name, const std::string& text) {
    test::writeFile(dir / name, text);
    return "--scene " + (dir / name).string();
  };
  const std::string eye =
      file("eye.json", R"({"camera": {"eye": [0, -300, 0], "center": [0, 0, 10], "up": [0, 0, 1]}})");
  // --orbit replaces the file's eye, with its center and up.
  json s = sceneOf(eye + " --orbit 10,20");
  EXPECT_EQ(s["camera"]["orbit"], json({10, 20}));
  EXPECT_FALSE(s["camera"].contains("eye"));
  // --center changes the file's explicit camera.
  s = sceneOf(eye + " --center 1,2,3");
  EXPECT_EQ(s["camera"]["eye"], json({0, -300, 0}));
  EXPECT_EQ(s["camera"]["center"], json({1, 2, 3}));
  EXPECT_EQ(s["camera"]["up"], json({0, 0, 1}));
  // A quality target in the file gives way to a setting it would choose, and the other way round.
  s = sceneOf(file("quality.json", R"({"quality": "psnr:40", "shading": true})") + " --step 0.5");
  EXPECT_FALSE(s.contains("quality"));
  EXPECT_EQ(s["step"], 0.5);
  EXPECT_EQ(s["shading"], true);
  s = sceneOf(file("step.json", R"({"step": 0.5, "lod": 2})") + " --quality ms:100");
  EXPECT_EQ(s["quality"], "ms:100");
  // --slab asks for slabs over the file's raycast, unless --raycast is given too.
  const std::string raycast = file("raycast.json", R"({"raycast": true})");
  EXPECT_EQ(sceneOf(raycast + " --slab 8")["raycast"], false);
  EXPECT_EQ(sceneOf(raycast + " --slab 8 --raycast")["raycast"], true);
  EXPECT_EQ(sceneOf("--slab 0")["raycast"], false);

  struct Refused {
    std::string args, says;
  };
  const std::vector<Refused> refused = {
      {eye + " --fit", "--fit cannot be combined with " + (dir / "eye.json").string() + "'s 'camera.eye'"},
      {eye + " --up-axis=-y", "--up-axis cannot be combined with"},
      {file("view.json", R"({"camera": {"view": "left"}})") + " --up-axis=y", "--up-axis cannot be combined with"},
      {"--quality psnr:40 --step 0.5", "--quality cannot be combined with --step: a quality target chooses it"},
      {"--orbit 1,2 --eye 1,2,3", "--orbit cannot be combined with --eye"},
      {"--view left --orbit 1,2", "--view cannot be combined with --orbit"},
      {"--center 1,2,3", "--center needs --eye"},
      {"--window 5,1", "--window: must be LO,HI in increasing order, not '5,1'"},
      {"--ert 0.3", "--ert: must be 0 or between 0.5 and 1, not '0.3'"},
      {"--size 0x10", "--size: must be WxH, integers between 1 and 8192 pixels, not '0x10'"},
      {"--view front", "--view: must be one of anterior, posterior, left, right, superior, inferior, not 'front'"},
      {"--view Anterior",
       "--view: must be one of anterior, posterior, left, right, superior, inferior, not 'Anterior'; did you mean "
       "'anterior'?"},
      {"--view superio", "not 'superio'; did you mean 'superior'?"},
      {"--size 512", "--size: must be WxH, integers between 1 and 8192 pixels, not '512'; e.g. "},
      {"--orbit 1", "--orbit: must be AZ,EL[,DIST], not '1'; e.g. 10,20,3"},
  };
  for (const Refused& r : refused) {
    const test::SplitResult result = runSplit("scene " + r.args);
    EXPECT_EQ(result.exitCode, 1) << r.args << "\n" << result.out;
    EXPECT_EQ(test::lineCount(result.err), 1) << result.err;
    EXPECT_NE(result.err.find(r.says), std::string::npos) << r.args << "\n" << result.err;
  }
}

TEST(SceneOptions, SchemaTakesNoSceneOptions) {
  const test::SplitResult r = runSplit("scene --schema --step 1");
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("--schema prints the schema"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace voxbrick
