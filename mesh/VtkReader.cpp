// The VTK legacy unstructured-grid reader (readVtk in mesh/MeshReaders.h). One file of about 500 lines on purpose: the
// format's header, points, cells, cell types and attributes are read by one parser (VtkParser) whose state they share.
#include <cstdint>
#include <optional>

#include "common/EnumNames.h"
#include "mesh/MeshReaders.h"
#include "mesh/ReaderSupport.h"
#include "mesh/VtkTypes.h"

namespace voxbrick::mesh {

namespace {

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
  void readScalars(size_t at, uint64_t count, bool pointData);
  void skipArray(const std::string& keyword, uint64_t count, uint64_t perTuple, bool pointData);
  void skipColours(const std::string& keyword, uint64_t count);
  void readFieldArrays(uint64_t count, bool pointData, bool datasetLevel);
  void skipMetadataIfPresent();
  TetMesh assemble();

  VtkType readType(const char* what);
  void endHeader();
  std::vector<std::string> restOfLine();
  void guard(VtkType type, uint64_t count, const char* what);
  int64_t integerValue(VtkType type, const char* what);
  template <class Sink>
  void readReals(VtkType type, uint64_t count, const char* what, Sink&& sink);
  void skipValues(VtkType type, uint64_t count, const char* what);
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

VtkType VtkParser::readType(const char* what) {
  const size_t at = (mIn.skipWhitespace(), mIn.offset());
  const std::string name = lowerCase(mIn.token(what));
  if (const std::optional<VtkType> type = common::valueOf<VtkType>(name)) return *type;
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

void VtkParser::guard(VtkType type, uint64_t count, const char* what) {
  if (type == VtkType::String) mIn.fail(std::string("string arrays are not supported (") + what + ")");
  if (!mBinary) return mIn.requireFits(count, 2, what, 1);  // a digit and a separator, none after the last
  if (type == VtkType::Bit) return mIn.requireFits((count + 7) / 8, 1, what);
  mIn.requireFits(count, vtkTypeBytes(type), what);
}

int64_t VtkParser::integerValue(VtkType type, const char* what) {
  if (!mBinary) return mIn.integer(what);
  switch (type) {
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
void VtkParser::readReals(VtkType type, uint64_t count, const char* what, Sink&& sink) {
  guard(type, count, what);
  if (!mBinary) {
    if (type == VtkType::Float32) {
      for (uint64_t i = 0; i < count; ++i) sink(i, static_cast<double>(mIn.realFloat(what)));
    } else {
      for (uint64_t i = 0; i < count; ++i) sink(i, mIn.real(what));
    }
    return;
  }
  auto loop = [&]<class T>() {
    for (uint64_t i = 0; i < count; ++i) sink(i, static_cast<double>(mIn.binary<T>(mSwap, what)));
  };
  switch (type) {
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

void VtkParser::skipValues(VtkType type, uint64_t count, const char* what) {
  guard(type, count, what);
  if (!mBinary) {
    for (uint64_t i = 0; i < count; ++i) mIn.token(what);
    return;
  }
  mIn.take(type == VtkType::Bit ? (count + 7) / 8 : count * vtkTypeBytes(type), what);
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
  VtkType type = readType("POINTS");
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
  const VtkType int32Type = VtkType::Int32;
  std::vector<uint64_t>& starts = mCellStart.emplace();
  if (lowerCase(mIn.peekToken()) == "offsets") {
    // VTK >= 5.1: "CELLS nOffsets nConnectivity", then the offsets (one more than the cells) and connectivity.
    mIn.expect("OFFSETS");
    const VtkType offsetType = readType("OFFSETS");
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
    const VtkType indexType = readType("CONNECTIVITY");
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
  if (n != cells)
    mIn.failAt(at, "CELL_TYPES has " + std::to_string(n) + " entries for " + std::to_string(cells) + " cells");
  endHeader();
  const VtkType int32Type = VtkType::Int32;
  guard(int32Type, n, "CELL_TYPES");
  std::vector<int32_t>& types = mCellTypes.emplace();
  types.reserve(n);
  for (uint64_t c = 0; c < n; ++c) {
    const size_t typeAt = mIn.offset();
    const int64_t type = integerValue(int32Type, "CELL_TYPES");
    if (!vtkCellKind(type))
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
    const std::string name = decodeVtkName(mIn.token("a FIELD array name"));
    if (name == "NULL_ARRAY") {
      endHeader();
      continue;
    }
    const int64_t components = mIn.integer("FIELD array components", 1, 1 << 20);
    const uint64_t tuples = static_cast<uint64_t>(mIn.integer("FIELD array tuples", 0, UINT32_MAX));
    VtkType type = readType("FIELD array");
    endHeader();
    const uint64_t values = tuples * static_cast<uint64_t>(components);
    const bool scalar = !datasetLevel && pointData && components == 1 && tuples == count;
    if (scalar && type != VtkType::Bit && type != VtkType::String && mPicker.offer(name)) {
      mScalars.resize(count);
      readReals(type, values, "FIELD array", [&](uint64_t i, double v) { mScalars[i] = static_cast<float>(v); });
    } else {
      if (!datasetLevel && !scalar)
        mPicker.noteUnusable(name, !pointData        ? "cell data"
                                   : components != 1 ? std::to_string(components) + " components"
                                                     : std::to_string(tuples) + " tuples");
      skipValues(type, values, "FIELD array");
    }
    skipMetadataIfPresent();
  }
}

/// After the SCALARS keyword: "name type [components]", an optional LOOKUP_TABLE line, then the values, read as the
/// field if the picker takes it, else skipped. `at` is the keyword's offset, for errors.
void VtkParser::readScalars(size_t at, uint64_t count, bool pointData) {
  const std::vector<std::string> words = restOfLine();  // name type [components]
  if (words.size() < 2 || words.size() > 3) mIn.failAt(at, "expected SCALARS name type [components]");
  const std::string name = decodeVtkName(words[0]);
  const std::string typeName = lowerCase(words[1]);
  const std::optional<VtkType> type = common::valueOf<VtkType>(typeName);
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
  if (pointData && components == 1 && *type != VtkType::Bit && mPicker.offer(name)) {
    mScalars.resize(count);
    readReals(*type, values, "SCALARS", [&](uint64_t i, double v) { mScalars[i] = static_cast<float>(v); });
  } else {
    if (!pointData || components != 1)
      mPicker.noteUnusable(name, pointData ? std::to_string(components) + " components" : "cell data");
    skipValues(*type, values, "SCALARS");
  }
}

/// After an attribute's keyword: "name type", then `perTuple` values a tuple, skipped (not a field one can choose).
void VtkParser::skipArray(const std::string& keyword, uint64_t count, uint64_t perTuple, bool pointData) {
  const std::string name = decodeVtkName(mIn.token("an array name"));
  VtkType type = readType(keyword.c_str());
  endHeader();
  mPicker.noteUnusable(name, pointData ? std::to_string(perTuple) + " components" : "cell data");
  skipValues(type, count * perTuple, keyword.c_str());
}

/// After COLOR_SCALARS or LOOKUP_TABLE: skips the colours, unsigned bytes in binary files and reals in ASCII ones;
/// a table has 4 per entry.
void VtkParser::skipColours(const std::string& keyword, uint64_t count) {
  mIn.token("a name");
  const int64_t perTuple = mIn.integer(keyword == "lookup_table" ? "table size" : "colour components", 0,
                                       keyword == "lookup_table" ? INT32_MAX : 4);
  endHeader();
  const VtkType bytes = VtkType::UInt8;
  skipValues(bytes,
             keyword == "lookup_table" ? 4 * static_cast<uint64_t>(perTuple) : count * static_cast<uint64_t>(perTuple),
             "colours");
}

void VtkParser::readAttributes(uint64_t count, bool pointData) {
  for (;;) {
    const size_t at = (mIn.skipWhitespace(), mIn.offset());
    const std::string keyword = lowerCase(mIn.peekToken());
    if (keyword == "scalars") {
      mIn.token();
      readScalars(at, count, pointData);
    } else if (keyword == "vectors" || keyword == "normals") {
      mIn.token();
      skipArray(keyword, count, 3, pointData);
    } else if (keyword == "tensors") {
      mIn.token();
      skipArray(keyword, count, 9, pointData);
    } else if (keyword == "tensors6") {
      mIn.token();
      skipArray(keyword, count, 6, pointData);
    } else if (keyword == "global_ids" || keyword == "pedigree_ids") {
      mIn.token();
      skipArray(keyword, count, 1, pointData);
    } else if (keyword == "texture_coordinates") {
      mIn.token();
      const std::string name = decodeVtkName(mIn.token("an array name"));
      const int64_t dim = mIn.integer("texture coordinate dimension", 1, 3);
      VtkType type = readType("TEXTURE_COORDINATES");
      endHeader();
      mPicker.noteUnusable(name, pointData ? "texture coordinates" : "cell data");
      skipValues(type, count * static_cast<uint64_t>(dim), "TEXTURE_COORDINATES");
    } else if (keyword == "color_scalars" || keyword == "lookup_table") {
      mIn.token();
      skipColours(keyword, count);
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
  mesh.tets.reserve(starts.size() - 1);
  CellCensus census;
  for (size_t c = 0; c + 1 < starts.size(); ++c) {
    const int32_t type = (*mCellTypes)[c];
    const uint64_t n = starts[c + 1] - starts[c];
    const VtkCellKind kind = *vtkCellKind(type);
    if (type == kVtkTetra) {
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
    } else {
      const std::string name = std::string(kind.name) + " (VTK type " + std::to_string(type) + ")";
      kind.dim == 3 ? census.refuse(name) : census.drop(name);
    }
  }
  census.throwIfRefused(mIn.name());
  mPicker.requireChosen(mIn.name());
  mesh.scalars = std::move(mScalars);
  mesh.field = mPicker.chosenName();
  mesh.dropped = census.dropped();
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
