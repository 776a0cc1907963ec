// An OpenVDB float grid as prep's input: read by the OpenVDB module (brickstore/modules/openvdb), loaded on first use.
#pragma once

#include <memory>
#include <string>

#include "brickstore/source/VolumeSource.h"

namespace voxbrick::store {

/// An OpenVDB float grid (by name, or the first float grid), over its active voxels' bounding box. Loads the OpenVDB
/// module the first time (common::ModuleError if it cannot).
std::unique_ptr<VolumeSource> openVdbSource(const std::string& path, const SourceOptions& options);

/// The OpenVDB module's ingest side: the table its entry VOXBRICK_VDB_INGEST_ENTRY gives (common/Modules.h; the name
/// changes with the table).
struct VdbIngestModule {
  std::unique_ptr<VolumeSource> (*openSource)(const std::string& path, const SourceOptions& options);
};
#define VOXBRICK_VDB_INGEST_ENTRY voxbrick_module_openvdb_ingest_v1

}  // namespace voxbrick::store
