// Opening a dataset by path, through the driver of the kind that recognises it.
#include "render/engine/Datasets.h"

#include <stdexcept>

#include "brickstore/format/Errors.h"
#include "brickstore/format/InputErrors.h"
#include "render/engine/DatasetDriver.h"
#include "render/volume/BrickStoreDataset.h"

namespace voxbrick::render {

bool isDataset(const std::filesystem::path& path) { return driverOfPath(path) != nullptr; }

std::vector<std::filesystem::path> datasetFiles(const std::filesystem::path& path) {
  if (const DatasetDriver* driver = driverOfPath(path)) return driver->files(path);
  return {path};
}

std::shared_ptr<const Dataset> openDataset(std::string name, const std::filesystem::path& path, size_t cacheBytes,
                                           const store::StoreOpenOptions& options) {
  store::requirePath(path);
  const DatasetDriver* driver = driverOfPath(path);
  if (!driver)
    throw store::InputError(path.string() +
                            ": not a dataset (no store.json, not a .vdb file, not an OME-Zarr, not a mesh store)");
  return driver->open(std::move(name), path, cacheBytes, options);
}

DatasetReport describeDataset(const std::filesystem::path& path, const store::StoreOpenOptions& options) {
  store::requirePath(path);
  const DatasetDriver* driver = driverOfPath(path);
  if (!driver) driver = findDriver(BrickStoreDataset::kKind);
  DatasetReport report = driver->describe(path, options);
  report.json["path"] = path.string();
  report.json["kind"] = std::string(driver->kind());
  return report;
}

}  // namespace voxbrick::render
