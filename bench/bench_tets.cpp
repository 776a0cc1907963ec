// The tables of Carrard & Juliachs' projected tetrahedra for this machine: a tetrahedral mesh rendered while the view turns
// about it, per image size: the visibility sort's time, the rendering time, the frame's total and the tets drawn
// per second (their Table 2); the same with a null fragment program, and the ratio of the two rendering times
// (Table 3); the bytes a tet costs on the GPU and in the store (their 64 bytes a tet, Table 4's basis).
//
// Protocol as the paper's: --views frames with the eye turning about the mesh (azimuth 0, 360/N, ... at elevation 20),
// the mean of each time over the frames of a pass, after one warm-up pass discarded; --runs passes, their median
// reported. Every run goes through all sizes and both fragment programs in turn, so that a drift of the machine's
// load reaches all alike.
//
//   bench_tets --store MESH.vms [--out bench/results/tets] [--name tets] [--sizes 256,512,768,1024] [--views 10]
//              [--runs 3] [--tf hot] [--visibility mpvo|centroid|raycast]
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "mesh/MeshStore.h"
#include "quality/Statistics.h"
#include "render/gl/GlContext.h"
#include "render/gl/tets/TetRenderer.h"

namespace fs = std::filesystem;
using namespace voxbrick;

namespace {

struct Options {
  std::string storePath, out = "bench/results/tets", name = "tets", sizes = "256,512,768,1024", tf = "hot",
                         visibility = "mpvo";
  int views = 10, runs = 3;
};

std::vector<int> parseSizes(const std::string& text) {
  std::vector<int> out;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = std::min(text.find(',', start), text.size());
    if (comma > start) out.push_back(std::stoi(text.substr(start, comma - start)));
    start = comma + 1;
  }
  return out;
}

/// The means over one pass of the views.
struct Pass {
  double sortMs = 0, drawMs = 0, totalMs = 0, fragments = 0;
};

/// The passes of each (size, null fragment program), and their medians.
struct Passes {
  std::map<std::pair<int, bool>, std::vector<Pass>> runs;

  double median(int size, bool nullFragment, double Pass::*field) const {
    std::vector<double> v;
    for (const Pass& p : runs.at({size, nullFragment})) v.push_back(p.*field);
    return quality::median(v);
  }
};

void addOptions(CLI::App& app, Options& o) {
  app.add_option("--store", o.storePath, "a mesh store (voxbrick prep MESH -o STORE)")->required();
  app.add_option("--out", o.out, "output directory");
  app.add_option("--name", o.name, "output file stem");
  app.add_option("--sizes", o.sizes, "square image sizes, comma-separated");
  app.add_option("--views", o.views, "frames a pass (the eye turning about the mesh)")->check(CLI::Range(1, 1000));
  app.add_option("--runs", o.runs, "timed passes (after a warm-up pass)")->check(CLI::Range(1, 100));
  app.add_option("--tf", o.tf, "transfer function preset");
  app.add_option("--visibility", o.visibility, "mpvo, centroid or raycast")
      ->check(CLI::IsMember({"mpvo", "centroid", "raycast"}));
}

/// One pass of the views at `size`, with the tet or the null fragment program.
Pass timePass(render::TetRenderer& renderer, render::Scene& scene, int size, bool nullFragment, int views) {
  scene.width = scene.height = size;
  Pass p;
  for (int v = 0; v < views; ++v) {
    scene.camera.azimuth = 360.0 * v / views;
    scene.camera.elevation = 20;
    scene.camera.distance = 2.2;
    render::FrameStats stats;
    renderer.render(scene, &stats, {nullFragment ? render::RenderMode::Roofline : render::RenderMode::Normal});
    p.sortMs += stats.msSorting / views;
    p.drawMs += (stats.msDrawing + stats.msReadback) / views;
    p.totalMs += stats.msTotal / views;
    p.fragments += double(stats.fragments) / views;
  }
  return p;
}

/// Every run goes through all sizes and both fragment programs in turn; run -1 is the warm-up pass, discarded.
Passes timeRuns(render::TetRenderer& renderer, render::Scene& scene, const std::vector<int>& sizes, const Options& o) {
  Passes passes;
  for (int run = -1; run < o.runs; ++run) {
    for (int size : sizes)
      for (bool nullFragment : {false, true}) {
        const Pass p = timePass(renderer, scene, size, nullFragment, o.views);
        if (run >= 0) passes.runs[{size, nullFragment}].push_back(p);
      }
    if (run >= 0) std::printf("run %d of %d done\n", run + 1, o.runs);
    std::fflush(stdout);
  }
  return passes;
}

void writeCsv(const fs::path& path, const std::string& device, size_t tets, const std::vector<int>& sizes,
              const Passes& p, const Options& o) {
  std::ofstream csv(path);
  csv << "# " << device << "; " << tets << " tets, " << o.views << " views a pass, median of " << o.runs << " passes\n";
  csv << "size,fragment_program,sort_ms,render_ms,total_ms,tets_per_s,fragments\n";
  for (int size : sizes)
    for (bool nullFragment : {false, true})
      csv << size << "," << (nullFragment ? "null" : "tet") << "," << p.median(size, nullFragment, &Pass::sortMs) << ","
          << p.median(size, nullFragment, &Pass::drawMs) << "," << p.median(size, nullFragment, &Pass::totalMs) << ","
          << double(tets) / (p.median(size, nullFragment, &Pass::totalMs) / 1000) << ","
          << p.median(size, nullFragment, &Pass::fragments) << "\n";
}

std::string fmt(const char* f, double v) {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return std::string(b);
}

/// A markdown table: a column per size, a row per `rows` entry (a label and its value at a size).
void writeTable(std::ofstream& md, const std::vector<int>& sizes,
                const std::vector<std::pair<const char*, std::function<std::string(int)>>>& rows) {
  md << "| | ";
  for (int size : sizes) md << size << "² | ";
  md << "\n|---|";
  for (size_t i = 0; i < sizes.size(); ++i) md << "---:|";
  for (const auto& [label, value] : rows) {
    md << "\n| " << label << " | ";
    for (int size : sizes) {
      char cell[64];
      std::snprintf(cell, sizeof cell, "%s", value(size).c_str());
      md << cell << " | ";
    }
  }
}

void writeMarkdown(const fs::path& path, const std::string& device, size_t tets, const mesh::MeshStoreInfo& info,
                   const std::vector<int>& sizes, const Passes& p, const Options& o) {
  std::ofstream md(path);
  md << "Device: " << device << ". " << tets << " tets (`" << o.storePath << "`), transfer function `" << o.tf
     << "`, visibility " << o.visibility << "; " << o.views << " views a pass (azimuth 0.." << 360 - 360 / o.views
     << "°, elevation 20°, 2.2 radii), a warm-up pass discarded, the median of " << o.runs << " passes.\n\n";
  md << "Table 2 (rendering speed against resolution):\n\n";
  const double n = double(tets);
  writeTable(md, sizes,
             {{"t sorting (ms)", [&](int s) { return fmt("%.0f", p.median(s, false, &Pass::sortMs)); }},
              {"t rendering (ms)", [&](int s) { return fmt("%.0f", p.median(s, false, &Pass::drawMs)); }},
              {"t frame (ms)", [&](int s) { return fmt("%.0f", p.median(s, false, &Pass::totalMs)); }},
              {"tets/s (10⁶)", [&](int s) { return fmt("%.2f", n / p.median(s, false, &Pass::totalMs) / 1000); }},
              {"fragments (10⁶)", [&](int s) { return fmt("%.1f", p.median(s, false, &Pass::fragments) / 1e6); }}});
  md << "\n\nTable 3 (a null fragment program: no ray-tet intersection, no classification, a constant colour):\n\n";
  writeTable(
      md, sizes,
      {{"t rendering (ms)", [&](int s) { return fmt("%.0f", p.median(s, true, &Pass::drawMs)); }},
       {"tets/s rendered (10⁶)", [&](int s) { return fmt("%.2f", n / p.median(s, true, &Pass::drawMs) / 1000); }},
       {"rendering time ratio",
        [&](int s) { return fmt("%.1f", p.median(s, false, &Pass::drawMs) / p.median(s, true, &Pass::drawMs)); }}});
  md << "\n\nBytes a tet: 64 on the GPU (four vertices, position and scalar, read by vertex pulling: the paper's point "
        "sprite) + 4 of visibility order uploaded each frame; "
     << fmt("%.1f", double(info.bytesStored) / double(info.tetCount)) << " in the store (zstd, "
     << fmt("%.1f", double(info.bytesRaw) / double(info.tetCount)) << " raw with the adjacency).\n";
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app("Carrard & Juliachs' projected-tetrahedra tables for this machine");
  addOptions(app, o);
  CLI11_PARSE(app, argc, argv);
  const std::vector<int> sizes = parseSizes(o.sizes);

  const mesh::MeshStore store = mesh::MeshStore::open(o.storePath);
  auto data = std::make_shared<const render::TetMeshData>(store.readAll(), store.readTopology());
  auto context = render::createContext(render::Backend::Auto);
  const std::string device = context->describe();
  const size_t tets = data->mesh.tets.size();
  render::TetRenderer renderer(*context, data, size_t(8) << 30);
  std::printf("bench_tets on %s: %zu tets, sizes %s, %d views, %d runs\n", device.c_str(), tets, o.sizes.c_str(),
              o.views, o.runs);

  render::Scene scene;
  scene.transferFunction = render::TransferFunction::load(o.tf);
  scene.transferFunctionName = o.tf;
  scene.visibility = render::parseTetSort(o.visibility, "--visibility");
  const Passes passes = timeRuns(renderer, scene, sizes, o);
  fs::create_directories(o.out);
  writeCsv(fs::path(o.out) / (o.name + ".csv"), device, tets, sizes, passes, o);
  writeMarkdown(fs::path(o.out) / (o.name + ".md"), device, tets, store.info(), sizes, passes, o);
  std::printf("wrote %s.{csv,md} in %s\n", o.name.c_str(), o.out.c_str());
  return 0;
}
