// VdbStore::open: the OpenVDB module's store (brickstore/modules/openvdb), the module loaded on first use.
#include "brickstore/read/VdbStore.h"

#include "common/Modules.h"

VOXBRICK_MODULE_ENTRY_DECLARE(VOXBRICK_VDB_READ_ENTRY);

namespace voxbrick::store {

std::shared_ptr<const VdbStore> VdbStore::open(const std::filesystem::path& file, const StoreOpenOptions& options) {
  static const VdbReadModule& module = VOXBRICK_MODULE_TABLE(VdbReadModule, "openvdb", VOXBRICK_VDB_READ_ENTRY);
  return module.open(file, options);
}

}  // namespace voxbrick::store
