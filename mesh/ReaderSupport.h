// What the VTK and gmsh readers share: the census of refused cells and the choice of the scalar field by name.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace voxbrick::mesh {

/// The volume cells a reader cannot take (anything but linear tetrahedra), counted by kind, so one error can name
/// them all.
class CellCensus {
 public:
  /// Counts one cell of `kind` (e.g. "hexahedron (VTK type 12)").
  void refuse(const std::string& kind) { ++mRefused[kind]; }
  /// Counts one cell of `kind` left out on purpose (e.g. "triangle (VTK type 5)": a boundary, not a volume).
  void drop(const std::string& kind) { ++mDropped[kind]; }
  /// The dropped cells, "N x KIND, ..." ("" when none), for TetMesh::dropped.
  std::string dropped() const { return countedKinds(mDropped); }
  bool anyRefused() const { return !mRefused.empty(); }
  /// Throws MeshError naming `file` and every refused kind with its count, if any was refused.
  void throwIfRefused(const std::string& file) const;

 private:
  static std::string countedKinds(const std::map<std::string, size_t>& kinds);

  std::map<std::string, size_t> mRefused;
  std::map<std::string, size_t> mDropped;
};

/// Chooses the point scalar to read: the one named `wanted`, or the first offered when `wanted` is empty.
class FieldPicker {
 public:
  explicit FieldPicker(std::string wanted) : mWanted(std::move(wanted)) {}

  /// Offers a one-component point array named `name`; true if the reader should read it (it is now the choice).
  bool offer(const std::string& name);
  /// Records an array that cannot be chosen, with the reason ("3 components", "cell data"), for the error message.
  void noteUnusable(const std::string& name, const std::string& reason);
  bool chosen() const { return mChosen; }
  const std::string& chosenName() const { return mChosenName; }
  /// Throws MeshError naming `file`, the wanted name and every name available, unless a field was chosen.
  void requireChosen(const std::string& file) const;

 private:
  std::string mWanted;
  bool mChosen = false;
  std::string mChosenName;
  std::vector<std::string> mOffered;
  std::vector<std::string> mUnusable;
};

}  // namespace voxbrick::mesh
