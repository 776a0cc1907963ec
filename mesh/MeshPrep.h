// `voxbrick prep` of a tetrahedral mesh as one call, as brickstore's prepStore is for a volume: the mesh read (or
// made), validated and repaired, its face adjacency built, the mesh store written.
#pragma once

#include <filesystem>
#include <functional>
#include <string>

#include "mesh/MeshStore.h"
#include "mesh/TetMesh.h"
#include "mesh/Validate.h"

namespace voxbrick::mesh {

/// True when `input` names a tetrahedral mesh rather than a volume: a .vtk or .msh file (by its name, whatever its
/// case), or "synthetic-mesh:SPEC".
bool isMeshInput(const std::string& input);

/// The mesh `input` names, as read: "synthetic-mesh:SPEC" made (syntheticMesh), else the file read (readMesh) with the
/// point scalar `field` (the first when empty). Throws MeshError naming the input and the problem.
TetMesh readMeshInput(const std::string& input, const std::string& field = "");

struct MeshPrepOptions {
  std::string field;       ///< the point scalar to keep (the first when empty)
  MeshStoreOptions store;  ///< chunks, zstd level, overwrite (its source is set to the input)
};

/// Where a mesh prep is, for the caller's messages and for stopping it (an exception the callback throws aborts the
/// prep like any failure, with nothing written): "read" once the mesh is read, "validated" once it is repaired,
/// "topology" once its faces are matched, then each stage of writing the store (MeshWriteProgress).
struct MeshPrepProgress {
  std::string stage;
  const TetMesh* mesh = nullptr;             ///< "read", "validated", "topology": the mesh so far
  const MeshWriteProgress* write = nullptr;  ///< the stages of writing
};

/// What a finished mesh prep reports.
struct MeshPrepSummary {
  MeshStoreInfo info;   ///< what the store holds, as `info` says it
  MeshRepairs repairs;  ///< what validation repaired
  double seconds = 0;   ///< from reading the input to the store in place
};

/// Writes the mesh store of `input` (isMeshInput) at `output`, as writeMeshStore does: complete or not at all. Throws
/// MeshError naming the input or the output and the problem, and what `progress` throws.
MeshPrepSummary prepMeshStore(const std::string& input, const std::filesystem::path& output,
                              const MeshPrepOptions& options,
                              const std::function<void(const MeshPrepProgress&)>& progress = {});

}  // namespace voxbrick::mesh
