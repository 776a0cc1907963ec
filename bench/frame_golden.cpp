// Golden frames for refactors of the renderer: renders a fixed matrix of scenes and settings (every option the
// tests and `voxbrick bench` cover) over stores made on the spot, and writes or checks the float images bit for bit.
//
//   frame_golden --work DIR --write GOLDEN_DIR   # before a change: one .f32 file per frame
//   frame_golden --work DIR --check GOLDEN_DIR   # after it: every frame must be byte-identical
//   frame_golden --work DIR --hashes FILE        # against committed digests (bench/results/golden/golden-frames.txt)
//   ... --fill-cell-tables                       # the ray caster's tables filled anew each frame: the same frames
//
// Bit-identical is the bar for a change that only moves code: any difference in a float means the GPU did other
// arithmetic, which is a behaviour change. The matrix stays in this one file so that the same source builds against
// the code before and after the change.
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "brickstore/ingest/Sources.h"
#include "brickstore/prep/StoreWriter.h"
#include "brickstore/read/BrickCache.h"
#include "brickstore/read/BrickStore.h"
#include "render/core/Scene.h"
#include "render/gl/GlContext.h"
#include "render/gl/volume/BrickAtlas.h"
#include "render/gl/volume/VolumeRenderer.h"
#include "render/reference/ReferenceRenderer.h"

namespace fs = std::filesystem;
using namespace voxbrick;

namespace {

/// The exit status of --hashes on a GPU, whose frames the committed (llvmpipe) digests do not describe.
constexpr int kNotCompared = 77;

struct Options {
  std::string work = "golden-work";
  std::string write;   ///< write each frame into this directory
  std::string check;   ///< check each frame against this directory
  std::string hashes;  ///< check each frame against this digest file
  bool fillCellTables = false;
};

struct Case {
  std::string name;
  std::string store;  // key into the stores map
  std::string sceneJson;
  size_t gpuBudgetMB = 256;
  render::AtlasFormat format = render::AtlasFormat::Float;
  render::RenderMode mode = render::RenderMode::Normal;
  bool reference = false;  // the CPU reference renderer instead of the GPU
  std::string analytic{};  // with reference: sample this synthetic field instead of the grid
};

/// FNV-1a, 64 bits: a digest of a frame's floats, enough to tell any changed bit (not a cryptographic hash).
uint64_t fnv1a(const std::string& bytes) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : bytes) h = (h ^ c) * 1099511628211ull;
  return h;
}

/// Lines "NAME DIGEST STATS..." of a digest file, by name.
std::map<std::string, std::string> readDigests(const fs::path& file) {
  std::map<std::string, std::string> out;
  std::ifstream in(file);
  for (std::string line; std::getline(in, line);)
    if (!line.empty() && line[0] != '#') out[line.substr(0, line.find(' '))] = line.substr(line.find(' ') + 1);
  return out;
}

std::shared_ptr<const store::BrickStore> prepStore(const std::string& spec, const fs::path& out, int brick) {
  if (!fs::exists(out / "store.json")) {
    auto source = store::openSource(spec, {});
    store::PrepOptions options;
    options.brickSize = brick;
    options.writeVdb = false;
    store::prepStore(*source, out, options);
  }
  return store::BrickStore::open(out);
}

std::vector<Case> cases() {
  std::vector<Case> out;
  // The Y-up orbit of the digests' time (the default up axis is now +z): the same floats.
  const std::vector<std::string> views = {
      R"("orbit": [30, 20, 2.5], "up_axis": "+y")", R"("orbit": [90, 0, 2.2], "up_axis": "+y")",
      R"("orbit": [0, 90, 2.5], "up_axis": "+y")", R"("orbit": [200, -35, 1.6], "up_axis": "+y")"};
  // Slicing of level 0, as when the digests were taken: the default drawing is now texture slabs with level of
  // detail (render/core/Scene.h).
  auto scene = [](const std::string& camera, const std::string& rest) {
    const std::string drawing = std::string(R"("slab": 0, "ert": 0, "lod": 0)") +
                                (rest.find("sub_block") == std::string::npos ? R"(, "sub_block": 0)" : "");
    return "{\"camera\": {" + camera + "}, \"size\": [96, 80], " + drawing + (rest.empty() ? "" : ", " + rest) + "}";
  };
  for (const std::string store : {"ml32", "sparse32", "mri32", "mri16"}) {
    const std::string tf = store == "sparse32"          ? R"("transfer_function": "sparse")"
                           : store.rfind("mri", 0) == 0 ? R"("transfer_function": "mri")"
                                                        : R"("transfer_function": "grayscale")";
    for (size_t v = 0; v < views.size(); ++v) {
      const std::string tag = store + "-v" + std::to_string(v);
      out.push_back({tag + "-default", store, scene(views[v], tf)});
      out.push_back({tag + "-cpu", store, scene(views[v], tf + R"(, "slicer": "cpu")")});
      out.push_back({tag + "-shaded", store, scene(views[v], tf + R"(, "shading": true)")});
      out.push_back({tag + "-sub8", store, scene(views[v], tf + R"(, "sub_block": 8)")});
      out.push_back({tag + "-sub4-cpu", store, scene(views[v], tf + R"(, "sub_block": 4, "slicer": "cpu")")});
      out.push_back({tag + "-noskip", store, scene(views[v], tf + R"(, "skip_empty": false, "cull": false)")});
      out.push_back({tag + "-step2", store, scene(views[v], tf + R"(, "step": 2)")});
      out.push_back({tag + "-step025", store, scene(views[v], tf + R"(, "step": 0.25)")});
    }
    const std::string v0 = views[0];
    out.push_back({store + "-ortho", store, scene(v0 + R"(, "orthographic": true)", tf)});
    out.push_back({store + "-ortho-sub8", store, scene(v0 + R"(, "orthographic": true)", tf + R"(, "sub_block": 8)")});
    out.push_back({store + "-inside", store, scene(R"("orbit": [40, 10, 0.3], "up_axis": "+y", "fov": 70)", tf)});
    // Explicit cameras are world coordinates: the MRI's box is centred on (0, -14.75, 9.25) (its sform), the same
    // view of its box as (0, 0, 400) was of the box centred on the origin.
    const std::string axis = store.rfind("mri", 0) == 0
                                 ? R"("eye": [0, -14.75, 409.25], "center": [0, -14.75, 9.25], "up": [0, 1, 0])"
                                 : R"("eye": [0, 0, 400], "center": [0, 0, 0], "up": [0, 1, 0])";
    out.push_back({store + "-axis", store, scene(axis, tf)});
    out.push_back(
        {store + "-window-bg", store, scene(v0, tf + R"(, "window": [0.1, 0.6], "background": [0.2, 0.3, 0.4])")});
    out.push_back({store + "-ct-bone-shaded", store, scene(v0, R"("transfer_function": "ct-bone", "shading": true)")});
    out.push_back({store + "-tight-budget", store, scene(v0, tf), 1});
    out.push_back({store + "-tight-budget-sub8", store, scene(v0, tf + R"(, "sub_block": 8)"), 1});
    out.push_back({store + "-native", store, scene(v0, tf), 256, render::AtlasFormat::Native});
    out.push_back({store + "-half", store, scene(v0, tf), 256, render::AtlasFormat::Half});
    out.push_back({store + "-roofline", store, scene(v0, tf + R"(, "skip_empty": false)"), 256,
                   render::AtlasFormat::Float, render::RenderMode::Roofline});
    out.push_back({store + "-roofline-cpu", store, scene(v0, tf + R"(, "slicer": "cpu")"), 256,
                   render::AtlasFormat::Float, render::RenderMode::Roofline});
    // The frame ray caster (the default drawing) at level 0, view after view with the same renderer: its cell table
    // kept from frame to frame, changed by a level cut, a window, stand-ins of another level, and a frame of batches.
    auto cast = [](const std::string& camera, const std::string& rest) {
      return "{\"camera\": {" + camera + "}, \"size\": [96, 80], \"lod\": 0, " + rest + "}";
    };
    for (size_t v = 0; v < views.size(); ++v)
      out.push_back({store + "-v" + std::to_string(v) + "-raycast", store, cast(views[v], tf)});
    out.push_back({store + "-raycast-lod", store, cast(views[3], tf + R"(, "lod": 2)")});
    out.push_back({store + "-raycast-window", store, cast(v0, tf + R"(, "window": [0.1, 0.6])")});
    out.push_back({store + "-raycast-sub4-pre", store, cast(v0, tf + R"(, "sub_block": 4, "pre_integration": true)")});
    out.push_back({store + "-raycast-shaded", store, cast(views[1], tf + R"(, "shading": true)")});
    out.push_back({store + "-raycast-tight-budget", store, cast(v0, tf), 1});
  }
  // The CPU reference renderer: small, since it is slow on purpose.
  auto reference = [&](const std::string& name, const std::string& store, const std::string& json,
                       const std::string& analytic = "") {
    Case c{name, store, json};
    c.reference = true;
    c.analytic = analytic;
    out.push_back(c);
  };
  const std::string v0 = R"("camera": {"orbit": [30, 20, 2.5], "up_axis": "+y"}, "size": [40, 32])";
  reference("ref-ml32", "ml32", "{" + v0 + "}");
  reference("ref-ml32-shaded", "ml32", "{" + v0 + R"(, "shading": true})");
  reference("ref-ml32-analytic", "ml32", "{" + v0 + "}", "marschner-lobb");
  reference("ref-sparse32", "sparse32", "{" + v0 + R"(, "transfer_function": "sparse"})");
  reference("ref-sparse32-noskip", "sparse32", "{" + v0 + R"(, "transfer_function": "sparse", "skip_empty": false})");
  reference("ref-mri32-window-bg", "mri32",
            "{" + v0 + R"(, "transfer_function": "ct-bone", "window": [20, 200], "background": [0.2, 0.3, 0.4]})");
  reference("ref-mri32-ortho", "mri32",
            R"({"camera": {"orbit": [90, 0, 2.2], "up_axis": "+y", "orthographic": true}, "size": [40, 32], )"
            R"("transfer_function": "mri"})");
  return out;
}

/// A rendered frame: its floats as bytes and its statistics as the line the golden files keep.
struct Frame {
  std::string bytes, statsLine;
};

using Stores = std::map<std::string, std::shared_ptr<const store::BrickStore>>;

Stores goldenStores(const fs::path& work) {
  const std::string mri = "/usr/share/mricron/templates/ch2better.nii.gz";
  return {{"ml32", prepStore("synthetic:marschner-lobb,n=48", work / "ml32.vbs", 32)},
          {"sparse32", prepStore("synthetic:sparse,n=96", work / "sparse32.vbs", 32)},
          {"mri32", prepStore(mri, work / "mri32.vbs", 32)},
          {"mri16", prepStore(mri, work / "mri16.vbs", 16)}};
}

/// The CPU reference renderer's frame of `c`, its statistics in the GPU's fields.
image::ImageF referenceFrame(const Stores& stores, const Case& c, const render::Scene& scene,
                             render::FrameStats& stats) {
  auto cache = std::make_shared<store::BrickCache>(stores.at(c.store), size_t(256) << 20, 0);
  render::ReferenceOptions options;
  if (!c.analytic.empty()) options.analytic = render::analyticFieldFor(cache->store()->meta(), c.analytic);
  render::ReferenceStats referenceStats;
  image::ImageF image = render::ReferenceRenderer(cache).render(scene, options, &referenceStats);
  stats.fragments = referenceStats.samples;
  stats.slices = referenceStats.rays;
  stats.bricksDrawn = referenceStats.bricksSkipped;
  return image;
}

/// Renders the frames of the cases: one GPU renderer per (store, budget, format), kept across cases as a server
/// keeps them, so residency is exercised.
class Renderers {
 public:
  /// `fillCellTables`: the ray caster fills its cell table anew every frame (FrameOptions::keepCellTable false).
  Renderers(render::GlContext& context, Stores stores, bool fillCellTables)
      : mContext(context), mStores(std::move(stores)), mFillCellTables(fillCellTables) {}

  Frame render(const Case& c) {
    render::FrameStats stats;
    const render::Scene scene = render::Scene::fromJson(c.sceneJson, c.name);
    const image::ImageF image =
        c.reference ? referenceFrame(mStores, c, scene, stats) : renderer(c).render(scene, &stats, options(c));
    Frame f;
    f.bytes.assign(reinterpret_cast<const char*>(image.rgba.data()), image.rgba.size() * sizeof(float));
    f.statsLine = std::to_string(stats.fragments) + " " + std::to_string(stats.slices) + " " +
                  std::to_string(stats.bricksDrawn) + " " + std::to_string(stats.boxesDrawn) + " " +
                  std::to_string(stats.bricksPagedIn) + " " + std::to_string(stats.batches);
    return f;
  }

 private:
  render::VolumeRenderer& renderer(const Case& c) {
    const std::string key = c.store + "/" + std::to_string(c.gpuBudgetMB) + "/" + std::to_string(int(c.format));
    auto& slot = mRenderers[key];
    if (!slot)
      slot = std::make_unique<render::VolumeRenderer>(
          mContext, std::make_shared<store::BrickCache>(mStores.at(c.store), size_t(256) << 20, 1), c.gpuBudgetMB << 20,
          c.format);
    return *slot;
  }

  render::FrameOptions options(const Case& c) const {
    render::FrameOptions o;
    o.mode = c.mode;
    o.keepCellTable = !mFillCellTables;
    return o;
  }

  render::GlContext& mContext;
  Stores mStores;
  bool mFillCellTables = false;
  std::map<std::string, std::unique_ptr<render::VolumeRenderer>> mRenderers;
};

/// Whether the frame's digest and statistics are the committed ones; prints the case if not.
bool matchesDigest(const Case& c, const Frame& f, const std::map<std::string, std::string>& digests) {
  char digest[32];
  std::snprintf(digest, sizeof digest, "%016llx", (unsigned long long)fnv1a(f.bytes));
  const std::string actual = std::string(digest) + " " + f.statsLine;
  const auto expected = digests.find(c.name);
  if (expected != digests.end() && expected->second == actual) return true;
  std::cout << "DIFFERS: " << c.name << ": " << actual << ", expected "
            << (expected == digests.end() ? "no entry" : expected->second) << "\n";
  return false;
}

void writeGolden(const fs::path& golden, const Case& c, const Frame& f) {
  std::ofstream(golden / (c.name + ".f32"), std::ios::binary) << f.bytes;
  std::ofstream(golden / (c.name + ".stats")) << f.statsLine;
}

/// Whether the frame is byte for byte the one written before, with the same statistics; prints the case if not.
bool matchesGolden(const fs::path& golden, const Case& c, const Frame& f) {
  std::ifstream in(golden / (c.name + ".f32"), std::ios::binary), inStats(golden / (c.name + ".stats"));
  const std::string expected((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::string expectedStats;
  std::getline(inStats, expectedStats);
  if (expected == f.bytes && expectedStats == f.statsLine) return true;
  std::cout << "DIFFERS: " << c.name << (expected != f.bytes ? " (pixels)" : "") << " stats '" << f.statsLine
            << "' expected '" << expectedStats << "'\n";
  return false;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"frame_golden: the renderer's frames over a fixed matrix of scenes, written or checked bit for bit"};
  app.add_option("--work", o.work, "directory for the stores (made once, kept)")->capture_default_str();
  CLI::Option* write = app.add_option("--write", o.write, "write one .f32 (and .stats) file per frame here");
  CLI::Option* check = app.add_option("--check", o.check, "check every frame against the files --write made here");
  app.add_option("--hashes", o.hashes, "check every frame against committed digests (bench/results/golden/golden-frames.txt)")
      ->check(CLI::ExistingFile)
      ->excludes(write)
      ->excludes(check);
  write->excludes(check);
  app.add_flag("--fill-cell-tables", o.fillCellTables,
               "the ray caster fills its cell table anew every frame instead of keeping it (the path the kept table "
               "replaced: both must draw the same frames)");
  CLI11_PARSE(app, argc, argv);
  const fs::path golden = o.write.empty() ? o.check : o.write;
  if (golden.empty() == o.hashes.empty()) {
    std::cerr << "usage: frame_golden --work DIR (--write DIR | --check DIR | --hashes FILE)\n";
    return 2;
  }
  const std::map<std::string, std::string> digests =
      o.hashes.empty() ? std::map<std::string, std::string>{} : readDigests(o.hashes);
  if (!o.hashes.empty() && digests.empty()) {
    std::cerr << "frame_golden: no digests in " << o.hashes << "\n";
    return 2;
  }
  fs::create_directories(o.work);
  if (!golden.empty()) fs::create_directories(golden);
  Stores stores = goldenStores(o.work);
  auto context = render::createContext(render::Backend::Auto);
  std::cout << context->describe() << "\n";
  if (!o.hashes.empty() && !context->software()) {
    // The committed digests are llvmpipe's: a GPU rounds otherwise, so there is nothing to compare (ctest: skipped).
    std::cout << "frame_golden: the digests are a software rasteriser's; this context is a GPU's: not compared\n";
    return kNotCompared;
  }
  Renderers renderers(*context, std::move(stores), o.fillCellTables);
  int failures = 0, frames = 0;
  for (const Case& c : cases()) {
    const Frame f = renderers.render(c);
    ++frames;
    if (!o.hashes.empty())
      failures += !matchesDigest(c, f, digests);
    else if (!o.write.empty())
      writeGolden(golden, c, f);
    else
      failures += !matchesGolden(golden, c, f);
  }
  std::cout << frames << " frames, " << failures << " differ\n";
  return failures == 0 ? 0 : 1;
}
