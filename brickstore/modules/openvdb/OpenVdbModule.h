// The OpenVDB module's own functions (libvoxbrick_openvdb.so; OpenVdbEntries.cpp gives them through its entries):
// what the read side, ingest and prep ask of a .vdb.
#pragma once

#include <filesystem>
#include <memory>
#include <string>

#include "brickstore/prep/VdbChunkWriter.h"
#include "brickstore/read/VdbStore.h"
#include "brickstore/source/VolumeSource.h"

namespace voxbrick::store {

/// VdbStore::open (VdbTreeStore.cpp).
std::shared_ptr<const VdbStore> openVdbTreeStore(const std::filesystem::path& file, const StoreOpenOptions& options);

/// openVdbSource (VdbGridSource.cpp).
std::unique_ptr<VolumeSource> openVdbGridSource(const std::string& path, const SourceOptions& options);

/// VdbChunkWriter::make, chunkBytes and residentBytes (VdbChunkFiles.cpp).
std::unique_ptr<VdbChunkWriter> makeVdbChunkFiles(const std::filesystem::path& storeDir, const VolumeInfo& info,
                                                  double background, int64_t chunkSlices, VdbCompression compression);
int64_t vdbChunkBytes(const Vec3i& dims, int64_t slices);
int64_t vdbResidentBytes(const Vec3i& dims, int64_t slices);

}  // namespace voxbrick::store
