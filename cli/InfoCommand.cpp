// `voxbrick info STORE [--json]`: what a store (or a .vdb read live) holds, level by level.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include <nlohmann/json.hpp>

#include "brickstore/format/InputErrors.h"
#include "brickstore/format/Orientation.h"
#include "brickstore/read/BrickStore.h"
#include "brickstore/read/OpenAnyStore.h"
#include "brickstore/read/VdbStore.h"
#include "brickstore/read/ZarrStore.h"
#include "cli/Commands.h"
#include "common/EnumNames.h"
#include "mesh/MeshStore.h"

namespace voxbrick::cli {
namespace {

struct InfoArgs {
  std::string store, grid;
  int brick = 32;
  int64_t time = 0, channel = 0;
  bool json = false;
};

/// The 256-bin histogram as a 32-character line, log-scaled so that a large background peak does not flatten it.
std::string sparkline(const store::Histogram& h) {
  static const char* kBars[] = {" ", "▁", "▂", "▃", "▄", "▅", "▆", "▇", "█"};
  constexpr size_t kColumns = 32;
  if (h.counts.empty()) return "";
  std::vector<double> cols(kColumns, 0);
  for (size_t b = 0; b < h.counts.size(); ++b) cols[b * kColumns / h.counts.size()] += double(h.counts[b]);
  double top = 0;
  for (double& c : cols) top = std::max(top, c = std::log1p(c));
  std::string line;
  for (double c : cols) line += kBars[top > 0 ? static_cast<int>(std::lround(c / top * 8)) : 0];
  return line;
}

/// `info` of a mesh store: what its index says, and with --json the same as JSON.
void runMeshInfo(const InfoArgs& a) {
  const mesh::MeshStore s = mesh::MeshStore::open(a.store);
  if (!a.json) {
    std::printf("%s", mesh::describeMeshStore(s).c_str());
    return;
  }
  const mesh::MeshStoreInfo& i = s.info();
  const nlohmann::json j = {
      {"path", a.store},
      {"kind", "tet-mesh"},
      {"source", i.source},
      {"field", i.field},
      {"points", i.vertexCount},
      {"tets", i.tetCount},
      {"boundary_faces", i.boundaryFaceCount},
      {"chunks", i.chunkCount},
      {"tets_per_chunk", i.tetsPerChunk},
      {"bounds", {{i.boundsMin.x, i.boundsMin.y, i.boundsMin.z}, {i.boundsMax.x, i.boundsMax.y, i.boundsMax.z}}},
      {"value_range", {i.scalarMin, i.scalarMax}},
      {"bytes_raw", i.bytesRaw},
      {"bytes_stored", i.bytesStored}};
  std::printf("%s\n", j.dump(2).c_str());
}

/// What every view of a brick store reports beside its metadata.
struct StoreSummary {
  double emptyFraction = 0;  ///< level 0's bricks that hold only the background
  double ratio = 0;          ///< raw bytes over stored bytes
};

StoreSummary summarise(const store::StoreMeta& m) {
  StoreSummary r;
  if (m.levels[0].bricksTotal() > 0)
    r.emptyFraction = 1.0 - double(m.levels[0].bricksStored) / double(m.levels[0].bricksTotal());
  r.ratio = m.bytesStored > 0 ? double(m.bytesRaw) / double(m.bytesStored) : 0.0;
  return r;
}

/// `info --json` of a brick store: its store.json with the summary, orientation and a live .vdb's open statistics.
void printStoreJson(const InfoArgs& a, const store::BrickStore& s, const store::VdbStore* live) {
  const store::StoreMeta& m = s.meta();
  const StoreSummary summary = summarise(m);
  nlohmann::json j = nlohmann::json::parse(m.toJson());
  j["path"] = a.store;
  j["empty_fraction"] = summary.emptyFraction;
  j["compression_ratio"] = summary.ratio;
  j["octree_depth"] = s.octree().depth();
  j["backing"] = common::nameOf(s.backing());
  // Always present here (store.json omits the identity): the axes as letters too.
  j["orientation"] = {{"space", "RAS"},
                      {"axes", m.orientation.axes},
                      {"origin", m.orientation.origin},
                      {"patient", m.orientation.patient},
                      {"letters", store::axesLetters(m.orientation)}};
  if (live) {
    const store::VdbOpenStats& o = live->openStats();
    j["open"] = {{"read_s", o.readSeconds},
                 {"scan_s", o.scanSeconds},
                 {"leaf_nodes", o.leafNodes},
                 {"tiles", o.tiles},
                 {"bricks_scanned", o.bricksScanned}};
  }
  std::printf("%s\n", j.dump(2).c_str());
}

/// The first lines of `info` about a brick store: where it came from, dims, orientation, values, histogram.
void printStoreHeader(const InfoArgs& a, const store::StoreMeta& m, const char* live) {
  std::printf("store        %s%s\n", a.store.c_str(), live);
  std::printf("source       %s\n", m.source.c_str());
  std::printf("dims         %s voxels, spacing %g x %g x %g, type %s\n", dimsText(m.dims).c_str(), m.spacing.x,
              m.spacing.y, m.spacing.z, std::string(store::valueTypeName(m.type)).c_str());
  std::printf("orientation  %s\n", m.orientation == store::Orientation{}
                                       ? "none stated (the box is centred on the origin)"
                                       : store::orientationText(m.orientation).c_str());
  std::printf("values       [%g, %g], background %g, %lld active voxels (%.1f%%)\n", m.valueMin, m.valueMax,
              m.background, static_cast<long long>(m.activeVoxels),
              100.0 * double(m.activeVoxels) / double(m.dims.volume()));
  if (m.quantisation)
    std::printf("quantised    from [%.9g, %.9g], a step of %.3g (%lld input voxels outside it clamped)\n",
                m.quantisation->lo, m.quantisation->hi,
                (m.quantisation->hi - m.quantisation->lo) / m.quantisation->steps(),
                static_cast<long long>(m.quantisationClamped));
  if (m.nonFiniteReplaced > 0)
    std::printf("non-finite   %lld NaN/Inf voxels replaced by the background at ingest\n",
                static_cast<long long>(m.nonFiniteReplaced));
  std::printf("histogram    |%s|  (log counts, 256 bins over the value range)\n", sparkline(m.histogram).c_str());
}

/// The levels of a brick store (and, for a live .vdb, what opening it took), after its header.
void printStoreLevels(const store::BrickStore& s, const store::VdbStore* live, bool zarr = false) {
  const store::StoreMeta& m = s.meta();
  const StoreSummary summary = summarise(m);
  std::printf("bricks       %d^3 + 1-voxel border, %zu levels, octree depth %d\n", m.brickSize, m.levels.size(),
              s.octree().depth());
  std::printf("  level  %-16s %-12s %10s %10s %8s %12s\n", "dims", "bricks", "total", "stored", "empty", "bytes");
  for (size_t l = 0; l < m.levels.size(); ++l) {
    const auto& lv = m.levels[l];
    std::printf("  %5zu  %-16s %-12s %10lld %10lld %7.1f%% %12s\n", l, dimsText(lv.dims).c_str(),
                dimsText(lv.bricks).c_str(), static_cast<long long>(lv.bricksTotal()),
                static_cast<long long>(lv.bricksStored),
                100.0 * (1.0 - double(lv.bricksStored) / double(lv.bricksTotal())),
                formatBytes(double(lv.bytesStored)).c_str());
  }
  if (live) {
    const store::VdbOpenStats& o = live->openStats();
    std::printf(
        "empty        %.1f%% of level-0 bricks hold only the background; levels >= 1 count the bricks over "
        "data (from the topology)\n",
        100 * summary.emptyFraction);
    std::printf("size         %s raw, %s OpenVDB file, nothing stored: bricks are extracted from the tree on demand\n",
                formatBytes(double(m.bytesRaw)).c_str(), formatBytes(double(m.bytesVdb)).c_str());
    std::printf(
        "open         %.3f s reading the file, %.3f s scanning the tree (%lld leaf nodes, %lld tiles, %lld of "
        "%lld level-0 bricks extracted)\n",
        o.readSeconds, o.scanSeconds, (long long)o.leafNodes, (long long)o.tiles, (long long)o.bricksScanned,
        (long long)m.levels[0].bricksTotal());
    return;
  }
  std::printf("empty        %.1f%% of level-0 bricks are empty (not stored)\n", 100 * summary.emptyFraction);
  if (zarr) return;
  std::printf("size         %s raw, %s stored (all levels, %.2fx), %s OpenVDB grid in %zu file(s)\n",
              formatBytes(double(m.bytesRaw)).c_str(), formatBytes(double(m.bytesStored)).c_str(), summary.ratio,
              formatBytes(double(m.bytesVdb)).c_str(), m.vdbFiles.size());
}

/// What opening an OME-Zarr live found: its chunks, which levels are its own, what the pass over them cost.
void printZarrOpen(const store::ZarrStore& z) {
  const store::ZarrOpenStats& o = z.openStats();
  std::printf(
      "live         OME-Zarr read live: %lld of %lld level-0 chunk files present; store levels 0-%d are its own "
      "datasets%s\n",
      (long long)o.chunksPresent, (long long)o.chunksTotal, o.ownLevels - 1,
      o.ownLevels < z.levelCount() ? ", the coarser averaged from the level below" : "");
  std::printf("open         %.3f s (%lld bricks read for their ranges, %lld chunk decodes)\n", o.scanSeconds,
              (long long)o.bricksScanned, (long long)o.chunksDecoded);
}

void runInfo(const InfoArgs& a) {
  if (mesh::looksLikeMeshStore(a.store)) return runMeshInfo(a);
  auto s = store::openAnyStore(a.store, {a.grid, a.brick, a.time, a.channel});
  const auto* live = dynamic_cast<const store::VdbStore*>(s.get());
  if (a.json) return printStoreJson(a, *s, live);
  const auto* zarr = dynamic_cast<const store::ZarrStore*>(s.get());
  printStoreHeader(a, s->meta(), live ? " (OpenVDB file, read live)" : zarr ? " (OME-Zarr, read live)" : "");
  printStoreLevels(*s, live, zarr != nullptr);
  if (zarr) printZarrOpen(*zarr);
}

}  // namespace

void addInfoCommand(CLI::App& app) {
  auto args = std::make_shared<InfoArgs>();
  CLI::App* cmd = app.add_subcommand("info", "Describe a brick store (or a .vdb, as it would be read live)");
  cmd->add_option("dataset", args->store, "store directory, a .vdb file or an OME-Zarr directory")->required();
  cmd->add_option("--grid", args->grid, ".vdb: the float grid to read (default: the first float grid)");
  cmd->add_option("--brick", args->brick, ".vdb: brick size B, a power of two in [8, 256]")
      ->capture_default_str()
      ->check(between(8, 256, "voxels"));
  addZarrIndexOptions(cmd, args->time, args->channel);
  cmd->add_flag("--json", args->json, "print one JSON object");
  cmd->callback([args] { store::namingInput({args->store}, [&] { runInfo(*args); }); });
}

}  // namespace voxbrick::cli
