// The first hour's mistakes, as a user makes them with the real binary: each message names the thing, suggests the
// closest valid choice or lists the choices, and carries no internal prefix or protocol message name.
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "cli/CliRun.h"
#include "server/ServerProcess.h"
#include "support/TestSupport.h"

namespace voxbrick {
namespace {

namespace fs = std::filesystem;
using test::runSplit;

std::string blobs() { return test::preppedStore("synthetic:blobs,n=32", "--brick 16"); }

bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

/// No function-name prefix ("Foo::bar: "), no protocol message name, no path of the binary.
void expectPlain(const std::string& err) {
  EXPECT_FALSE(has(err, "::")) << err;
  EXPECT_FALSE(has(err, "ListDatasets")) << err;
  EXPECT_FALSE(has(err, VOXBRICK_EXE)) << err;
}

/// The options of `voxbrick SUB --help`: for each, its first line's head (names, type, range: the text before the
/// description column) and its whole entry with runs of white space as one space.
struct HelpEntry {
  std::string head, text;
};
std::map<std::string, HelpEntry> helpEntries(const std::string& sub) {
  const auto r = runSplit(sub + " --help", 30);
  EXPECT_EQ(r.exitCode, 0) << r.err;
  std::map<std::string, HelpEntry> entries;
  std::istringstream lines(r.out.substr(std::min(r.out.size(), r.out.find("\nOptions:"))));
  std::string line, name;
  while (std::getline(lines, line)) {
    if (line.rfind("  -", 0) == 0) {
      const size_t gap = line.find("  ", 2);
      const std::string head = line.substr(2, gap == std::string::npos ? std::string::npos : gap - 2);
      name = head.substr(0, head.find(' '));
      if (const size_t comma = name.rfind(','); comma != std::string::npos) name = name.substr(comma + 1);
      entries[name].head = head;
    } else if (name.empty()) {
      continue;
    }
    for (char c : line) {
      std::string& text = entries[name].text;
      if (!std::isspace(static_cast<unsigned char>(c)) || (!text.empty() && text.back() != ' '))
        text += std::isspace(static_cast<unsigned char>(c)) ? ' ' : c;
    }
    entries[name].text += ' ';
  }
  return entries;
}

size_t count(const std::string& text, const std::string& part) {
  size_t n = 0;
  for (size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + 1)) ++n;
  return n;
}

// Help texts say each default one way, "(default VALUE)" at the end of the text (the value the parser holds, or for
// serve the built-in one with its configuration key: ServeHelp in the server tests), never CLI11's "=VALUE" after
// the type; an option that takes a value and shows no default is required or one of those whose absence means
// "none" (an output not written, an input not given). One idea has one name across commands.
TEST(Messages, HelpTextsSayEveryDefaultOneWay) {
  // Options without a default: absent, nothing is written or read, or the input decides.
  const std::set<std::string> noDefault = {
      "prep --dims",        "prep --type",
      "prep --series",      "prep --quantise",
      "prep --grid",        "render --stats",
      "render --scene",     "render --analytic",

      "orbit --scene",      "orbit --interactive",
      "serve --port-file",  "serve --http-port-file",
      "serve --config",     "serve --http",
      "serve --replay-frames",
      "request --dataset",  "request --output",
      "request --stats",    "request --scene",
      "load --json",        "load --corrupt-dataset",
      "load --interactive", "load --provisional-encoding",
      "compare --heatmap",  "bench --calibrate",
      "scene --scene",
  };
  std::set<std::string> unusedExceptions = noDefault;
  for (const char* sub :
       {"prep", "info", "render", "orbit", "serve", "request", "load", "compare", "bench", "presets", "scene"}) {
    const auto entries = helpEntries(sub);
    ASSERT_FALSE(entries.empty()) << sub;
    for (const auto& [name, e] : entries) {
      const std::string what = std::string(sub) + " " + name;
      EXPECT_EQ(e.head.find('='), std::string::npos) << what << ": a default after the type: " << e.head;
      EXPECT_LE(count(e.text, "(default"), 1u) << what << ": " << e.text;
      // The second word of the head is the value's form (TEXT, INT:..., WxH); a flag has none, or only
      // "Excludes:"/"Needs:".
      const std::string second = e.head.find(' ') == std::string::npos ? "" : e.head.substr(e.head.find(' ') + 1);
      const bool takesValue = !second.empty() && second.rfind("Excludes:", 0) != 0 && second.rfind("Needs:", 0) != 0;
      const bool required = e.head.find("REQUIRED") != std::string::npos;
      if (!takesValue || required) continue;
      if (noDefault.count(what)) {
        unusedExceptions.erase(what);
        continue;
      }
      EXPECT_NE(e.text.find("(default"), std::string::npos) << what << " shows no default: " << e.text;
    }
    EXPECT_EQ(entries.count("--host-budget"), 0u) << sub << " lists the old name of --host-cache";
  }
  std::string unused;
  for (const std::string& what : unusedExceptions) unused += " '" + what + "'";
  EXPECT_TRUE(unused.empty()) << "listed as having no default but required, shown with one, or gone:" << unused;
  for (const char* sub : {"render", "orbit", "serve"}) {
    const auto entries = helpEntries(sub);
    EXPECT_EQ(entries.count("--host-cache"), 1u) << sub;
    EXPECT_EQ(entries.count("--gpu-budget"), 1u) << sub;
  }
  // The old name of --host-cache says the new one.
  const auto old = runSplit("render " + blobs() + " --host-budget 64 -o f.png", 30);
  EXPECT_EQ(old.exitCode, 1);
  EXPECT_TRUE(has(old.err, "unknown option '--host-budget': it is now '--host-cache'")) << old.err;
}

// A value of the wrong shape: the option, the value and an example of a good one, in one form for every command.
TEST(Messages, BadFormatsNameTheOptionTheValueAndAnExample) {
  const struct {
    std::string args, says;
  } cases[] = {
      {"prep in.raw -o s --dims 1,2 --type u8", "--dims: must be three comma-separated numbers, not '1,2'; e.g. "},
      {"prep in.raw -o s --dims 4,4,4 --type u8 --spacing 1,x,1", "--spacing: 'x' is not a number, in '1,x,1'; e.g. "},
      {"render s -o f.png --size 512", "--size: must be WxH, integers between 1 and 8192 pixels, not '512'; e.g. "},
      {"render s -o f.png --window 5", "--window: must be LO,HI in increasing order, not '5'; e.g. "},
      {"load 127.0.0.1:1 --dataset d --size 512", "--size: must be WxH, not '512'; e.g. 512x512"},
      {"request 127.0.0.1 --dataset d -o f.png", "'127.0.0.1' is not HOST:PORT; e.g. 127.0.0.1:7420"},
  };
  test::ScratchDir dir;
  test::writeFile(dir / "in.raw", std::string(64, '\0'));
  for (const auto& c : cases) {
    const auto r = runSplit(c.args, 30, "cd '" + dir.path().string() + "';");
    EXPECT_EQ(r.exitCode, 1) << c.args << "\n" << r.out << r.err;
    EXPECT_EQ(test::lineCount(r.err), 1) << r.err;
    EXPECT_TRUE(has(r.err, c.says)) << c.args << "\n" << r.err;
    expectPlain(r.err);
  }
}

TEST(Messages, NoSubcommandListsThem) {
  const auto r = runSplit("", 30);
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_TRUE(has(r.err, "voxbrick: error: a subcommand is needed: one of prep, info, render")) << r.err;
  expectPlain(r.err);
}

TEST(Messages, AMistypedSubcommandGetsTheClosest) {
  const auto r = runSplit("rendr x -o y.png", 30);
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_TRUE(has(r.err, "no subcommand 'rendr'; did you mean 'render'?")) << r.err;
  EXPECT_TRUE(has(r.err, "serve")) << "the choices are listed: " << r.err;
  expectPlain(r.err);
}

TEST(Messages, AnUnknownOptionIsNamedFirst) {
  test::ScratchDir dir;
  const auto r = runSplit("render " + blobs() + " --transfer mri -o " + (dir / "x.png").string(), 30);
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_TRUE(has(r.err, "voxbrick render: error: unknown option '--transfer'")) << r.err;
  EXPECT_TRUE(has(r.err, "voxbrick render --help lists the options")) << r.err;
  EXPECT_FALSE(has(r.err, "were not expected")) << r.err;
  const auto close = runSplit("render " + blobs() + " --sise 64x64 -o " + (dir / "x.png").string(), 30);
  EXPECT_TRUE(has(close.err, "unknown option '--sise'; did you mean '--size'?")) << close.err;
}

TEST(Messages, UsageLinesSayVoxbrickNotThePathOfTheBinary) {
  const auto r = runSplit("render --help", 30);
  EXPECT_EQ(r.exitCode, 0);
  EXPECT_TRUE(has(r.out, "Usage: voxbrick render")) << r.out;
  EXPECT_FALSE(has(r.out, VOXBRICK_EXE)) << r.out;
}

TEST(Messages, PresetsAreFoundButForCaseAndSuggestedWhenMistyped) {
  test::ScratchDir dir;
  const auto upper = runSplit("render -q " + blobs() + " --size 32x32 --tf MRI -o " + (dir / "a.png").string(), 120);
  EXPECT_EQ(upper.exitCode, 0) << "a preset named but for case is the preset: " << upper.err;
  const auto typo = runSplit("render -q " + blobs() + " --size 32x32 --tf mrri -o " + (dir / "b.png").string(), 120);
  EXPECT_EQ(typo.exitCode, 1);
  EXPECT_TRUE(has(typo.err, "no preset 'mrri'")) << typo.err;
  EXPECT_TRUE(has(typo.err, "did you mean 'mri'?")) << typo.err;
  EXPECT_TRUE(has(typo.err, "presets: ")) << typo.err;
  expectPlain(typo.err);
}

TEST(Messages, AnUnknownDatasetGetsTheServersListAndTheClosest) {
  test::ScratchDir dir;
  fs::create_directories(dir / "datasets");
  fs::copy(blobs(), dir / "datasets" / "blobs.vbs", fs::copy_options::recursive);
  test::ServerProcess server("--no-config --datasets " + (dir / "datasets").string() + " --render-threads 1",
                             dir.path());
  const std::string address = "127.0.0.1:" + std::to_string(server.port());
  const auto r = runSplit("request " + address + " --dataset blobs --size 32x32 -o " + (dir / "x.png").string(), 60);
  EXPECT_NE(r.exitCode, 0);
  EXPECT_TRUE(has(r.err, "no dataset 'blobs'; did you mean 'blobs.vbs'? (one of: blobs.vbs)")) << r.err;
  expectPlain(r.err);
  const auto ok =
      runSplit("request " + address + " --dataset blobs.vbs --size 32x32 -o " + (dir / "y.png").string(), 60);
  EXPECT_EQ(ok.exitCode, 0) << ok.err;
}

TEST(Messages, AMissingPathIsReportedTheSameWayByEveryCommand) {
  test::ScratchDir dir;
  const std::string missing = (dir / "data" / "mri.vb").string();
  for (const std::string& command : {"prep " + missing + " -o " + (dir / "s").string(), "info " + missing,
                                     "render " + missing + " -o " + (dir / "x.png").string()}) {
    const auto r = runSplit(command, 60);
    EXPECT_EQ(r.exitCode, 1) << command;
    EXPECT_TRUE(has(r.err, ": error: " + missing + ": no such file or directory")) << command << ": " << r.err;
    expectPlain(r.err);
  }
}

}  // namespace
}  // namespace voxbrick
