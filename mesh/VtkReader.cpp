// The VTK legacy unstructured-grid reader (readVtk in mesh/MeshReaders.h).
#include <array>
#include <cstdint>
#include <optional>

#include "mesh/MeshReaders.h"
#include "mesh/ReaderSupport.h"

namespace voxbrick::mesh {

namespace {

enum class VtkType { Bit, Int8, UInt8, Int16, UInt16, Int32, UInt32, Int64, UInt64, Float32, Float64, String };

struct TypeInfo {
  const char* name;
  VtkType type;
  uint32_t bytes;  // in binary files; 0 for bit and string arrays
};

constexpr TypeInfo kTypes[] = {
    {"bit", VtkType::Bit, 0},           {"char", VtkType::Int8, 1},           {"signed_char", VtkType::Int8, 1},
    {"unsigned_char", VtkType::UInt8, 1}, {"short", VtkType::Int16, 2},     {"unsigned_short", VtkType::UInt16, 2},
    {"int", VtkType::Int32, 4},         {"unsigned_int", VtkType::UInt32, 4},
    // "long" has the writer's sizeof(long): 8 on the LP64 systems that write nearly all such files.
    {"long", VtkType::Int64, 8},        {"unsigned_long", VtkType::UInt64, 8}, {"vtkidtype", VtkType::Int64, 8},
    {"vtktypeint8", VtkType::Int8, 1},  {"vtktypeuint8", VtkType::UInt8, 1},  {"vtktypeint16", VtkType::Int16, 2},
    {"vtktypeuint16", VtkType::UInt16, 2}, {"vtktypeint32", VtkType::Int32, 4}, {"vtktypeuint32", VtkType::UInt32, 4},
    {"vtktypeint64", VtkType::Int64, 8}, {"vtktypeuint64", VtkType::UInt64, 8}, {"float", VtkType::Float32, 4},
    {"double", VtkType::Float64, 8},    {"vtktypefloat32", VtkType::Float32, 4}, {"vtktypefloat64", VtkType::Float64, 8},
    {"string", VtkType::String, 0},     {"utf8_string", VtkType::String, 0}};

constexpr int kTetra = 10;

// VTK's cell types (vtkCellType.h) by number: name and dimension. Cells below dimension 3 are boundary or
// annotation cells and are dropped; volume cells other than the linear tetra are refused.
struct CellKind {
  const char* name;
  int dim;
};

std::optional<CellKind> cellKind(int64_t type) {
  static const std::pair<int, CellKind> kKinds[] = {
      {0, {"empty cell", 0}}, {1, {"vertex", 0}}, {2, {"poly-vertex", 0}}, {3, {"line", 1}}, {4, {"poly-line", 1}},
      {5, {"triangle", 2}}, {6, {"triangle strip", 2}}, {7, {"polygon", 2}}, {8, {"pixel", 2}}, {9, {"quad", 2}},
      {10, {"tetra", 3}}, {11, {"voxel", 3}}, {12, {"hexahedron", 3}}, {13, {"wedge", 3}}, {14, {"pyramid", 3}},
      {15, {"pentagonal prism", 3}}, {16, {"hexagonal prism", 3}}, {21, {"quadratic edge", 1}},
      {22, {"quadratic triangle", 2}}, {23, {"quadratic quad", 2}}, {24, {"quadratic tetra", 3}},
      {25, {"quadratic hexahedron", 3}}, {26, {"quadratic wedge", 3}}, {27, {"quadratic pyramid", 3}},
      {28, {"biquadratic quad", 2}}, {29, {"triquadratic hexahedron", 3}}, {30, {"quadratic-linear quad", 2}},
      {31, {"quadratic-linear wedge", 3}}, {32, {"biquadratic-quadratic wedge", 3}},
      {33, {"biquadratic-quadratic hexahedron", 3}}, {34, {"biquadratic triangle", 2}}, {35, {"cubic line", 1}},
      {36, {"quadratic polygon", 2}}, {37, {"triquadratic pyramid", 3}}, {41, {"convex point set", 3}},
      {42, {"polyhedron", 3}}, {51, {"parametric curve", 1}}, {52, {"parametric surface", 2}},
      {53, {"parametric tri surface", 2}}, {54, {"parametric quad surface", 2}},
      {55, {"parametric tetra region", 3}}, {56, {"parametric hex region", 3}}, {60, {"higher-order edge", 1}},
      {61, {"higher-order triangle", 2}}, {62, {"higher-order quad", 2}}, {63, {"higher-order polygon", 2}},
      {64, {"higher-order tetrahedron", 3}}, {65, {"higher-order wedge", 3}}, {66, {"higher-order pyramid", 3}},
      {67, {"higher-order hexahedron", 3}}, {68, {"Lagrange curve", 1}}, {69, {"Lagrange triangle", 2}},
      {70, {"Lagrange quadrilateral", 2}}, {71, {"Lagrange tetrahedron", 3}}, {72, {"Lagrange hexahedron", 3}},
      {73, {"Lagrange wedge", 3}}, {74, {"Lagrange pyramid", 3}}, {75, {"Bezier curve", 1}},
      {76, {"Bezier triangle", 2}}, {77, {"Bezier quadrilateral", 2}}, {78, {"Bezier tetrahedron", 3}},
      {79, {"Bezier hexahedron", 3}}, {80, {"Bezier wedge", 3}}, {81, {"Bezier pyramid", 3}}};
  // Indexed once: a file can hold millions of cells.
  static const auto kByNumber = [] {
    std::array<std::optional<CellKind>, 82> table{};
    for (const auto& [number, kind] : kKinds) table[static_cast<size_t>(number)] = kind;
    return table;
  }();
  if (type < 0 || type >= static_cast<int64_t>(kByNumber.size())) return std::nullopt;
  return kByNumber[static_cast<size_t>(type)];
}

// VTK 7+ writes names with spaces and unprintable bytes as %XX.
std::string decodeName(std::string_view text) {
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

// Binary content that makes no sense in the byte order tried (a cell type VTK does not have, cell sizes that do
// not add up): readVtk then tries the other order.
class ByteOrderSuspect : public MeshError {
 public:
  using MeshError::MeshError;
};

class VtkParser {
 public:
  VtkParser(FileCursor& in, const std::string& field, bool bigEndian)
      : mIn(in), mPicker(field), mSwap(needsSwap(bigEndian)) {}

  TetMesh parse();

 private:
  void readHeader();
  void readPoints();
  void readCells();
  void readCellTypes();
  void readAttributes(uint64_t count, bool pointData);
  void readFieldArrays(uint64_t count, bool pointData, bool datasetLevel);
  void skipMetadataIfPresent();
  TetMesh assemble();

  const TypeInfo& readType(const char* what);
  void endHeader();
  std::vector<std::string> restOfLine();
  void guard(const TypeInfo& type, uint64_t count, const char* what);
  int64_t integerValue(const TypeInfo& type, const char* what);
  template <class Sink>
  void readReals(const TypeInfo& type, uint64_t count, const char* what, Sink&& sink);
  void skipValues(const TypeInfo& type, uint64_t count, const char* what);
  [[noreturn]] void suspect(size_t offset, const std::string& what) const;

  FileCursor& mIn;
  FieldPicker mPicker;
  bool mSwap;
  bool mBinary = false;
  std::optional<std::vector<glm::vec3>> mPoints;
  std::optional<std::vector<uint64_t>> mCellStart;  // ncells + 1 offsets into mConnectivity
  std::vector<uint32_t> mConnectivity;
  std::optional<std::vector<int32_t>> mCellTypes;
  std::vector<float> mScalars;
};

void VtkParser::suspect(size_t offset, const std::string& what) const {
  if (mBinary) throw ByteOrderSuspect(mIn.where(offset) + ": " + what);
  mIn.failAt(offset, what);
}

const TypeInfo& VtkParser::readType(const char* what) {
  const size_t at = (mIn.skipWhitespace(), mIn.offset());
  const std::string name = lowerCase(mIn.token(what));
  for (const TypeInfo& info : kTypes)
    if (name == info.name) return info;
  mIn.failAt(at, "unknown data type '" + name + "' for " + what);
}

void VtkParser::endHeader() {
  // Binary data starts right after the header line's end, so the rest of the line must be consumed exactly.
  if (!mBinary) return;
  const size_t at = mIn.offset();
  std::string_view rest = mIn.line();
  if (rest.find_first_not_of(" \t") != std::string_view::npos) mIn.failAt(at, "unexpected text after the header");
}

std::vector<std::string> VtkParser::restOfLine() {
  std::vector<std::string> words;
  FileCursor line(mIn.name(), [&] {
    std::string_view text = mIn.line();
    return std::vector<char>(text.begin(), text.end());
  }());
  for (std::string_view w = line.token(); !w.empty(); w = line.token()) words.emplace_back(w);
  return words;
}

void VtkParser::guard(const TypeInfo& type, uint64_t count, const char* what) {
  if (type.type == VtkType::String) mIn.fail(std::string("string arrays are not supported (") + what + ")");
  if (!mBinary) return mIn.requireFits(count, 2, what, 1);  // a digit and a separator, none after the last
  if (type.type == VtkType::Bit) return mIn.requireFits((count + 7) / 8, 1, what);
  mIn.requireFits(count, type.bytes, what);
}

int64_t VtkParser::integerValue(const TypeInfo& type, const char* what) {
  if (!mBinary) return mIn.integer(what);
  switch (type.type) {
    case VtkType::Int8: return mIn.binary<int8_t>(mSwap, what);
    case VtkType::UInt8: return mIn.binary<uint8_t>(mSwap, what);
    case VtkType::Int16: return mIn.binary<int16_t>(mSwap, what);
    case VtkType::UInt16: return mIn.binary<uint16_t>(mSwap, what);
    case VtkType::Int32: return mIn.binary<int32_t>(mSwap, what);
    case VtkType::UInt32: return mIn.binary<uint32_t>(mSwap, what);
    case VtkType::Int64: return mIn.binary<int64_t>(mSwap, what);
    case VtkType::UInt64: {
      const uint64_t v = mIn.binary<uint64_t>(mSwap, what);
      return v > static_cast<uint64_t>(INT64_MAX) ? -1 : static_cast<int64_t>(v);  // callers reject negatives
    }
    default: mIn.fail(std::string(what) + " must have an integer type");
  }
}

template <class Sink>
void VtkParser::readReals(const TypeInfo& type, uint64_t count, const char* what, Sink&& sink) {
  guard(type, count, what);
  if (!mBinary) {
    if (type.type == VtkType::Float32) {
      for (uint64_t i = 0; i < count; ++i) sink(i, static_cast<double>(mIn.realFloat(what)));
    } else {
      for (uint64_t i = 0; i < count; ++i) sink(i, mIn.real(what));
    }
    return;
  }
  auto loop = [&]<class T>() {
    for (uint64_t i = 0; i < count; ++i) sink(i, static_cast<double>(mIn.binary<T>(mSwap, what)));
  };
  switch (type.type) {
    case VtkType::Int8: return loop.template operator()<int8_t>();
    case VtkType::UInt8: return loop.template operator()<uint8_t>();
    case VtkType::Int16: return loop.template operator()<int16_t>();
    case VtkType::UInt16: return loop.template operator()<uint16_t>();
    case VtkType::Int32: return loop.template operator()<int32_t>();
    case VtkType::UInt32: return loop.template operator()<uint32_t>();
    case VtkType::Int64: return loop.template operator()<int64_t>();
    case VtkType::UInt64: return loop.template operator()<uint64_t>();
    case VtkType::Float32: return loop.template operator()<float>();
    case VtkType::Float64: return loop.template operator()<double>();
    default: mIn.fail(std::string(what) + ": bit arrays cannot be read as numbers");
  }
}

void VtkParser::skipValues(const TypeInfo& type, uint64_t count, const char* what) {
  guard(type, count, what);
  if (!mBinary) {
    for (uint64_t i = 0; i < count; ++i) mIn.token(what);
    return;
  }
  mIn.take(type.type == VtkType::Bit ? (count + 7) / 8 : count * type.bytes, what);
}

void VtkParser::readHeader() {
  const std::string_view first = mIn.line();
  if (lowerCase(first.substr(0, 22)) != "# vtk datafile version")
    mIn.failAt(0, "not a VTK legacy file: the first line is not '# vtk DataFile Version x.y'");
  mIn.line();  // the title, free text
  const size_t at = mIn.offset();
  std::string_view format = mIn.line();
  while (!format.empty() && (format.back() == ' ' || format.back() == '\t')) format.remove_suffix(1);
  const std::string mode = lowerCase(format);
  if (mode != "ascii" && mode != "binary")
    mIn.failAt(at, "expected ASCII or BINARY on the third line, got '" + std::string(format.substr(0, 40)) + "'");
  mBinary = mode == "binary";
  mIn.expect("DATASET");
  const size_t typeAt = (mIn.skipWhitespace(), mIn.offset());
  const std::string dataset(mIn.token("a dataset type"));
  if (lowerCase(dataset) != "unstructured_grid")
    mIn.failAt(typeAt, "DATASET " + dataset + " is not supported, only UNSTRUCTURED_GRID");
  endHeader();
}

void VtkParser::readPoints() {
  const size_t at = mIn.offset();
  if (mPoints) mIn.failAt(at, "a second POINTS section");
  const uint64_t n = static_cast<uint64_t>(mIn.integer("point count", 0, UINT32_MAX));
  const TypeInfo& type = readType("POINTS");
  endHeader();
  guard(type, 3 * n, "POINTS");
  mPoints.emplace(n);
  std::vector<glm::vec3>& points = *mPoints;
  readReals(type, 3 * n, "POINTS", [&](uint64_t i, double v) { points[i / 3][i % 3] = static_cast<float>(v); });
}

void VtkParser::readCells() {
  if (mCellStart) mIn.fail("a second CELLS section");
  const uint64_t first = static_cast<uint64_t>(mIn.integer("CELLS count", 0, UINT32_MAX));
  const uint64_t size = static_cast<uint64_t>(mIn.integer("CELLS size", 0, INT64_MAX));
  const size_t afterCounts = mIn.offset();
  const TypeInfo int32Type{"int", VtkType::Int32, 4};
  std::vector<uint64_t>& starts = mCellStart.emplace();
  if (lowerCase(mIn.peekToken()) == "offsets") {
    // VTK >= 5.1: "CELLS nOffsets nConnectivity", then the offsets (one more than the cells) and connectivity.
    mIn.expect("OFFSETS");
    const TypeInfo& offsetType = readType("OFFSETS");
    endHeader();
    guard(offsetType, first, "OFFSETS");
    starts.reserve(first);
    for (uint64_t i = 0; i < first; ++i) {
      const size_t at = mIn.offset();
      const int64_t v = integerValue(offsetType, "OFFSETS");
      const int64_t previous = starts.empty() ? 0 : static_cast<int64_t>(starts.back());
      if (i == 0 && v != 0) suspect(at, "the first offset is " + std::to_string(v) + ", not 0");
      if (v < previous || static_cast<uint64_t>(v) > size)
        suspect(at, "offset " + std::to_string(i) + " is " + std::to_string(v) + ": offsets must increase up to " +
                        "the connectivity size " + std::to_string(size));
      starts.push_back(static_cast<uint64_t>(v));
    }
    if (!starts.empty() && starts.back() != size)
      suspect(mIn.offset(), "the last offset is " + std::to_string(starts.back()) + ", but the connectivity has " +
                                std::to_string(size) + " entries");
    if (starts.empty()) starts.push_back(0);
    mIn.expect("CONNECTIVITY");
    const TypeInfo& indexType = readType("CONNECTIVITY");
    endHeader();
    guard(indexType, size, "CONNECTIVITY");
    mConnectivity.reserve(size);
    for (uint64_t i = 0; i < size; ++i) {
      const size_t at = mIn.offset();
      const int64_t v = integerValue(indexType, "CONNECTIVITY");
      if (v < 0 || v > UINT32_MAX) suspect(at, "point index " + std::to_string(v) + " is out of range");
      mConnectivity.push_back(static_cast<uint32_t>(v));
    }
    return;
  }
  // The classic layout: "CELLS n size", then per cell its point count and indices, all int.
  mIn.seek(afterCounts);
  endHeader();
  guard(int32Type, size, "CELLS");
  if (size < first) suspect(afterCounts, "CELLS size " + std::to_string(size) + " is less than its cell count");
  starts.reserve(first + 1);
  mConnectivity.reserve(size - first);
  starts.push_back(0);
  for (uint64_t c = 0; c < first; ++c) {
    const size_t at = mIn.offset();
    const uint64_t used = c + mConnectivity.size();  // values of the CELLS size the earlier cells took
    if (used + 1 > size) suspect(at, "the cells before cell " + std::to_string(c) + " fill the CELLS size");
    const int64_t n = integerValue(int32Type, "CELLS");
    const uint64_t left = size - used - 1;
    if (n < 0 || static_cast<uint64_t>(n) > left)
      suspect(at, "cell " + std::to_string(c) + " has " + std::to_string(n) + " points, but the CELLS size " +
                      std::to_string(size) + " leaves " + std::to_string(left));
    for (int64_t k = 0; k < n; ++k) {
      const size_t indexAt = mIn.offset();
      const int64_t v = integerValue(int32Type, "CELLS");
      if (v < 0) suspect(indexAt, "cell " + std::to_string(c) + " has the negative point index " + std::to_string(v));
      mConnectivity.push_back(static_cast<uint32_t>(v));
    }
    starts.push_back(mConnectivity.size());
  }
  if (first + mConnectivity.size() != size)
    suspect(mIn.offset(), "CELLS size " + std::to_string(size) + ", but the cells use " +
                              std::to_string(first + mConnectivity.size()) + " values");
}

void VtkParser::readCellTypes() {
  const size_t at = mIn.offset();
  if (!mCellStart) mIn.failAt(at, "CELL_TYPES before CELLS");
  if (mCellTypes) mIn.failAt(at, "a second CELL_TYPES section");
  const uint64_t cells = mCellStart->size() - 1;
  const uint64_t n = static_cast<uint64_t>(mIn.integer("CELL_TYPES count", 0, UINT32_MAX));
  if (n != cells) mIn.failAt(at, "CELL_TYPES has " + std::to_string(n) + " entries for " + std::to_string(cells) +
                                     " cells");
  endHeader();
  const TypeInfo int32Type{"int", VtkType::Int32, 4};
  guard(int32Type, n, "CELL_TYPES");
  std::vector<int32_t>& types = mCellTypes.emplace();
  types.reserve(n);
  for (uint64_t c = 0; c < n; ++c) {
    const size_t typeAt = mIn.offset();
    const int64_t type = integerValue(int32Type, "CELL_TYPES");
    if (!cellKind(type))
      suspect(typeAt, "cell " + std::to_string(c) + " has type " + std::to_string(type) + ", not a VTK cell type");
    types.push_back(static_cast<int32_t>(type));
  }
}

void VtkParser::skipMetadataIfPresent() {
  // VTK 8+ may follow an array with "METADATA", then INFORMATION / COMPONENT_NAMES lines, ended by a blank line.
  if (lowerCase(mIn.peekToken()) != "metadata") return;
  mIn.token();
  mIn.skipLine();
  while (!mIn.atEnd()) {
    std::string_view text = mIn.line();
    if (text.find_first_not_of(" \t") == std::string_view::npos) break;
  }
}

void VtkParser::readFieldArrays(uint64_t count, bool pointData, bool datasetLevel) {
  mIn.token("a FIELD name");
  const int64_t arrays = mIn.integer("FIELD array count", 0, 1 << 20);
  endHeader();
  for (int64_t a = 0; a < arrays; ++a) {
    const std::string name = decodeName(mIn.token("a FIELD array name"));
    if (name == "NULL_ARRAY") {
      endHeader();
      continue;
    }
    const int64_t components = mIn.integer("FIELD array components", 1, 1 << 20);
    const uint64_t tuples = static_cast<uint64_t>(mIn.integer("FIELD array tuples", 0, UINT32_MAX));
    const TypeInfo& type = readType("FIELD array");
    endHeader();
    const uint64_t values = tuples * static_cast<uint64_t>(components);
    const bool scalar = !datasetLevel && pointData && components == 1 && tuples == count;
    if (scalar && type.type != VtkType::Bit && type.type != VtkType::String && mPicker.offer(name)) {
      mScalars.resize(count);
      readReals(type, values, "FIELD array", [&](uint64_t i, double v) { mScalars[i] = static_cast<float>(v); });
    } else {
      if (!datasetLevel && !scalar)
        mPicker.noteUnusable(name, !pointData ? "cell data"
                                              : components != 1 ? std::to_string(components) + " components"
                                                                : std::to_string(tuples) + " tuples");
      skipValues(type, values, "FIELD array");
    }
    skipMetadataIfPresent();
  }
}

void VtkParser::readAttributes(uint64_t count, bool pointData) {
  for (;;) {
    const size_t at = (mIn.skipWhitespace(), mIn.offset());
    const std::string keyword = lowerCase(mIn.peekToken());
    auto skipArray = [&](uint64_t perTuple) {
      const std::string name = decodeName(mIn.token("an array name"));
      const TypeInfo& type = readType(keyword.c_str());
      endHeader();
      mPicker.noteUnusable(name, pointData ? std::to_string(perTuple) + " components" : "cell data");
      skipValues(type, count * perTuple, keyword.c_str());
    };
    if (keyword == "scalars") {
      mIn.token();
      const std::vector<std::string> words = restOfLine();  // name type [components]
      if (words.size() < 2 || words.size() > 3) mIn.failAt(at, "expected SCALARS name type [components]");
      const std::string name = decodeName(words[0]);
      const std::string typeName = lowerCase(words[1]);
      const TypeInfo* type = nullptr;
      for (const TypeInfo& info : kTypes)
        if (typeName == info.name) type = &info;
      if (!type) mIn.failAt(at, "unknown data type '" + typeName + "' for SCALARS " + name);
      int components = 1;
      if (words.size() == 3) {
        FileCursor number(mIn.name(), std::vector<char>(words[2].begin(), words[2].end()));
        try {
          components = static_cast<int>(number.integer("SCALARS components", 1, 4));
        } catch (const MeshError&) {
          mIn.failAt(at, "SCALARS " + name + ": bad component count '" + words[2] + "' (1 to 4)");
        }
      }
      const size_t beforeTable = mIn.offset();
      if (lowerCase(mIn.peekToken()) == "lookup_table") {
        mIn.token();
        mIn.token("a lookup table name");
        endHeader();
      } else {
        mIn.seek(beforeTable);  // the table line is optional here; what follows is data
      }
      const uint64_t values = count * static_cast<uint64_t>(components);
      if (pointData && components == 1 && type->type != VtkType::Bit && mPicker.offer(name)) {
        mScalars.resize(count);
        readReals(*type, values, "SCALARS", [&](uint64_t i, double v) { mScalars[i] = static_cast<float>(v); });
      } else {
        if (!pointData || components != 1)
          mPicker.noteUnusable(name, pointData ? std::to_string(components) + " components" : "cell data");
        skipValues(*type, values, "SCALARS");
      }
    } else if (keyword == "vectors" || keyword == "normals") {
      mIn.token();
      skipArray(3);
    } else if (keyword == "tensors") {
      mIn.token();
      skipArray(9);
    } else if (keyword == "tensors6") {
      mIn.token();
      skipArray(6);
    } else if (keyword == "global_ids" || keyword == "pedigree_ids") {
      mIn.token();
      skipArray(1);
    } else if (keyword == "texture_coordinates") {
      mIn.token();
      const std::string name = decodeName(mIn.token("an array name"));
      const int64_t dim = mIn.integer("texture coordinate dimension", 1, 3);
      const TypeInfo& type = readType("TEXTURE_COORDINATES");
      endHeader();
      mPicker.noteUnusable(name, pointData ? "texture coordinates" : "cell data");
      skipValues(type, count * static_cast<uint64_t>(dim), "TEXTURE_COORDINATES");
    } else if (keyword == "color_scalars" || keyword == "lookup_table") {
      // Colours are unsigned bytes in binary files, reals in ASCII ones; a table has 4 per entry.
      mIn.token();
      mIn.token("a name");
      const int64_t perTuple = mIn.integer(keyword == "lookup_table" ? "table size" : "colour components", 0,
                                           keyword == "lookup_table" ? INT32_MAX : 4);
      endHeader();
      const TypeInfo bytes{"unsigned_char", VtkType::UInt8, 1};
      skipValues(bytes, keyword == "lookup_table" ? 4 * static_cast<uint64_t>(perTuple)
                                                  : count * static_cast<uint64_t>(perTuple), "colours");
    } else if (keyword == "field") {
      mIn.token();
      readFieldArrays(count, pointData, false);
    } else if (keyword == "metadata") {
      skipMetadataIfPresent();
    } else {
      return;  // POINT_DATA, CELL_DATA or the end: the caller's keywords
    }
  }
}

TetMesh VtkParser::parse() {
  readHeader();
  for (;;) {
    const size_t at = (mIn.skipWhitespace(), mIn.offset());
    const std::string keyword = lowerCase(mIn.token());
    if (keyword.empty()) break;
    if (keyword == "points") {
      readPoints();
    } else if (keyword == "cells") {
      readCells();
    } else if (keyword == "cell_types") {
      readCellTypes();
    } else if (keyword == "point_data" || keyword == "cell_data") {
      const bool pointData = keyword == "point_data";
      const uint64_t n = static_cast<uint64_t>(mIn.integer("attribute count", 0, UINT32_MAX));
      const uint64_t expected = pointData ? (mPoints ? mPoints->size() : 0) : (mCellStart ? mCellStart->size() - 1 : 0);
      if (pointData ? !mPoints : !mCellStart) mIn.failAt(at, keyword + " before " + (pointData ? "POINTS" : "CELLS"));
      if (n != expected)
        mIn.failAt(at, keyword + " " + std::to_string(n) + " does not match the " + std::to_string(expected) +
                           (pointData ? " points" : " cells"));
      endHeader();
      readAttributes(n, pointData);
    } else if (keyword == "field") {
      readFieldArrays(0, false, true);  // data about the whole dataset (time, cycle): not per point
    } else if (keyword == "metadata") {
      mIn.seek(at);
      skipMetadataIfPresent();
    } else {
      mIn.failAt(at, "unexpected keyword '" + keyword.substr(0, 40) + "'");
    }
  }
  return assemble();
}

TetMesh VtkParser::assemble() {
  const size_t end = mIn.offset();
  if (!mPoints) mIn.failAt(end, "no POINTS section");
  if (!mCellStart) mIn.failAt(end, "no CELLS section");
  if (!mCellTypes) mIn.failAt(end, "no CELL_TYPES section");
  TetMesh mesh;
  mesh.points = std::move(*mPoints);
  const std::vector<uint64_t>& starts = *mCellStart;
  CellCensus census;
  for (size_t c = 0; c + 1 < starts.size(); ++c) {
    const int32_t type = (*mCellTypes)[c];
    const uint64_t n = starts[c + 1] - starts[c];
    const CellKind kind = *cellKind(type);
    if (type == kTetra) {
      if (n != 4)
        throw MeshError(mIn.name() + ": cell " + std::to_string(c) + " is a tetra with " + std::to_string(n) +
                        " points");
      Tet tet;
      for (int k = 0; k < 4; ++k) {
        tet[k] = mConnectivity[starts[c] + k];
        if (tet[k] >= mesh.points.size())
          throw MeshError(mIn.name() + ": cell " + std::to_string(c) + " uses point " + std::to_string(tet[k]) +
                          ", but there are " + std::to_string(mesh.points.size()) + " points");
      }
      mesh.tets.push_back(tet);
    } else if (kind.dim == 3) {
      census.refuse(std::string(kind.name) + " (VTK type " + std::to_string(type) + ")");
    }
  }
  census.throwIfRefused(mIn.name());
  mPicker.requireChosen(mIn.name());
  mesh.scalars = std::move(mScalars);
  mesh.field = mPicker.chosenName();
  return mesh;
}

}  // namespace

TetMesh readVtk(FileCursor& in, const std::string& field) {
  // Binary legacy VTK is big-endian by the format's definition, but some writers emit the machine's order. Read
  // as big-endian; if the cell structure is implausible (a cell type VTK lacks, cell sizes that do not add up to
  // the CELLS size, offsets that do not increase), read again as little-endian. Points alone could not tell: any
  // bytes are some float. When both orders fail that way, the big-endian error is the one reported.
  const size_t start = in.offset();
  try {
    return VtkParser(in, field, true).parse();
  } catch (const ByteOrderSuspect& bigEndianError) {
    in.seek(start);
    try {
      return VtkParser(in, field, false).parse();
    } catch (const ByteOrderSuspect&) {
      throw MeshError(std::string(bigEndianError.what()) + " (read as big-endian; little-endian fails too)");
    }
  }
}

}  // namespace voxbrick::mesh
