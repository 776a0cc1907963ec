// The gmsh reader (readGmsh in mesh/MeshReaders.h): MSH 2.x and 4.1, ASCII and binary.
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <unordered_map>
#include <utility>

#include "mesh/MeshReaders.h"
#include "mesh/ReaderSupport.h"

namespace voxbrick::mesh {

namespace {

constexpr int kTetrahedron = 4;

struct GmshKind {
  const char* name;
  int nodes;
  int dim;
};

// gmsh's element types by number (the reference manual's list): the node count is needed to step over elements
// we do not keep, the dimension decides between dropping (boundary and point tags) and refusing.
std::optional<GmshKind> gmshKind(int64_t type) {
  static const std::pair<int, GmshKind> kKinds[] = {{1, {"line", 2, 1}},
                                                    {2, {"triangle", 3, 2}},
                                                    {3, {"quadrangle", 4, 2}},
                                                    {4, {"tetrahedron", 4, 3}},
                                                    {5, {"hexahedron", 8, 3}},
                                                    {6, {"prism", 6, 3}},
                                                    {7, {"pyramid", 5, 3}},
                                                    {8, {"3-node line", 3, 1}},
                                                    {9, {"6-node triangle", 6, 2}},
                                                    {10, {"9-node quadrangle", 9, 2}},
                                                    {11, {"10-node tetrahedron", 10, 3}},
                                                    {12, {"27-node hexahedron", 27, 3}},
                                                    {13, {"18-node prism", 18, 3}},
                                                    {14, {"14-node pyramid", 14, 3}},
                                                    {15, {"point", 1, 0}},
                                                    {16, {"8-node quadrangle", 8, 2}},
                                                    {17, {"20-node hexahedron", 20, 3}},
                                                    {18, {"15-node prism", 15, 3}},
                                                    {19, {"13-node pyramid", 13, 3}},
                                                    {20, {"9-node triangle", 9, 2}},
                                                    {21, {"10-node triangle", 10, 2}},
                                                    {22, {"12-node triangle", 12, 2}},
                                                    {23, {"15-node triangle", 15, 2}},
                                                    {24, {"15-node incomplete triangle", 15, 2}},
                                                    {25, {"21-node triangle", 21, 2}},
                                                    {26, {"4-node line", 4, 1}},
                                                    {27, {"5-node line", 5, 1}},
                                                    {28, {"6-node line", 6, 1}},
                                                    {29, {"20-node tetrahedron", 20, 3}},
                                                    {30, {"35-node tetrahedron", 35, 3}},
                                                    {31, {"56-node tetrahedron", 56, 3}},
                                                    {92, {"64-node hexahedron", 64, 3}},
                                                    {93, {"125-node hexahedron", 125, 3}}};
  for (const auto& [number, kind] : kKinds)
    if (number == type) return kind;
  return std::nullopt;
}

constexpr uint32_t kNoIndex = std::numeric_limits<uint32_t>::max();

// gmsh node tags are arbitrary positive numbers, often but not always 1..n: a dense table when they are compact,
// a hash map when they are sparse (so a tag of 10^12 costs no memory).
class NodeIndex {
 public:
  void build(const std::vector<uint64_t>& tags, const FileCursor& in, size_t at) {
    uint64_t maxTag = 0;
    for (uint64_t t : tags) maxTag = std::max(maxTag, t);
    mDense.clear();
    mSparse.clear();
    mIsDense = maxTag <= 2 * static_cast<uint64_t>(tags.size()) + 1024;
    if (mIsDense) mDense.assign(maxTag + 1, kNoIndex);
    for (size_t i = 0; i < tags.size(); ++i) {
      const bool fresh = mIsDense ? std::exchange(mDense[tags[i]], static_cast<uint32_t>(i)) == kNoIndex
                                  : mSparse.emplace(tags[i], static_cast<uint32_t>(i)).second;
      if (!fresh) in.failAt(at, "node tag " + std::to_string(tags[i]) + " is defined twice");
    }
  }
  uint32_t find(uint64_t tag) const {
    if (mIsDense) return tag < mDense.size() ? mDense[tag] : kNoIndex;
    auto it = mSparse.find(tag);
    return it == mSparse.end() ? kNoIndex : it->second;
  }

 private:
  bool mIsDense = true;
  std::vector<uint32_t> mDense;
  std::unordered_map<uint64_t, uint32_t> mSparse;
};

class GmshParser {
 public:
  GmshParser(FileCursor& in, const std::string& field) : mIn(in), mPicker(field) {}
  TetMesh parse();

 private:
  void readFormat();
  void readNodes2();
  void readElements2();
  void readNodes4();
  void readElements4();
  void readData(const std::string& section);
  void skipSection(const std::string& name);
  void endSection(const std::string& name) { mIn.expect("$End" + name); }
  void endHeaderLine();
  void requireOneLine(size_t start, uint64_t tag);
  void addElement(const GmshKind& kind, int64_t type, const std::vector<uint64_t>& nodes, uint64_t tag, size_t at);
  void requireNodes(size_t at, const char* section) const {
    if (!mHaveNodes) mIn.failAt(at, std::string(section) + " before $Nodes");
  }

  // Values as the format stores them: text in ASCII files, fixed-size binary in binary ones.
  int64_t intValue(const char* what, int64_t lo = INT32_MIN, int64_t hi = INT32_MAX);
  uint64_t sizeValue(const char* what);
  double doubleValue(const char* what) { return mBinary ? mIn.binary<double>(mSwap, what) : mIn.real(what); }
  /// Bytes (binary) or text bytes (ASCII: a digit and a separator per value) that `count` values need at least.
  void guard(uint64_t count, uint64_t binaryBytesEach, uint64_t valuesEach, const char* what) const;

  FileCursor& mIn;
  FieldPicker mPicker;
  int mVersion = 0;  // 2 or 4 (4.1)
  bool mBinary = false;
  bool mSwap = false;
  int mSizeT = 8;  // bytes of a size_t in a binary 4.1 file
  bool mHaveNodes = false;
  bool mHaveElements = false;
  std::vector<glm::vec3> mPoints;
  std::vector<uint64_t> mNodeTags;
  NodeIndex mIndex;
  std::vector<Tet> mTets;
  CellCensus mCensus;
  std::vector<float> mScalars;
};

int64_t GmshParser::intValue(const char* what, int64_t lo, int64_t hi) {
  const size_t at = mIn.offset();
  const int64_t v = mBinary ? mIn.binary<int32_t>(mSwap, what) : mIn.integer(what, INT64_MIN, INT64_MAX);
  if (v < lo || v > hi)
    mIn.failAt(at, std::string(what) + " " + std::to_string(v) + " is out of range [" + std::to_string(lo) + ", " +
                       std::to_string(hi) + "]");
  return v;
}

uint64_t GmshParser::sizeValue(const char* what) {
  if (!mBinary) return static_cast<uint64_t>(mIn.integer(what, 0, INT64_MAX));
  return mSizeT == 8 ? mIn.binary<uint64_t>(mSwap, what) : mIn.binary<uint32_t>(mSwap, what);
}

void GmshParser::guard(uint64_t count, uint64_t binaryBytesEach, uint64_t valuesEach, const char* what) const {
  if (mBinary) return mIn.requireFits(count, binaryBytesEach, what);
  mIn.requireFits(count, 2 * valuesEach, what, 1);
}

void GmshParser::endHeaderLine() {
  // In binary files the data starts right after the line end.
  if (!mBinary) return;
  const size_t at = mIn.offset();
  std::string_view rest = mIn.line();
  if (rest.find_first_not_of(" \t") != std::string_view::npos) mIn.failAt(at, "unexpected text before binary data");
}

void GmshParser::skipSection(const std::string& name) {
  // gmsh's rule: a reader ignores sections it does not know ($Comments, $Periodic, $Entities for us).
  const std::string end = "$End" + name;
  const size_t found = mIn.view(mIn.offset()).find(end);
  if (found == std::string_view::npos) mIn.fail("section $" + name + " has no " + end);
  mIn.seek(mIn.offset() + found + end.size());
}

void GmshParser::readFormat() {
  const size_t at = (mIn.skipWhitespace(), mIn.offset());
  const std::string version(mIn.token("a format version"));
  const std::string major = version.substr(0, version.find('.'));
  if (major == "2") {
    mVersion = 2;
  } else if (version == "4.1") {
    mVersion = 4;
  } else {
    mIn.failAt(at, "gmsh format " + version + " is not supported (2.x and 4.1 are; gmsh -save -format msh41)");
  }
  mBinary = mIn.integer("file type", 0, 1) == 1;
  const size_t sizeAt = (mIn.skipWhitespace(), mIn.offset());
  const int64_t dataSize = mIn.integer("data size", 1, 64);
  if (mVersion == 2 && dataSize != 8)
    mIn.failAt(sizeAt, "data size " + std::to_string(dataSize) + ": MSH 2 files must store 8-byte reals");
  if (mVersion == 4 && dataSize != 8 && dataSize != 4)
    mIn.failAt(sizeAt, "data size " + std::to_string(dataSize) + ": MSH 4.1 size_t must have 4 or 8 bytes");
  mSizeT = static_cast<int>(dataSize);
  if (mBinary) {
    endHeaderLine();
    // The writer's int 1, in its byte order: the one check of endianness the format has.
    const size_t oneAt = mIn.offset();
    const int32_t one = mIn.binary<int32_t>(false, "the endianness check");
    if (one != 1 && one != 0x01000000)
      mIn.failAt(oneAt, "the binary endianness check is " + std::to_string(one) + ", not 1");
    mSwap = one != 1;
  }
  endSection("MeshFormat");
}

void GmshParser::readNodes2() {
  const size_t at = mIn.offset();
  const uint64_t n = static_cast<uint64_t>(mIn.integer("node count", 0, kNoIndex - 1));
  endHeaderLine();
  guard(n, 4 + 3 * 8, 4, "$Nodes");
  mPoints.resize(n);
  mNodeTags.resize(n);
  for (uint64_t i = 0; i < n; ++i) {
    mNodeTags[i] = static_cast<uint64_t>(intValue("node tag", 1, INT64_MAX));
    for (int k = 0; k < 3; ++k) mPoints[i][k] = static_cast<float>(doubleValue("node coordinate"));
  }
  mIndex.build(mNodeTags, mIn, at);
  endSection("Nodes");
}

void GmshParser::readNodes4() {
  const size_t at = mIn.offset();
  endHeaderLine();
  const uint64_t blocks = sizeValue("entity block count");
  const uint64_t n = sizeValue("node count");
  sizeValue("min node tag");
  sizeValue("max node tag");
  if (n >= kNoIndex) mIn.failAt(at, "node count " + std::to_string(n) + " is too large");
  guard(blocks, 12 + static_cast<uint64_t>(mSizeT), 4, "$Nodes entity blocks");
  guard(n, static_cast<uint64_t>(mSizeT) + 3 * 8, 4, "$Nodes");
  mPoints.reserve(n);
  mNodeTags.reserve(n);
  for (uint64_t b = 0; b < blocks; ++b) {
    const size_t blockAt = mIn.offset();
    const int64_t dim = intValue("entity dimension", 0, 3);
    intValue("entity tag");
    const int64_t parametric = intValue("parametric flag", 0, 1);
    const uint64_t count = sizeValue("nodes in block");
    if (count > n - mPoints.size())
      mIn.failAt(blockAt, "entity block " + std::to_string(b) + " has " + std::to_string(count) +
                              " nodes, more than the header's " + std::to_string(n) + " leave");
    for (uint64_t i = 0; i < count; ++i) mNodeTags.push_back(sizeValue("node tag"));
    const int64_t extra = parametric ? dim : 0;  // u, v, w after x, y, z
    for (uint64_t i = 0; i < count; ++i) {
      glm::vec3 p;
      for (int k = 0; k < 3; ++k) p[k] = static_cast<float>(doubleValue("node coordinate"));
      for (int64_t k = 0; k < extra; ++k) doubleValue("parametric coordinate");
      mPoints.push_back(p);
    }
  }
  if (mPoints.size() != n)
    mIn.failAt(at, "the entity blocks hold " + std::to_string(mPoints.size()) + " nodes, the header says " +
                       std::to_string(n));
  for (uint64_t tag : mNodeTags)
    if (tag == 0) mIn.failAt(at, "node tag 0 (tags start at 1)");
  mIndex.build(mNodeTags, mIn, at);
  endSection("Nodes");
}

/// An ASCII element is one line: its numbers may neither run onto the next line (a number missing: the next
/// element's would be read as its node) nor leave some on this one.
void GmshParser::requireOneLine(size_t start, uint64_t tag) {
  if (mBinary) return;
  std::string_view from = mIn.view(start);
  const size_t lead = std::min(from.find_first_not_of(" \t\r\n"), mIn.offset() - start);  // the previous line's end
  from.remove_prefix(lead);
  start += lead;
  const size_t used = mIn.offset() - start, end = std::min(from.find('\n'), from.size());
  if (end < used)
    mIn.failAt(start, "element " + std::to_string(tag) + " has fewer numbers than its type needs (its line ends)");
  if (from.substr(used, end - used).find_first_not_of(" \t\r") != std::string_view::npos)
    mIn.failAt(start, "element " + std::to_string(tag) + " has more numbers than its type needs");
}

void GmshParser::addElement(const GmshKind& kind, int64_t type, const std::vector<uint64_t>& nodes, uint64_t tag,
                            size_t at) {
  if (type != kTetrahedron) {
    // Points, lines and surface elements are boundary and region tags, not volume: dropped, and counted for a note.
    const std::string name = std::string(kind.name) + " (gmsh type " + std::to_string(type) + ")";
    kind.dim < 3 ? mCensus.drop(name) : mCensus.refuse(name);
    return;
  }
  Tet tet;
  for (int k = 0; k < 4; ++k) {
    tet[k] = mIndex.find(nodes[k]);
    if (tet[k] == kNoIndex)
      mIn.failAt(at, "element " + std::to_string(tag) + " uses node tag " + std::to_string(nodes[k]) +
                         ", which $Nodes does not define");
  }
  mTets.push_back(tet);
}

void GmshParser::readElements2() {
  const size_t at = mIn.offset();
  requireNodes(at, "$Elements");
  const uint64_t n = static_cast<uint64_t>(mIn.integer("element count", 0, INT64_MAX));
  endHeaderLine();
  guard(n, 4 * 4, 4, "$Elements");
  std::vector<uint64_t> nodes;
  if (!mBinary) {
    for (uint64_t e = 0; e < n; ++e) {
      const size_t elementAt = (mIn.skipWhitespace(), mIn.offset());
      const uint64_t tag = static_cast<uint64_t>(mIn.integer("element tag", 0, INT64_MAX));
      const size_t typeAt = (mIn.skipWhitespace(), mIn.offset());
      const int64_t type = mIn.integer("element type");
      const std::optional<GmshKind> kind = gmshKind(type);
      if (!kind) mIn.failAt(typeAt, "unknown gmsh element type " + std::to_string(type));
      const int64_t tags = mIn.integer("element tag count", 0, 1000);
      for (int64_t t = 0; t < tags; ++t) mIn.token("an element tag");
      nodes.resize(static_cast<size_t>(kind->nodes));
      for (uint64_t& node : nodes) node = static_cast<uint64_t>(mIn.integer("node tag", 1, INT64_MAX));
      requireOneLine(elementAt, tag);
      addElement(*kind, type, nodes, tag, elementAt);
    }
  } else {
    // Binary MSH 2: runs of elements of one type, each run headed by (type, count, tags per element).
    for (uint64_t done = 0; done < n;) {
      const size_t runAt = mIn.offset();
      const int64_t type = intValue("element type");
      const int64_t count = intValue("elements in run", 1, INT32_MAX);
      const int64_t tags = intValue("element tag count", 0, 1000);
      const std::optional<GmshKind> kind = gmshKind(type);
      if (!kind) mIn.failAt(runAt, "unknown gmsh element type " + std::to_string(type));
      if (static_cast<uint64_t>(count) > n - done)
        mIn.failAt(runAt,
                   "a run of " + std::to_string(count) + " elements exceeds the element count " + std::to_string(n));
      guard(static_cast<uint64_t>(count), 4 * static_cast<uint64_t>(1 + tags + kind->nodes), 0, "$Elements");
      nodes.resize(static_cast<size_t>(kind->nodes));
      for (int64_t e = 0; e < count; ++e) {
        const size_t elementAt = mIn.offset();
        const uint64_t tag = static_cast<uint64_t>(intValue("element tag", 0, INT32_MAX));
        mIn.take(4 * static_cast<size_t>(tags), "element tags");
        for (uint64_t& node : nodes) node = static_cast<uint64_t>(intValue("node tag", 1, INT32_MAX));
        addElement(*kind, type, nodes, tag, elementAt);
      }
      done += static_cast<uint64_t>(count);
    }
  }
  endSection("Elements");
}

void GmshParser::readElements4() {
  const size_t at = mIn.offset();
  requireNodes(at, "$Elements");
  endHeaderLine();
  const uint64_t blocks = sizeValue("entity block count");
  const uint64_t n = sizeValue("element count");
  sizeValue("min element tag");
  sizeValue("max element tag");
  const uint64_t sizeT = static_cast<uint64_t>(mSizeT);
  guard(blocks, 12 + sizeT, 4, "$Elements entity blocks");
  guard(n, 2 * sizeT, 2, "$Elements");
  std::vector<uint64_t> nodes;
  uint64_t done = 0;
  for (uint64_t b = 0; b < blocks; ++b) {
    const size_t blockAt = mIn.offset();
    intValue("entity dimension", 0, 3);
    intValue("entity tag");
    const int64_t type = intValue("element type");
    const uint64_t count = sizeValue("elements in block");
    const std::optional<GmshKind> kind = gmshKind(type);
    if (!kind) mIn.failAt(blockAt, "unknown gmsh element type " + std::to_string(type));
    if (count > n - done)
      mIn.failAt(blockAt, "entity block " + std::to_string(b) + " has " + std::to_string(count) +
                              " elements, more than the header's " + std::to_string(n) + " leave");
    const uint64_t values = 1 + static_cast<uint64_t>(kind->nodes);
    guard(count, sizeT * values, values, "$Elements block");
    nodes.resize(static_cast<size_t>(kind->nodes));
    for (uint64_t e = 0; e < count; ++e) {
      const size_t elementAt = mIn.offset();
      const uint64_t tag = sizeValue("element tag");
      for (uint64_t& node : nodes) node = sizeValue("node tag");
      requireOneLine(elementAt, tag);
      addElement(*kind, type, nodes, tag, elementAt);
    }
    done += count;
  }
  if (done != n)
    mIn.failAt(at,
               "the entity blocks hold " + std::to_string(done) + " elements, the header says " + std::to_string(n));
  endSection("Elements");
}

void GmshParser::readData(const std::string& section) {
  const size_t at = mIn.offset();
  std::vector<std::string> strings(static_cast<size_t>(mIn.integer("string tag count", 0, 1000)));
  for (std::string& text : strings) {
    mIn.skipWhitespace();
    std::string_view line = mIn.line();
    while (!line.empty() && (line.back() == ' ' || line.back() == '\t')) line.remove_suffix(1);
    if (line.size() >= 2 && line.front() == '"' && line.back() == '"') line = line.substr(1, line.size() - 2);
    text = line;
  }
  const int64_t reals = mIn.integer("real tag count", 0, 1000);
  for (int64_t r = 0; r < reals; ++r) mIn.real("real tag");
  std::vector<int64_t> ints(static_cast<size_t>(mIn.integer("integer tag count", 0, 1000)));
  for (int64_t& value : ints) value = mIn.integer("integer tag");
  const std::string name = strings.empty() ? std::string() : strings[0];
  if (section != "NodeData") {
    mPicker.noteUnusable(name, "element data");
    return skipSection(section);
  }
  if (ints.size() < 3) mIn.failAt(at, "$NodeData needs 3 integer tags (time step, components, count)");
  const int64_t components = ints[1];
  const int64_t count = ints[2];
  if (components < 1 || components > 1000)
    mIn.failAt(at, "$NodeData has " + std::to_string(components) + " components");
  if (count < 0 || count > static_cast<int64_t>(kNoIndex))
    mIn.failAt(at, "$NodeData count " + std::to_string(count) + " is out of range");
  endHeaderLine();
  const uint64_t entries = static_cast<uint64_t>(count);
  const uint64_t perEntry = 1 + static_cast<uint64_t>(components);
  guard(entries, 4 + 8 * static_cast<uint64_t>(components), perEntry, "$NodeData");
  if (components != 1) mPicker.noteUnusable(name, std::to_string(components) + " components");
  if (components == 1 && mPicker.offer(name)) {
    requireNodes(at, "$NodeData");
    mScalars.assign(mPoints.size(), std::numeric_limits<float>::quiet_NaN());
    std::vector<uint8_t> seen(mPoints.size(), 0);
    size_t filled = 0;
    for (uint64_t e = 0; e < entries; ++e) {
      const size_t entryAt = mIn.offset();
      // The node tag is an int in binary files of either version.
      const uint64_t tag = static_cast<uint64_t>(intValue("node tag", 1, mBinary ? INT32_MAX : INT64_MAX));
      const uint32_t index = mIndex.find(tag);
      if (index == kNoIndex) mIn.failAt(entryAt, "a value for node tag " + std::to_string(tag) + ", not defined");
      mScalars[index] = static_cast<float>(doubleValue("node value"));
      filled += seen[index] == 0;
      seen[index] = 1;
    }
    if (filled != mPoints.size())
      mIn.failAt(at, "view '" + name + "' gives values for " + std::to_string(filled) + " of the " +
                         std::to_string(mPoints.size()) + " nodes");
  } else if (mBinary) {
    mIn.take(static_cast<size_t>(entries * (4 + 8 * static_cast<uint64_t>(components))), "$NodeData");
  } else {
    for (uint64_t v = 0; v < entries * perEntry; ++v) mIn.token("a $NodeData value");
  }
  endSection(section);
}

TetMesh GmshParser::parse() {
  bool haveFormat = false;
  for (;;) {
    const size_t at = (mIn.skipWhitespace(), mIn.offset());
    const std::string_view token = mIn.token();
    if (token.empty()) break;
    if (token[0] != '$')
      mIn.failAt(at, "expected a section such as $Nodes, got '" + std::string(token.substr(0, 40)) + "'");
    const std::string name(token.substr(1));
    if (!haveFormat) {
      if (name != "MeshFormat") mIn.failAt(at, "a gmsh file starts with $MeshFormat");
      readFormat();
      haveFormat = true;
    } else if (name == "MeshFormat" || name.starts_with("End")) {
      mIn.failAt(at, "unexpected $" + name.substr(0, 40));
    } else if (name == "Nodes") {
      if (mHaveNodes) mIn.failAt(at, "a second $Nodes section");
      mVersion == 2 ? readNodes2() : readNodes4();
      mHaveNodes = true;
    } else if (name == "Elements") {
      if (mHaveElements) mIn.failAt(at, "a second $Elements section");
      mVersion == 2 ? readElements2() : readElements4();
      mHaveElements = true;
    } else if (name == "NodeData" || name == "ElementData" || name == "ElementNodeData") {
      readData(name);
    } else {
      skipSection(name);
    }
  }
  if (!haveFormat) mIn.failAt(0, "empty file, expected $MeshFormat");
  if (!mHaveNodes) mIn.fail("no $Nodes section");
  if (!mHaveElements) mIn.fail("no $Elements section");
  mCensus.throwIfRefused(mIn.name());
  mPicker.requireChosen(mIn.name());
  TetMesh mesh;
  mesh.points = std::move(mPoints);
  mesh.tets = std::move(mTets);
  mesh.scalars = std::move(mScalars);
  mesh.field = mPicker.chosenName();
  mesh.dropped = mCensus.dropped();
  return mesh;
}

}  // namespace

TetMesh readGmsh(FileCursor& in, const std::string& field) { return GmshParser(in, field).parse(); }

}  // namespace voxbrick::mesh
