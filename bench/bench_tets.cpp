// The tables of Carrard & Juliachs (seed 002) for this machine: a tetrahedral mesh rendered while the view turns
// about it, per image size: the visibility sort's time, the rendering time, the frame's total and the tets drawn
// per second (their Table 2); the same with a null fragment program, and the ratio of the two rendering times
// (Table 3); the bytes a tet costs on the GPU and in the store (their 64 bytes a tet, Table 4's basis).
//
// Protocol as the paper's: --views frames with the eye turning about the mesh (azimuth 0, 360/N, ... at elevation 20),
// the mean of each time over the frames of a pass, after one warm-up pass discarded; --runs passes, their median
// reported. Every run goes through all sizes and both fragment programs in turn, so that a drift of the machine's
// load reaches all alike.
//
//   bench_tets --store MESH.vms [--out bench/results] [--name tets] [--sizes 256,512,768,1024] [--views 10]
//              [--runs 3] [--tf hot] [--visibility mpvo|centroid|raycast]
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "mesh/MeshStore.h"
#include "render/gl/GlContext.h"
#include "render/gl/tets/TetRenderer.h"

namespace fs = std::filesystem;
using namespace voxbrick;

namespace {

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

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

/// The means over one pass of the views.
struct Pass {
  double sortMs = 0, drawMs = 0, totalMs = 0, fragments = 0;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("The seed's projected-tetrahedra tables for this machine");
  std::string storePath, out = "bench/results", name = "tets", sizesText = "256,512,768,1024", tf = "hot",
                         visibility = "mpvo";
  int views = 10, runs = 3;
  app.add_option("--store", storePath, "a mesh store (voxbrick prep MESH -o STORE)")->required();
  app.add_option("--out", out, "output directory");
  app.add_option("--name", name, "output file stem");
  app.add_option("--sizes", sizesText, "square image sizes, comma-separated");
  app.add_option("--views", views, "frames a pass (the eye turning about the mesh)")->check(CLI::Range(1, 1000));
  app.add_option("--runs", runs, "timed passes (after a warm-up pass)")->check(CLI::Range(1, 100));
  app.add_option("--tf", tf, "transfer function preset");
  app.add_option("--visibility", visibility, "mpvo, centroid or raycast")
      ->check(CLI::IsMember({"mpvo", "centroid", "raycast"}));
  CLI11_PARSE(app, argc, argv);
  const std::vector<int> sizes = parseSizes(sizesText);

  const mesh::MeshStore store = mesh::MeshStore::open(storePath);
  auto data = std::make_shared<const render::TetMeshData>(store.readAll(), store.readTopology());
  auto context = render::createContext(render::Backend::Auto);
  const std::string device = context->describe();
  const size_t tets = data->mesh.tets.size();
  render::TetRenderer renderer(*context, data, size_t(8) << 30);
  std::printf("bench_tets on %s: %zu tets, sizes %s, %d views, %d runs\n", device.c_str(), tets, sizesText.c_str(),
              views, runs);

  render::Scene scene;
  scene.transferFunction = render::TransferFunction::load(tf);
  scene.transferFunctionName = tf;
  scene.visibility = render::parseTetSort(visibility, "--visibility");
  auto pass = [&](int size, bool nullFragment) {
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
  };
  // (size, null) -> passes
  std::map<std::pair<int, bool>, std::vector<Pass>> results;
  for (int run = -1; run < runs; ++run) {
    for (int size : sizes)
      for (bool nullFragment : {false, true}) {
        const Pass p = pass(size, nullFragment);
        if (run >= 0) results[{size, nullFragment}].push_back(p);
      }
    if (run >= 0) std::printf("run %d of %d done\n", run + 1, runs);
    std::fflush(stdout);
  }

  auto med = [&](int size, bool nullFragment, double Pass::*field) {
    std::vector<double> v;
    for (const Pass& p : results[{size, nullFragment}]) v.push_back(p.*field);
    return median(v);
  };
  fs::create_directories(out);
  std::ofstream csv(fs::path(out) / (name + ".csv"));
  csv << "# " << device << "; " << tets << " tets, " << views << " views a pass, median of " << runs << " passes\n";
  csv << "size,fragment_program,sort_ms,render_ms,total_ms,tets_per_s,fragments\n";
  for (int size : sizes)
    for (bool nullFragment : {false, true})
      csv << size << "," << (nullFragment ? "null" : "tet") << "," << med(size, nullFragment, &Pass::sortMs) << ","
          << med(size, nullFragment, &Pass::drawMs) << "," << med(size, nullFragment, &Pass::totalMs) << ","
          << double(tets) / (med(size, nullFragment, &Pass::totalMs) / 1000) << ","
          << med(size, nullFragment, &Pass::fragments) << "\n";

  std::ofstream md(fs::path(out) / (name + ".md"));
  md << "Device: " << device << ". " << tets << " tets (`" << storePath << "`), transfer function `" << tf
     << "`, visibility " << visibility << "; " << views << " views a pass (azimuth 0.." << 360 - 360 / views
     << "°, elevation 20°, 2.2 radii), a warm-up pass discarded, the median of " << runs << " passes.\n\n";
  md << "Table 2 (rendering speed against resolution):\n\n| | ";
  for (int size : sizes) md << size << "² | ";
  md << "\n|---|";
  for (size_t i = 0; i < sizes.size(); ++i) md << "---:|";
  auto row = [&](const char* label, auto value) {
    md << "\n| " << label << " | ";
    for (int size : sizes) {
      char cell[64];
      std::snprintf(cell, sizeof cell, "%s", value(size).c_str());
      md << cell << " | ";
    }
  };
  auto fmt = [](const char* f, double v) {
    char b[64];
    std::snprintf(b, sizeof b, f, v);
    return std::string(b);
  };
  row("t sorting (ms)", [&](int s) { return fmt("%.0f", med(s, false, &Pass::sortMs)); });
  row("t rendering (ms)", [&](int s) { return fmt("%.0f", med(s, false, &Pass::drawMs)); });
  row("t frame (ms)", [&](int s) { return fmt("%.0f", med(s, false, &Pass::totalMs)); });
  row("tets/s (10⁶)", [&](int s) { return fmt("%.2f", double(tets) / med(s, false, &Pass::totalMs) / 1000); });
  row("fragments (10⁶)", [&](int s) { return fmt("%.1f", med(s, false, &Pass::fragments) / 1e6); });
  md << "\n\nTable 3 (a null fragment program: no ray-tet intersection, no classification, a constant colour):\n\n| | ";
  for (int size : sizes) md << size << "² | ";
  md << "\n|---|";
  for (size_t i = 0; i < sizes.size(); ++i) md << "---:|";
  row("t rendering (ms)", [&](int s) { return fmt("%.0f", med(s, true, &Pass::drawMs)); });
  row("tets/s rendered (10⁶)", [&](int s) { return fmt("%.2f", double(tets) / med(s, true, &Pass::drawMs) / 1000); });
  row("rendering time ratio", [&](int s) { return fmt("%.1f", med(s, false, &Pass::drawMs) / med(s, true, &Pass::drawMs)); });
  const mesh::MeshStoreInfo& info = store.info();
  md << "\n\nBytes a tet: 64 on the GPU (four vertices, position and scalar, read by vertex pulling: the seed's point "
        "sprite) + 4 of visibility order uploaded each frame; "
     << fmt("%.1f", double(info.bytesStored) / double(info.tetCount)) << " in the store (zstd, "
     << fmt("%.1f", double(info.bytesRaw) / double(info.tetCount)) << " raw with the adjacency).\n";
  std::printf("wrote %s.{csv,md} in %s\n", name.c_str(), out.c_str());
  return 0;
}
