#include "mesh/ReaderSupport.h"

#include <algorithm>

#include "mesh/TetMesh.h"

namespace voxbrick::mesh {

namespace {

std::string joined(const std::vector<std::string>& items) {
  std::string out;
  for (const std::string& item : items) out += (out.empty() ? "" : ", ") + item;
  return out;
}

}  // namespace

std::string CellCensus::countedKinds(const std::map<std::string, size_t>& kinds) {
  std::string out;
  for (const auto& [kind, count] : kinds) out += (out.empty() ? "" : ", ") + std::to_string(count) + " x " + kind;
  return out;
}

void CellCensus::throwIfRefused(const std::string& file) const {
  if (mRefused.empty()) return;
  const std::string kinds = countedKinds(mRefused);
  // Splitting other cells into tets is possible but not faithful: a hexahedron's trilinear field (or a wedge's,
  // a pyramid's) is not piecewise linear, so any split changes the rendered field and depends on the diagonal
  // chosen. Refusing says so instead of rendering something else.
  throw MeshError(file + ": only linear tetrahedra are supported as volume cells; found " + kinds +
                  " (splitting them into tetrahedra would not reproduce their interpolation)");
}

bool FieldPicker::offer(const std::string& name) {
  if (std::find(mOffered.begin(), mOffered.end(), name) == mOffered.end()) mOffered.push_back(name);
  if (mChosen || (!mWanted.empty() && name != mWanted)) return false;
  mChosen = true;
  mChosenName = name;
  return true;
}

void FieldPicker::noteUnusable(const std::string& name, const std::string& reason) {
  mUnusable.push_back(name + " (" + reason + ")");
}

void FieldPicker::requireChosen(const std::string& file) const {
  if (mChosen) return;
  std::string message = file + ": ";
  message += mWanted.empty() ? "no point scalar field" : "no point scalar field named '" + mWanted + "'";
  message += "; available point scalars: " + (mOffered.empty() ? std::string("none") : joined(mOffered));
  if (!mUnusable.empty()) message += "; not usable: " + joined(mUnusable);
  throw MeshError(message);
}

}  // namespace voxbrick::mesh
