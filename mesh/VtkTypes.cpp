#include "mesh/VtkTypes.h"

#include <array>
#include <utility>

namespace voxbrick::mesh {

uint32_t vtkTypeBytes(VtkType type) {
  switch (type) {
    case VtkType::Int8:
    case VtkType::UInt8: return 1;
    case VtkType::Int16:
    case VtkType::UInt16: return 2;
    case VtkType::Int32:
    case VtkType::UInt32:
    case VtkType::Float32: return 4;
    case VtkType::Int64:
    case VtkType::UInt64:
    case VtkType::Float64: return 8;
    case VtkType::Bit:
    case VtkType::String: break;
  }
  return 0;
}

std::optional<VtkCellKind> vtkCellKind(int64_t type) {
  // Below dimension 3 a cell is a boundary or annotation cell, which readers drop.
  static const std::pair<int, VtkCellKind> kKinds[] = {{0, {"empty cell", 0}},
                                                       {1, {"vertex", 0}},
                                                       {2, {"poly-vertex", 0}},
                                                       {3, {"line", 1}},
                                                       {4, {"poly-line", 1}},
                                                       {5, {"triangle", 2}},
                                                       {6, {"triangle strip", 2}},
                                                       {7, {"polygon", 2}},
                                                       {8, {"pixel", 2}},
                                                       {9, {"quad", 2}},
                                                       {10, {"tetra", 3}},
                                                       {11, {"voxel", 3}},
                                                       {12, {"hexahedron", 3}},
                                                       {13, {"wedge", 3}},
                                                       {14, {"pyramid", 3}},
                                                       {15, {"pentagonal prism", 3}},
                                                       {16, {"hexagonal prism", 3}},
                                                       {21, {"quadratic edge", 1}},
                                                       {22, {"quadratic triangle", 2}},
                                                       {23, {"quadratic quad", 2}},
                                                       {24, {"quadratic tetra", 3}},
                                                       {25, {"quadratic hexahedron", 3}},
                                                       {26, {"quadratic wedge", 3}},
                                                       {27, {"quadratic pyramid", 3}},
                                                       {28, {"biquadratic quad", 2}},
                                                       {29, {"triquadratic hexahedron", 3}},
                                                       {30, {"quadratic-linear quad", 2}},
                                                       {31, {"quadratic-linear wedge", 3}},
                                                       {32, {"biquadratic-quadratic wedge", 3}},
                                                       {33, {"biquadratic-quadratic hexahedron", 3}},
                                                       {34, {"biquadratic triangle", 2}},
                                                       {35, {"cubic line", 1}},
                                                       {36, {"quadratic polygon", 2}},
                                                       {37, {"triquadratic pyramid", 3}},
                                                       {41, {"convex point set", 3}},
                                                       {42, {"polyhedron", 3}},
                                                       {51, {"parametric curve", 1}},
                                                       {52, {"parametric surface", 2}},
                                                       {53, {"parametric tri surface", 2}},
                                                       {54, {"parametric quad surface", 2}},
                                                       {55, {"parametric tetra region", 3}},
                                                       {56, {"parametric hex region", 3}},
                                                       {60, {"higher-order edge", 1}},
                                                       {61, {"higher-order triangle", 2}},
                                                       {62, {"higher-order quad", 2}},
                                                       {63, {"higher-order polygon", 2}},
                                                       {64, {"higher-order tetrahedron", 3}},
                                                       {65, {"higher-order wedge", 3}},
                                                       {66, {"higher-order pyramid", 3}},
                                                       {67, {"higher-order hexahedron", 3}},
                                                       {68, {"Lagrange curve", 1}},
                                                       {69, {"Lagrange triangle", 2}},
                                                       {70, {"Lagrange quadrilateral", 2}},
                                                       {71, {"Lagrange tetrahedron", 3}},
                                                       {72, {"Lagrange hexahedron", 3}},
                                                       {73, {"Lagrange wedge", 3}},
                                                       {74, {"Lagrange pyramid", 3}},
                                                       {75, {"Bezier curve", 1}},
                                                       {76, {"Bezier triangle", 2}},
                                                       {77, {"Bezier quadrilateral", 2}},
                                                       {78, {"Bezier tetrahedron", 3}},
                                                       {79, {"Bezier hexahedron", 3}},
                                                       {80, {"Bezier wedge", 3}},
                                                       {81, {"Bezier pyramid", 3}}};
  // Indexed once: a file can hold millions of cells.
  static const auto kByNumber = [] {
    std::array<std::optional<VtkCellKind>, 82> table{};
    for (const auto& [number, kind] : kKinds) table[static_cast<size_t>(number)] = kind;
    return table;
  }();
  if (type < 0 || type >= static_cast<int64_t>(kByNumber.size())) return std::nullopt;
  return kByNumber[static_cast<size_t>(type)];
}

std::string encodeVtkName(std::string_view name) {
  const char* hex = "0123456789ABCDEF";
  std::string out;
  for (char c : name) {
    const auto u = static_cast<unsigned char>(c);
    if (u <= ' ' || u >= 127 || c == '%') {
      out += '%';
      out += hex[u >> 4];
      out += hex[u & 15];
    } else {
      out += c;
    }
  }
  return out;
}

std::string decodeVtkName(std::string_view text) {
  auto hex = [](char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
  };
  std::string out;
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '%' && i + 2 < text.size() && hex(text[i + 1]) >= 0 && hex(text[i + 2]) >= 0) {
      out += static_cast<char>(hex(text[i + 1]) * 16 + hex(text[i + 2]));
      i += 2;
    } else {
      out += text[i];
    }
  }
  return out;
}

}  // namespace voxbrick::mesh
