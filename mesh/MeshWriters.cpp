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

void writeGmsh(const TetMesh& mesh, const std::filesystem::path& path, int version, bool binary) {
  if (version != 2 && version != 4)
    throw MeshError(path.string() + ": gmsh version " + std::to_string(version) + " cannot be written (2 or 4)");
  checkWritable(mesh, path);
  constexpr bool kNative = std::endian::native == std::endian::big;  // gmsh writes its machine's order
  OutFile out(path);
  const size_t n = mesh.points.size(), m = mesh.tets.size();
  out.text(version == 2 ? "$MeshFormat\n2.2 " : "$MeshFormat\n4.1 ");
  out.text(binary ? "1 8\n" : "0 8\n");
  if (binary) {
    out.binary(int32_t{1}, kNative);
    out.text("\n");
  }
  out.text("$EndMeshFormat\n");
  // Text lines of numbers, or the same numbers as binary values of the given types.
  auto size = [&](uint64_t v, const char* after) {
    binary ? out.binary(v, kNative) : (out.number(v), out.text(after));
  };
  auto integer = [&](int32_t v, const char* after) {
    binary ? out.binary(v, kNative) : (out.number(v), out.text(after));
  };
  auto real = [&](double v, const char* after) { binary ? out.binary(v, kNative) : (out.number(v), out.text(after)); };

  if (version == 2) {
    out.text("$Nodes\n" + std::to_string(n) + "\n");
    for (size_t i = 0; i < n; ++i) {
      integer(static_cast<int32_t>(i + 1), " ");
      for (int k = 0; k < 3; ++k) real(mesh.points[i][k], k < 2 ? " " : "\n");
    }
    out.text(binary ? "\n$EndNodes\n$Elements\n" : "$EndNodes\n$Elements\n");
    out.text(std::to_string(m) + "\n");
    if (binary && m > 0) {  // one run: type 4, m elements, 2 tags each
      integer(4, "");
      integer(static_cast<int32_t>(m), "");
      integer(2, "");
    }
    for (size_t t = 0; t < m; ++t) {
      integer(static_cast<int32_t>(t + 1), " ");
      if (!binary) out.text("4 2 ");
      integer(0, " ");  // physical group
      integer(1, " ");  // elementary entity
      for (int k = 0; k < 4; ++k) integer(static_cast<int32_t>(mesh.tets[t][k] + 1), k < 3 ? " " : "\n");
    }
    out.text(binary ? "\n$EndElements\n" : "$EndElements\n");
  } else {
    // One volume entity holds every node and element.
    const auto [lo, hi] = mesh.bounds();
    out.text("$Entities\n");
    for (uint64_t count : {0, 0, 0, 1}) size(count, count == 1 ? "\n" : " ");
    integer(1, " ");
    for (int k = 0; k < 3; ++k) real(n ? lo[k] : 0.0f, " ");
    for (int k = 0; k < 3; ++k) real(n ? hi[k] : 0.0f, " ");
    size(0, " ");  // physical tags
    size(0, "\n");  // bounding surfaces
    // A section's header (blocks, count, tag range) and its one block's header in volume entity 1: `kind` is the
    // nodes' parametric flag (0) or the elements' type (4: tetrahedra). Nothing after the header for an empty one.
    auto sectionOfOneBlock = [&](size_t count, int32_t kind) {
      size(count ? 1 : 0, " ");
      size(count, " ");
      size(count ? 1 : 0, " ");
      size(count, "\n");
      if (count == 0) return false;
      integer(3, " ");
      integer(1, " ");
      integer(kind, " ");
      size(count, "\n");
      return true;
    };
    out.text(binary ? "\n$EndEntities\n$Nodes\n" : "$EndEntities\n$Nodes\n");
    if (sectionOfOneBlock(n, 0)) {
      for (size_t i = 0; i < n; ++i) size(i + 1, "\n");
      for (const glm::vec3& p : mesh.points)
        for (int k = 0; k < 3; ++k) real(p[k], k < 2 ? " " : "\n");
    }
    out.text(binary ? "\n$EndNodes\n$Elements\n" : "$EndNodes\n$Elements\n");
    if (sectionOfOneBlock(m, 4)) {
      for (size_t t = 0; t < m; ++t) {
        size(t + 1, " ");
        for (int k = 0; k < 4; ++k) size(uint64_t{mesh.tets[t][k]} + 1, k < 3 ? " " : "\n");
      }
    }
    out.text(binary ? "\n$EndElements\n" : "$EndElements\n");
  }

  if (!mesh.scalars.empty()) {
    std::string name = mesh.field.empty() ? "scalars" : mesh.field;
    for (char& c : name)
      if (c == '"' || c == '\n' || c == '\r') c = '_';
    out.text("$NodeData\n1\n\"" + name + "\"\n1\n0\n3\n0\n1\n" + std::to_string(n) + "\n");
    for (size_t i = 0; i < n; ++i) {
      integer(static_cast<int32_t>(i + 1), " ");
      real(mesh.scalars[i], "\n");
    }
    out.text(binary ? "\n$EndNodeData\n" : "$EndNodeData\n");
  }
  out.close();
}

}  // namespace voxbrick::mesh
