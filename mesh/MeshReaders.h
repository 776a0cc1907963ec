// Ingest of unstructured tetrahedral meshes: VTK legacy unstructured grids (.vtk, ASCII or binary, classic or
// VTK 5.1 cell layout) and gmsh meshes (.msh 2.x and 4.1, ASCII or binary), with one scalar per vertex.
// The formats accepted and refused, and the byte-order rule for binary VTK, are in mesh/README.md.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "mesh/FileCursor.h"
#include "mesh/TetMesh.h"

namespace voxbrick::mesh {

/// Reads the mesh in `path` and the point scalar named `field` (the first point scalar when empty). The format is
/// chosen by the file's first bytes ("# vtk DataFile" or "$MeshFormat"), then by its extension. Cells of lower
/// dimension (vertices, lines, triangles, quads: boundary tags) are dropped; volume cells other than linear
/// tetrahedra are refused. The result is as the file says: call validateMesh (mesh/Validate.h) before using it.
/// Throws MeshError naming the file, the place in it and what is wrong (a missing field lists those available).
TetMesh readMesh(const std::filesystem::path& path, const std::string& field = "");

/// The same from bytes in memory; `name` stands for the file in messages and decides the format as an extension
/// would when the content does not.
TetMesh readMeshBytes(const std::string& name, std::vector<char> bytes, const std::string& field = "");

/// A VTK legacy unstructured grid from `in` (positioned at the start). Throws MeshError.
TetMesh readVtk(FileCursor& in, const std::string& field);
/// A gmsh mesh, format 2.x or 4.1, from `in` (positioned at the start). Throws MeshError.
TetMesh readGmsh(FileCursor& in, const std::string& field);

}  // namespace voxbrick::mesh
