// `voxbrick info` of a brick store (a prepped directory, a .vdb or an OME-Zarr read live): where it came from, its
// values, its levels, and for a live backing what opening it took.
#include <algorithm>
#include <cmath>
#include <vector>

#include <nlohmann/json.hpp>

#include "brickstore/format/Orientation.h"
#include "brickstore/read/BrickStore.h"
#include "brickstore/read/OpenAnyStore.h"
#include "brickstore/read/VdbStore.h"
#include "brickstore/read/ZarrStore.h"
#include "common/EnumNames.h"
#include "common/Units.h"
#include "render/engine/BuiltInDrivers.h"

namespace voxbrick::render {
namespace {

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

/// The JSON of a brick store: its store.json with the summary, orientation and a live .vdb's open statistics.
nlohmann::json storeJson(const store::BrickStore& s, const store::VdbStore* live) {
  const store::StoreMeta& m = s.meta();
  const StoreSummary summary = summarise(m);
  nlohmann::json j = nlohmann::json::parse(m.toJson());
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
  return j;
}

/// The first lines of `info` about a brick store: where it came from, dims, orientation, values, histogram.
std::string storeHeader(const std::string& path, const store::StoreMeta& m, const char* live) {
  std::string text;
  text += printed("store        %s%s\n", path.c_str(), live);
  text += printed("source       %s\n", m.source.c_str());
  text += printed("dims         %s voxels, spacing %g x %g x %g, type %s\n", store::dimsText(m.dims).c_str(), m.spacing.x,
              m.spacing.y, m.spacing.z, std::string(store::valueTypeName(m.type)).c_str());
  text += printed("orientation  %s\n", m.orientation == store::Orientation{}
                                       ? "none stated (the box is centred on the origin)"
                                       : store::orientationText(m.orientation).c_str());
  text += printed("values       [%g, %g], background %g, %lld active voxels (%.1f%%)\n", m.valueMin, m.valueMax,
              m.background, static_cast<long long>(m.activeVoxels),
              100.0 * double(m.activeVoxels) / double(m.dims.volume()));
  if (m.quantisation)
    text += printed("quantised    from [%.9g, %.9g], a step of %.3g (%lld input voxels outside it clamped)\n",
                m.quantisation->lo, m.quantisation->hi,
                (m.quantisation->hi - m.quantisation->lo) / m.quantisation->steps(),
                static_cast<long long>(m.quantisationClamped));
  if (m.nonFiniteReplaced > 0)
    text += printed("non-finite   %lld NaN/Inf voxels replaced by the background at ingest\n",
                static_cast<long long>(m.nonFiniteReplaced));
  text += printed("histogram    |%s|  (log counts, 256 bins over the value range)\n", sparkline(m.histogram).c_str());
  return text;
}

/// The levels of a brick store (and, for a live .vdb, what opening it took), after its header.
std::string storeLevels(const store::BrickStore& s, const store::VdbStore* live, bool zarr) {
  std::string text;
  const store::StoreMeta& m = s.meta();
  const StoreSummary summary = summarise(m);
  text += printed("bricks       %d^3 + 1-voxel border, %zu levels, octree depth %d\n", m.brickSize, m.levels.size(),
              s.octree().depth());
  text += printed("  level  %-16s %-12s %10s %10s %8s %12s\n", "dims", "bricks", "total", "stored", "empty", "bytes");
  for (size_t l = 0; l < m.levels.size(); ++l) {
    const auto& lv = m.levels[l];
    text += printed("  %5zu  %-16s %-12s %10lld %10lld %7.1f%% %12s\n", l, store::dimsText(lv.dims).c_str(),
                store::dimsText(lv.bricks).c_str(), static_cast<long long>(lv.bricksTotal()),
                static_cast<long long>(lv.bricksStored),
                100.0 * (1.0 - double(lv.bricksStored) / double(lv.bricksTotal())),
                common::formatBytes(double(lv.bytesStored)).c_str());
  }
  if (live) {
    const store::VdbOpenStats& o = live->openStats();
    text += printed(
        "empty        %.1f%% of level-0 bricks hold only the background; levels >= 1 count the bricks over "
        "data (from the topology)\n",
        100 * summary.emptyFraction);
    text += printed("size         %s raw, %s OpenVDB file, nothing stored: bricks are extracted from the tree on demand\n",
                common::formatBytes(double(m.bytesRaw)).c_str(), common::formatBytes(double(m.bytesVdb)).c_str());
    text += printed(
        "open         %.3f s reading the file, %.3f s scanning the tree (%lld leaf nodes, %lld tiles, %lld of "
        "%lld level-0 bricks extracted)\n",
        o.readSeconds, o.scanSeconds, (long long)o.leafNodes, (long long)o.tiles, (long long)o.bricksScanned,
        (long long)m.levels[0].bricksTotal());
    return text;
  }
  text += printed("empty        %.1f%% of level-0 bricks are empty (not stored)\n", 100 * summary.emptyFraction);
  if (zarr) return text;
  text += printed("size         %s raw, %s stored (all levels, %.2fx), %s OpenVDB grid in %zu file(s)\n",
              common::formatBytes(double(m.bytesRaw)).c_str(), common::formatBytes(double(m.bytesStored)).c_str(), summary.ratio,
              common::formatBytes(double(m.bytesVdb)).c_str(), m.vdbFiles.size());
  return text;
}

/// What opening an OME-Zarr live found: its chunks, which levels are its own, what the pass over them cost.
std::string zarrOpen(const store::ZarrStore& z) {
  std::string text;
  const store::ZarrOpenStats& o = z.openStats();
  text += printed(
      "live         OME-Zarr read live: %lld of %lld level-0 chunk files present; store levels 0-%d are its own "
      "datasets%s\n",
      (long long)o.chunksPresent, (long long)o.chunksTotal, o.ownLevels - 1,
      o.ownLevels < z.levelCount() ? ", the coarser averaged from the level below" : "");
  text += printed("open         %.3f s (%lld bricks read for their ranges, %lld chunk decodes)\n", o.scanSeconds,
              (long long)o.bricksScanned, (long long)o.chunksDecoded);
  return text;
}

}  // namespace

DatasetReport describeGrid(const std::filesystem::path& path, const store::StoreOpenOptions& options) {
  const auto s = store::openAnyStore(path, options);
  // The backings differ in what opening them did (a live one cut no bricks before; a .vdb scanned its tree).
  const auto* live = dynamic_cast<const store::VdbStore*>(s.get());
  const auto* zarr = dynamic_cast<const store::ZarrStore*>(s.get());
  DatasetReport report;
  report.json = storeJson(*s, live);
  report.text = storeHeader(path.string(), s->meta(),
                            live ? " (OpenVDB file, read live)" : zarr ? " (OME-Zarr, read live)" : "") +
                storeLevels(*s, live, zarr != nullptr) + (zarr ? zarrOpen(*zarr) : std::string());
  return report;
}

}  // namespace voxbrick::render
