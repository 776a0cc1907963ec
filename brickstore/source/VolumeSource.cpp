// What every reader checks of the slices a header declares before it allocates one.
#include "brickstore/source/VolumeSource.h"

#include <cmath>
#include <cstdio>

#include "brickstore/format/Errors.h"

namespace voxbrick::store {

void checkSliceFitsMemory(int64_t nx, int64_t ny, size_t valueBytes, const SourceOptions& options,
                          const std::string& file, const std::string& field) {
  if (options.memoryBudgetMB <= 0) return;
  constexpr double kProcessMB = 112;  // an idle voxbrick, as StoreWriter's memory plan counts it
  const double sliceMB = double(nx) * double(ny) * double(valueBytes) / double(1 << 20);
  if (2 * sliceMB + kProcessMB <= double(options.memoryBudgetMB)) return;
  char text[160];
  std::snprintf(text, sizeof text, " declares slices of %lldx%lld voxels of %zu bytes (%.0f MB each): --memory %lld MB",
                static_cast<long long>(nx), static_cast<long long>(ny), valueBytes, sliceMB,
                static_cast<long long>(options.memoryBudgetMB));
  throw InputError(file + ": " + field + text + " is too small (it needs at least " +
                   std::to_string(static_cast<long long>(std::ceil(2 * sliceMB + kProcessMB))) + " MB)");
}

}  // namespace voxbrick::store
