// The OpenVDB module's entries: one table for each side that asks (read, ingest, prep), as their headers declare.
#include "brickstore/ingest/vdb/VdbSource.h"
#include "brickstore/modules/openvdb/OpenVdbModule.h"
#include "common/Modules.h"

VOXBRICK_MODULE_ENTRY_DEFINE(VOXBRICK_VDB_READ_ENTRY) {
  static const voxbrick::store::VdbReadModule table{&voxbrick::store::openVdbTreeStore};
  return &table;
}

VOXBRICK_MODULE_ENTRY_DEFINE(VOXBRICK_VDB_INGEST_ENTRY) {
  static const voxbrick::store::VdbIngestModule table{&voxbrick::store::openVdbGridSource};
  return &table;
}

VOXBRICK_MODULE_ENTRY_DEFINE(VOXBRICK_VDB_PREP_ENTRY) {
  static const voxbrick::store::VdbPrepModule table{
      &voxbrick::store::makeVdbChunkFiles, &voxbrick::store::vdbChunkBytes, &voxbrick::store::vdbResidentBytes};
  return &table;
}
