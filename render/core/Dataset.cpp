// The dataset base: the quality table, resolving a quality target.
#include "render/core/Dataset.h"

#include <stdexcept>

#include <nlohmann/json.hpp>

#include "render/core/RenderErrors.h"

namespace voxbrick::render {

std::optional<QualityTable> Dataset::qualityTable() const {
  const std::filesystem::path file = QualityTable::pathFor(mPath);
  std::error_code error;
  const auto time = std::filesystem::last_write_time(file, error);
  std::lock_guard lock(mQualityMutex);
  if (error) {
    mQuality.reset();
    return std::nullopt;
  }
  if (!mQuality || time != mQualityTime) {
    mQuality = QualityTable::load(mPath);
    mQualityTime = time;
  }
  return mQuality;
}

Scene resolveQuality(const Dataset& dataset, const Scene& scene, std::optional<QualityChoice>* choice) {
  if (choice) choice->reset();
  if (!scene.quality) return scene;
  const std::optional<QualityTable> table = dataset.qualityTable();
  if (!table)
    throw RenderInputError("quality " + scene.quality->text() + ": dataset '" + dataset.name() +
                           "' has no quality table (" + QualityTable::pathFor(dataset.path()).string() +
                           "); measure one with `voxbrick bench --calibrate " + dataset.path().string() + "`");
  const QualityChoice chosen = table->choose(*scene.quality, scene);
  Scene resolved = scene;
  chosen.setting.applyTo(resolved);
  resolved.validate();
  if (choice) *choice = chosen;
  return resolved;
}

}  // namespace voxbrick::render
