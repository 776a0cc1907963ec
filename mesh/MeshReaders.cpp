#include "mesh/MeshReaders.h"

namespace voxbrick::mesh {

namespace {

TetMesh readAny(FileCursor& in, const std::string& field) {
  // Content first: files are often renamed (.txt, .dat), and a wrong extension should not hide a readable file.
  std::string_view head = in.view().substr(0, 64);
  while (!head.empty() && (head.front() == ' ' || head.front() == '\n' || head.front() == '\r')) head.remove_prefix(1);
  if (lowerCase(head.substr(0, 14)) == "# vtk datafile") return readVtk(in, field);
  if (head.substr(0, 11) == "$MeshFormat") return readGmsh(in, field);
  const std::string ext = lowerCase(std::filesystem::path(in.name()).extension().string());
  if (ext == ".vtk") return readVtk(in, field);
  if (ext == ".msh") return readGmsh(in, field);
  in.failAt(0, "not a VTK legacy file (no '# vtk DataFile' line) nor a gmsh file (no $MeshFormat)");
}

}  // namespace

TetMesh readMesh(const std::filesystem::path& path, const std::string& field) {
  FileCursor in(path);
  return readAny(in, field);
}

TetMesh readMeshBytes(const std::string& name, std::vector<char> bytes, const std::string& field) {
  FileCursor in(name, std::move(bytes));
  return readAny(in, field);
}

}  // namespace voxbrick::mesh
