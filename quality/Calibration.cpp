// A sweep's points on one store as its quality table.
#include "quality/Calibration.h"

#include <algorithm>

namespace voxbrick::quality {
namespace fs = std::filesystem;

render::QualityTable qualityTable(const SweepResult& result, const fs::path& work, const fs::path& store) {
  render::QualityTable table;
  table.device = result.device;
  table.width = table.height = result.spec.size;
  table.views = result.spec.views;
  for (const Point& p : result.points) {
    const auto d = std::find_if(result.spec.datasets.begin(), result.spec.datasets.end(),
                                [&](const Dataset& x) { return x.name == p.dataset; });
    const Setting& s = p.setting;
    if (d == result.spec.datasets.end() || datasetStorePath(*d, 32, work) != store || s.brick != 32 || !s.skip ||
        s.slicer != render::Slicer::Vertex)
      continue;
    render::QualityEntry e;
    e.transferFunction = p.variant.transferFunction;
    e.shading = p.variant.shading;
    e.setting = {s.step, s.raycast, s.slab, s.ert, s.preIntegration, s.subBlock, s.lod};
    e.msMedian = p.msMedian;
    // An image equal to the reference has an infinite PSNR, which JSON cannot hold: 999 dB stands for it.
    e.psnrMin = std::min(p.psnrMin, 999.0);
    table.entries.push_back(e);
  }
  return table;
}

render::QualityTable saveQualityTable(const SweepResult& result, const fs::path& work, const fs::path& store) {
  render::QualityTable table = qualityTable(result, work, store);
  if (!table.entries.empty()) table.save(store);
  return table;
}

}  // namespace voxbrick::quality
