// mesh.json: the metadata file of a mesh store, written last (a directory without it is not a complete store).
#pragma once

#include <string>

#include "mesh/MeshStore.h"

namespace voxbrick::mesh {

/// The JSON text of mesh.json for `info` (pretty-printed, keys in a fixed order, so the same store gives the same
/// bytes).
std::string meshInfoToJson(const MeshStoreInfo& info);

/// Parses mesh.json text. Fills field, source, counts, tetsPerChunk and zstdLevel (the rest comes from the index).
/// Throws MeshError naming `where` when the text is not JSON, is not a mesh store's, or lacks a field.
MeshStoreInfo meshInfoFromJson(const std::string& text, const std::string& where);

}  // namespace voxbrick::mesh
