#include "mesh/MeshWriters.h"

#include <charconv>
#include <cstring>
#include <fstream>
#include <string>

#include "mesh/FileCursor.h"
#include "mesh/VtkTypes.h"

namespace voxbrick::mesh {

namespace {

// Buffered output that turns every failure into a MeshError naming the file.
class OutFile {
 public:
  explicit OutFile(const std::filesystem::path& path)
      : mName(path.string()), mOut(path, std::ios::binary | std::ios::trunc) {
    if (!mOut) throw MeshError(mName + ": cannot open for writing");
  }

  void text(std::string_view s) {
    mBuffer.append(s);
    maybeFlush();
  }
  // Shortest text that reads back to the same value, so ASCII files round-trip exactly.
  template <class T>
  void number(T value) {
    char digits[40];
    const auto result = std::to_chars(digits, digits + sizeof(digits), value);
    mBuffer.append(digits, result.ptr);
  }
  template <class T>
  void binary(T value, bool bigEndian) {
    char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    if (needsSwap(bigEndian))
      for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
    mBuffer.append(bytes, sizeof(T));
    maybeFlush();
  }
  void close() {
    flush();
    mOut.close();
    if (!mOut) throw MeshError(mName + ": writing failed");
  }

 private:
  void maybeFlush() {
    if (mBuffer.size() >= (1u << 20)) flush();
  }
  void flush() {
    mOut.write(mBuffer.data(), static_cast<std::streamsize>(mBuffer.size()));
    mBuffer.clear();
    if (!mOut) throw MeshError(mName + ": writing failed");
  }

  std::string mName;
  std::ofstream mOut;
  std::string mBuffer;
};

void checkWritable(const TetMesh& mesh, const std::filesystem::path& path) {
  if (!mesh.scalars.empty() && mesh.scalars.size() != mesh.points.size())
    throw MeshError(path.string() + ": cannot write " + std::to_string(mesh.scalars.size()) + " scalars for " +
                    std::to_string(mesh.points.size()) + " vertices");
  // Both formats store indices (and gmsh tags) as 32-bit ints in binary files.
  if (mesh.points.size() >= INT32_MAX || mesh.tets.size() >= INT32_MAX)
    throw MeshError(path.string() + ": too many vertices or tets for 32-bit indices");
}

}  // namespace

void writeVtk(const TetMesh& mesh, const std::filesystem::path& path, bool binary, bool bigEndian) {
  checkWritable(mesh, path);
  OutFile out(path);
  const std::string n = std::to_string(mesh.points.size()), m = std::to_string(mesh.tets.size());
  out.text("# vtk DataFile Version 3.0\nvoxbrick tetrahedral mesh\n");
  out.text(binary ? "BINARY\n" : "ASCII\n");
  out.text("DATASET UNSTRUCTURED_GRID\nPOINTS " + n + " float\n");
  for (const glm::vec3& p : mesh.points)
    for (int k = 0; k < 3; ++k) {
      if (binary) {
        out.binary(p[k], bigEndian);
      } else {
        out.number(p[k]);
        out.text(k < 2 ? " " : "\n");
      }
    }
  out.text((binary ? "\nCELLS " : "CELLS ") + m + " " + std::to_string(5 * mesh.tets.size()) + "\n");
  for (const Tet& tet : mesh.tets) {
    if (binary) {
      out.binary(int32_t{4}, bigEndian);
      for (uint32_t v : tet) out.binary(static_cast<int32_t>(v), bigEndian);
    } else {
      out.text("4");
      for (uint32_t v : tet) {
        out.text(" ");
        out.number(v);
      }
      out.text("\n");
    }
  }
  out.text((binary ? "\nCELL_TYPES " : "CELL_TYPES ") + m + "\n");
  for (size_t t = 0; t < mesh.tets.size(); ++t) binary ? out.binary(int32_t{10}, bigEndian) : out.text("10\n");
  if (!mesh.scalars.empty()) {
    const std::string name = encodeVtkName(mesh.field.empty() ? "scalars" : mesh.field);
    out.text((binary ? "\nPOINT_DATA " : "POINT_DATA ") + n + "\nSCALARS " + name + " float 1\nLOOKUP_TABLE default\n");
    for (float s : mesh.scalars) {
      if (binary) {
        out.binary(s, bigEndian);
      } else {
        out.number(s);
        out.text("\n");
      }
    }
  }
  if (binary) out.text("\n");
  out.close();
}

namespace {

/// A gmsh file's numbers: text, each followed by its separator, or binary values of the given types in the
/// machine's byte order (gmsh writes its machine's order).
class GmshOut {
 public:
  GmshOut(const std::filesystem::path& path, bool binary) : mOut(path), mBinary(binary) {}
  void text(std::string_view s) { mOut.text(s); }
  /// Text after a run of numbers: binary values end without a newline, so one goes first.
  void textAfterData(const std::string& s) { mOut.text(mBinary ? "\n" + s : s); }
  void size(uint64_t v, const char* after) { put(v, after); }
  void integer(int32_t v, const char* after) { put(v, after); }
  void real(double v, const char* after) { put(v, after); }
  void close() { mOut.close(); }

 private:
  template <class T>
  void put(T v, const char* after) {
    constexpr bool kNative = std::endian::native == std::endian::big;
    if (mBinary) {
      mOut.binary(v, kNative);
    } else {
      mOut.number(v);
      mOut.text(after);
    }
  }

  OutFile mOut;
  bool mBinary;
};

/// Version 2.2: nodes, then tetrahedra with two tags each (binary: in one run of type 4).
void writeGmsh2Body(GmshOut& out, const TetMesh& mesh, bool binary) {
  const size_t n = mesh.points.size(), m = mesh.tets.size();
  out.text("$Nodes\n" + std::to_string(n) + "\n");
  for (size_t i = 0; i < n; ++i) {
    out.integer(static_cast<int32_t>(i + 1), " ");
    for (int k = 0; k < 3; ++k) out.real(mesh.points[i][k], k < 2 ? " " : "\n");
  }
  out.textAfterData("$EndNodes\n$Elements\n");
  out.text(std::to_string(m) + "\n");
  if (binary && m > 0) {  // one run: type 4, m elements, 2 tags each
    out.integer(4, "");
    out.integer(static_cast<int32_t>(m), "");
    out.integer(2, "");
  }
  for (size_t t = 0; t < m; ++t) {
    out.integer(static_cast<int32_t>(t + 1), " ");
    if (!binary) out.text("4 2 ");
    out.integer(0, " ");  // physical group
    out.integer(1, " ");  // elementary entity
    for (int k = 0; k < 4; ++k) out.integer(static_cast<int32_t>(mesh.tets[t][k] + 1), k < 3 ? " " : "\n");
  }
  out.textAfterData("$EndElements\n");
}

/// A version 4 section's header (blocks, count, tag range) and its one block's header in volume entity 1: `kind`
/// is the nodes' parametric flag (0) or the elements' type (4: tetrahedra). Nothing after the header for an empty
/// one; returns whether the block follows.
bool gmsh4SectionOfOneBlock(GmshOut& out, size_t count, int32_t kind) {
  out.size(count ? 1 : 0, " ");
  out.size(count, " ");
  out.size(count ? 1 : 0, " ");
  out.size(count, "\n");
  if (count == 0) return false;
  out.integer(3, " ");
  out.integer(1, " ");
  out.integer(kind, " ");
  out.size(count, "\n");
  return true;
}

/// Version 4.1: one volume entity holds every node and element.
void writeGmsh4Body(GmshOut& out, const TetMesh& mesh) {
  const size_t n = mesh.points.size(), m = mesh.tets.size();
  const auto [lo, hi] = mesh.bounds();
  out.text("$Entities\n");
  for (uint64_t count : {0, 0, 0, 1}) out.size(count, count == 1 ? "\n" : " ");
  out.integer(1, " ");
  for (int k = 0; k < 3; ++k) out.real(n ? lo[k] : 0.0f, " ");
  for (int k = 0; k < 3; ++k) out.real(n ? hi[k] : 0.0f, " ");
  out.size(0, " ");   // physical tags
  out.size(0, "\n");  // bounding surfaces
  out.textAfterData("$EndEntities\n$Nodes\n");
  if (gmsh4SectionOfOneBlock(out, n, 0)) {
    for (size_t i = 0; i < n; ++i) out.size(i + 1, "\n");
    for (const glm::vec3& p : mesh.points)
      for (int k = 0; k < 3; ++k) out.real(p[k], k < 2 ? " " : "\n");
  }
  out.textAfterData("$EndNodes\n$Elements\n");
  if (gmsh4SectionOfOneBlock(out, m, 4)) {
    for (size_t t = 0; t < m; ++t) {
      out.size(t + 1, " ");
      for (int k = 0; k < 4; ++k) out.size(uint64_t{mesh.tets[t][k]} + 1, k < 3 ? " " : "\n");
    }
  }
  out.textAfterData("$EndElements\n");
}

/// The scalars as one $NodeData view named after the field.
void writeGmshNodeData(GmshOut& out, const TetMesh& mesh) {
  std::string name = mesh.field.empty() ? "scalars" : mesh.field;
  for (char& c : name)
    if (c == '"' || c == '\n' || c == '\r') c = '_';
  const size_t n = mesh.points.size();
  out.text("$NodeData\n1\n\"" + name + "\"\n1\n0\n3\n0\n1\n" + std::to_string(n) + "\n");
  for (size_t i = 0; i < n; ++i) {
    out.integer(static_cast<int32_t>(i + 1), " ");
    out.real(mesh.scalars[i], "\n");
  }
  out.textAfterData("$EndNodeData\n");
}

}  // namespace

void writeGmsh(const TetMesh& mesh, const std::filesystem::path& path, int version, bool binary) {
  if (version != 2 && version != 4)
    throw MeshError(path.string() + ": gmsh version " + std::to_string(version) + " cannot be written (2 or 4)");
  checkWritable(mesh, path);
  GmshOut out(path, binary);
  out.text(version == 2 ? "$MeshFormat\n2.2 " : "$MeshFormat\n4.1 ");
  out.text(binary ? "1 8\n" : "0 8\n");
  if (binary) {
    out.integer(1, "");
    out.text("\n");
  }
  out.text("$EndMeshFormat\n");
  if (version == 2)
    writeGmsh2Body(out, mesh, binary);
  else
    writeGmsh4Body(out, mesh);
  if (!mesh.scalars.empty()) writeGmshNodeData(out, mesh);
  out.close();
}

}  // namespace voxbrick::mesh
