// Writers for the formats mesh/MeshReaders.h reads: for tests, and for benchmarks that feed other renderers.
#pragma once

#include <filesystem>

#include "mesh/TetMesh.h"

namespace voxbrick::mesh {

/// Writes `mesh` as a VTK legacy unstructured grid (version 3.0, the classic CELLS layout, float points), with
/// its scalars as SCALARS named mesh.field ("scalars" when empty; spaces written as %20). Binary files are
/// big-endian as the format specifies unless `bigEndian` is false (what some writers emit). Throws MeshError when
/// the file cannot be written.
void writeVtk(const TetMesh& mesh, const std::filesystem::path& path, bool binary, bool bigEndian = true);

/// Writes `mesh` as a gmsh file of `version` 2 (MSH 2.2) or 4 (MSH 4.1), ASCII or binary (in this machine's byte
/// order, as gmsh does): nodes tagged 1..n, the tets as elements of type 4, the scalars as a $NodeData view named
/// mesh.field ("scalars" when empty; a '"' in it becomes '_'). Throws MeshError for another version or when the
/// file cannot be written.
void writeGmsh(const TetMesh& mesh, const std::filesystem::path& path, int version, bool binary);

}  // namespace voxbrick::mesh
