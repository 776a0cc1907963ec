// The quality table (render/core/Quality.h) behind `render --quality`: a sweep's measurements on one store, as its
// quality.json.
#pragma once

#include <filesystem>

#include "quality/SweepResult.h"
#include "render/core/Quality.h"

namespace voxbrick::quality {

/// The quality table (render/core/Quality.h) of the points measured on `store` (a path, as datasetStorePath gives it):
/// every point of a dataset kept there with bricks of 32 (the store's), skipping and the vertex slicer, one entry per
/// transfer function, shading and setting. `device` names the GL renderer.
render::QualityTable qualityTable(const SweepResult& result, const std::filesystem::path& work,
                                  const std::filesystem::path& store);

/// Writes the quality table of the points measured on `store` beside it (render::QualityTable::save) and returns
/// it; writes nothing and returns an empty table if no point was measured there.
render::QualityTable saveQualityTable(const SweepResult& result, const std::filesystem::path& work,
                                      const std::filesystem::path& store);

}  // namespace voxbrick::quality
