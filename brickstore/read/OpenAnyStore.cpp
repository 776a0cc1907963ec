// The one place that tells the store's backings apart by a path's form.
#include "brickstore/read/OpenAnyStore.h"

#include <algorithm>
#include <cctype>
#include <string>

#include "brickstore/format/Errors.h"
#include "brickstore/format/InputErrors.h"
#include "brickstore/read/VdbStore.h"
#include "brickstore/read/ZarrStore.h"
#include "brickstore/zarr/ZarrMeta.h"

namespace voxbrick::store {
namespace fs = std::filesystem;

bool isVdbFile(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  std::error_code ec;
  return ext == ".vdb" && !fs::is_directory(path, ec);
}

std::shared_ptr<const BrickStore> openAnyStore(const fs::path& path, const StoreOpenOptions& options) {
  requirePath(path);
  const bool zarr = isZarrDirectory(path);
  if ((options.time != 0 || options.channel != 0) && !zarr)
    throw InputError(path.string() + ": --time and --channel apply to an OME-Zarr only");
  if (zarr) return ZarrStore::open(path, options);
  if (isVdbFile(path)) return VdbStore::open(path, options);
  if (!options.gridName.empty() || options.brickSize != StoreOpenOptions{}.brickSize)
    throw InputError(
        path.string() +
        ": --grid and --brick apply to a .vdb file only (--brick also to an OME-Zarr; a store directory has its "
        "own brick size)");
  return BrickStore::open(path);
}

}  // namespace voxbrick::store
