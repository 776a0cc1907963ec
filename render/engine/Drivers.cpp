// The registry of dataset kinds: the built-in ones, one line each, and those registered at run time.
#include <algorithm>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "render/core/RenderErrors.h"
#include "render/engine/BuiltInDrivers.h"
#include "render/engine/DatasetDriver.h"

namespace voxbrick::render {
namespace {

struct Registry {
  std::mutex mutex;
  std::vector<std::shared_ptr<const DatasetDriver>> drivers;
};

Registry& registry() {
  static Registry r{{}, {
                            gridDriver(),
                            meshDriver(),
                        }};
  return r;
}

}  // namespace

void DatasetDriver::prefetch(const Dataset&, const Scene&, const FrameRenderer*) const {}

void DatasetDriver::checkSubBlock(const Dataset&, int) const {}

DatasetReport DatasetDriver::describe(const std::filesystem::path& path, const store::StoreOpenOptions&) const {
  return {path.string() + ": a dataset of kind " + std::string(kind()) + "\n", nlohmann::json::object()};
}

PixelRect SortLastParts::footprint(int, const Scene&, int width, int height, const FrameStats*) const {
  return {0, 0, std::max(width, 0), std::max(height, 0)};
}

std::shared_ptr<const SortLastParts> DatasetDriver::partition(const Dataset& dataset, int) const {
  throw RenderInputError("the distributed mode cannot split '" + dataset.name() + "', a " + std::string(kind()) +
                         ", into parts");
}

const DatasetDriver* findDriver(std::string_view kind) {
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  for (const auto& driver : r.drivers)
    if (driver->kind() == kind) return driver.get();
  return nullptr;
}

const DatasetDriver& driverFor(const Dataset& dataset) {
  if (const DatasetDriver* driver = findDriver(dataset.kind())) return *driver;
  throw RenderInputError("no driver draws datasets of kind '" + std::string(dataset.kind()) + "' ('" +
                         dataset.name() + "')");
}

const DatasetDriver* driverOfPath(const std::filesystem::path& path) {
  Registry& r = registry();
  std::vector<std::shared_ptr<const DatasetDriver>> drivers;
  {
    std::lock_guard lock(r.mutex);
    drivers = r.drivers;
  }
  for (const auto& driver : drivers)
    if (driver->recognises(path)) return driver.get();
  return nullptr;
}

void registerDriver(std::shared_ptr<const DatasetDriver> driver) {
  if (!driver) throw std::invalid_argument("registerDriver: no driver");
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  for (const auto& other : r.drivers)
    if (other->kind() == driver->kind())
      throw std::invalid_argument("registerDriver: kind '" + std::string(driver->kind()) + "' is registered already");
  r.drivers.push_back(std::move(driver));
}

}  // namespace voxbrick::render
