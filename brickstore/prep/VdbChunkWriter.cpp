// VdbChunkWriter: the OpenVDB module's (brickstore/modules/openvdb), the module loaded on first use.
#include "brickstore/prep/VdbChunkWriter.h"

#include "common/Modules.h"

VOXBRICK_MODULE_ENTRY_DECLARE(VOXBRICK_VDB_PREP_ENTRY);

namespace voxbrick::store {
namespace {

const VdbPrepModule& prepModule() {
  static const VdbPrepModule& module = VOXBRICK_MODULE_TABLE(VdbPrepModule, "openvdb", VOXBRICK_VDB_PREP_ENTRY);
  return module;
}

}  // namespace

std::unique_ptr<VdbChunkWriter> VdbChunkWriter::make(const std::filesystem::path& storeDir, const VolumeInfo& info,
                                                     double background, int64_t chunkSlices,
                                                     VdbCompression compression) {
  return prepModule().make(storeDir, info, background, chunkSlices, compression);
}

int64_t VdbChunkWriter::chunkBytes(const Vec3i& dims, int64_t slices) { return prepModule().chunkBytes(dims, slices); }

int64_t VdbChunkWriter::residentBytes(const Vec3i& dims, int64_t slices) {
  return prepModule().residentBytes(dims, slices);
}

}  // namespace voxbrick::store
