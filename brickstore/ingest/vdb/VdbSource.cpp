// openVdbSource: the OpenVDB module's source (brickstore/modules/openvdb), the module loaded on first use.
#include "brickstore/ingest/vdb/VdbSource.h"

#include "common/Modules.h"

VOXBRICK_MODULE_ENTRY_DECLARE(VOXBRICK_VDB_INGEST_ENTRY);

namespace voxbrick::store {

std::unique_ptr<VolumeSource> openVdbSource(const std::string& path, const SourceOptions& options) {
  static const VdbIngestModule& module = VOXBRICK_MODULE_TABLE(VdbIngestModule, "openvdb", VOXBRICK_VDB_INGEST_ENTRY);
  return module.openSource(path, options);
}

}  // namespace voxbrick::store
