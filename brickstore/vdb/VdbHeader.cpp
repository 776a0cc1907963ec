// Bounds check of an OpenVDB file's header (see VdbHeader.h). The layout is OpenVDB's (io/Archive.cc readHeader,
// io/GridDescriptor.cc, MetaMap::readMeta, io/DelayedLoadMetadata.cc readValue, math/Transform.cc read): little-endian
// integers, strings as a uint32 length and that many bytes.
#include "brickstore/vdb/VdbHeader.h"

#include <openvdb/version.h>
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>

#include "brickstore/format/Errors.h"

namespace voxbrick::store {
namespace {

constexpr int64_t kVdbMagic = 0x56444220;             // "VDB " as OpenVDB writes it, an int64
constexpr uint32_t kOldestVersion = 221;              // OpenVDB refuses older files
constexpr uint32_t kPerGridCompressionVersion = 222;  // from here on, compression flags are stored per grid
constexpr uint32_t kKnownCompressionFlags = 0x7;      // zip, active mask, blosc
constexpr uint64_t kLeafTopologyBytes = 64;           // a leaf's value mask: the least a leaf takes in a file
constexpr uint64_t kBloscHeaderBytes = 16;
constexpr uint64_t kBloscPadBytes = 128;  // OpenVDB pads a table of under 48 bytes to this before compressing it
constexpr uint32_t kNoCompressedSizes = 0xFFFFFFFF;  // delayed-load metadata without compressed sizes

/// Value sizes of OpenVDB's fixed-size metadata types: it reads that many bytes whatever size the file records.
const std::map<std::string, uint32_t>& fixedMetadataSizes() {
  static const std::map<std::string, uint32_t> sizes = {
      {"bool", 1},   {"half", 2},   {"int32", 4},   {"int64", 8},   {"float", 4},  {"double", 8}, {"vec2i", 8},
      {"vec2s", 8},  {"vec2d", 16}, {"vec3i", 12},  {"vec3s", 12},  {"vec3d", 24}, {"vec4i", 16}, {"vec4s", 16},
      {"vec4d", 32}, {"mat4s", 64}, {"mat4d", 128}, {"ptidx32", 4}, {"ptidx64", 8}};
  return sizes;
}

/// A cursor over the file with a limit: the end of the file, or of the grid being checked.
class HeaderReader {
 public:
  explicit HeaderReader(const std::string& path) : mPath(path), mIn(path, std::ios::binary | std::ios::ate) {
    if (!mIn) throw IoError(errnoMessage(path));
    mSize = uint64_t(mIn.tellg());
    mIn.seekg(0);
    limit = mSize;
  }

  uint64_t pos = 0;
  uint64_t limit = 0;
  uint64_t size() const { return mSize; }
  uint64_t left() const { return limit > pos ? limit - pos : 0; }

  [[noreturn]] void fail(const std::string& why) const {
    throw InputError(mPath + ": not a readable OpenVDB file (" + why + ")");
  }
  /// Throws unless `n` more bytes lie before the limit: `field` claims more than the file can hold.
  void need(uint64_t n, const std::string& field) const {
    if (n > left())
      fail(field + " " + std::to_string(n) + " exceeds the " + std::to_string(left()) + " bytes left " + where() +
           " at byte " + std::to_string(pos));
  }
  void read(void* dst, uint64_t n, const std::string& field) {
    if (n > left()) fail(field + " at byte " + std::to_string(pos) + " lies past the end " + where() + " (truncated?)");
    mIn.seekg(std::streamoff(pos));
    mIn.read(static_cast<char*>(dst), std::streamsize(n));
    if (!mIn) throw IoError(errnoMessage(mPath));
    pos += n;
  }
  uint32_t u32(const std::string& field) {
    unsigned char b[4];
    read(b, 4, field);
    return uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24;
  }
  int64_t i64(const std::string& field) {
    const uint64_t lo = u32(field), hi = u32(field);
    return int64_t(hi << 32 | lo);
  }
  void skip(uint64_t n, const std::string& field) {
    need(n, field);
    pos += n;
  }
  /// A string: its length bounded by the bytes left; the first kKeep characters returned (for messages).
  std::string string(const std::string& field) {
    const uint32_t length = u32(field + " length");
    need(length, field + " length");
    std::string text(std::min<uint64_t>(length, kKeep), '\0');
    read(text.data(), text.size(), field);
    pos += length - text.size();
    for (char& c : text)
      if (c < 0x20 || c > 0x7e) c = '?';  // a damaged file can put any bytes into a name
    return text;
  }

 private:
  static constexpr uint64_t kKeep = 256;
  std::string where() const { return limit == mSize ? "in the file" : "in the grid"; }

  std::string mPath;
  std::ifstream mIn;
  uint64_t mSize = 0;
};

/// A blosc-compressed table of `count` entries of `entryBytes`: its uncompressed size (blosc's header) must be
/// that of the table (or of OpenVDB's padding of a small one), as OpenVDB reserves that much before it decompresses.
void checkBloscTable(HeaderReader& r, uint32_t bytes, uint64_t count, uint64_t entryBytes, const std::string& field) {
  r.need(bytes, field + " compressed size");
  if (bytes < kBloscHeaderBytes)
    r.fail(field + " compressed size " + std::to_string(bytes) + " is below blosc's header");
  const uint64_t start = r.pos;
  r.pos += 4;
  const uint32_t uncompressed = r.u32(field + " uncompressed size");
  if (uncompressed > std::max(count * entryBytes, kBloscPadBytes))
    r.fail(field + " uncompressed size " + std::to_string(uncompressed) + " exceeds its " + std::to_string(count) +
           " entries of " + std::to_string(entryBytes) + " bytes");
  r.pos = start + bytes;
}

/// OpenVDB's delayed-load metadata: a leaf count, then a mask byte and a compressed size per leaf, each table raw or
/// blosc-compressed. OpenVDB resizes both tables to the count before reading them.
void checkDelayedLoad(HeaderReader& r, uint32_t valueBytes, const std::string& field) {
  r.need(valueBytes, field + " size");
  const uint64_t end = r.pos + valueBytes, savedLimit = r.limit;
  if (valueBytes == 0) return;
  r.limit = end;
  const uint32_t count = r.u32(field + " leaf count");
  if (count > r.size() / kLeafTopologyBytes)
    r.fail(field + " leaf count " + std::to_string(count) + " exceeds the " +
           std::to_string(r.size() / kLeafTopologyBytes) + " leaves a file of " + std::to_string(r.size()) +
           " bytes can hold");
  const uint32_t maskBytes = r.u32(field + " mask size");
  if (maskBytes > 0)
    checkBloscTable(r, maskBytes, count, 1, field + " mask");
  else
    r.skip(count, field + " mask");
  const uint32_t sizesBytes = r.u32(field + " compressed sizes size");
  if (sizesBytes > 0 && sizesBytes != kNoCompressedSizes)
    checkBloscTable(r, sizesBytes, count, 8, field + " compressed sizes");
  else if (sizesBytes == 0)
    r.skip(uint64_t(count) * 8, field + " compressed sizes");
  r.pos = end;
  r.limit = savedLimit;
}

/// A MetaMap: a count, then per entry a name, a type name and a value of a recorded size.
void checkMetaMap(HeaderReader& r, const std::string& owner) {
  const uint32_t count = r.u32(owner + " metadata count");
  const uint64_t leastEntry = 12;  // two empty strings and a value size
  if (count > r.left() / leastEntry)
    r.fail(owner + " metadata count " + std::to_string(count) + " exceeds what the " + std::to_string(r.left()) +
           " bytes left at byte " + std::to_string(r.pos) + " can hold");
  for (uint32_t i = 0; i < count; ++i) {
    const std::string item = owner + " metadata " + std::to_string(i);
    const std::string name = r.string(item + " name");
    const std::string field = owner + " metadata '" + name + "'";
    const std::string type = r.string(field + " type name");
    const uint32_t valueBytes = r.u32(field + " value size");
    const auto fixed = fixedMetadataSizes().find(type);
    if (type == "__delayedload") {
      checkDelayedLoad(r, valueBytes, field);
    } else if (fixed != fixedMetadataSizes().end() && valueBytes != fixed->second) {
      r.fail(field + " (" + type + ") value size " + std::to_string(valueBytes) + ", expected " +
             std::to_string(fixed->second));
    } else {
      r.skip(valueBytes, field + " value size");
    }
  }
}

/// What the file header says the rest of the file holds.
struct FileHeader {
  uint32_t version = 0;
  bool hasGridOffsets = false;
};

FileHeader checkFileHeader(HeaderReader& r) {
  if (r.size() < 8) r.fail("the file has " + std::to_string(r.size()) + " bytes, too few for a header");
  if (r.i64("magic number") != kVdbMagic) r.fail("no VDB magic number at byte 0");
  FileHeader h;
  h.version = r.u32("file format version");
  if (h.version < kOldestVersion)
    r.fail("file format version " + std::to_string(h.version) + " is older than " + std::to_string(kOldestVersion));
  // A newer format than this OpenVDB writes is one it cannot know the layout of (OpenVDB itself reads on).
  if (h.version > openvdb::OPENVDB_FILE_VERSION)
    r.fail("file format version " + std::to_string(h.version) + " is newer than this OpenVDB reads (" +
           std::to_string(openvdb::OPENVDB_FILE_VERSION) + ")");
  r.skip(8, "library version");
  char flag = 0;
  r.read(&flag, 1, "grid offsets flag");
  h.hasGridOffsets = flag != 0;
  if (h.version < kPerGridCompressionVersion) r.skip(1, "compression flag");
  r.skip(36, "UUID");
  return h;
}

/// One grid: its descriptor, compression flags, metadata and transform type name. Returns false when the next
/// grid cannot be found without reading this one's tree (a file written as a stream, without grid offsets).
bool checkGrid(HeaderReader& r, const FileHeader& h, int32_t index) {
  const std::string at = "grid " + std::to_string(index);
  const std::string name = r.string(at + " name");
  const std::string grid = "grid '" + name + "'";
  r.string(grid + " type name");
  r.string(grid + " instance parent name");
  const int64_t gridPos = r.i64(grid + " position"), blockPos = r.i64(grid + " data position");
  const int64_t endPos = r.i64(grid + " end position");
  if (h.hasGridOffsets) {
    if (endPos < 0 || uint64_t(endPos) > r.size())
      r.fail(grid + " end position " + std::to_string(endPos) + " lies past the file's " + std::to_string(r.size()) +
             " bytes (truncated?)");
    if (gridPos < int64_t(r.pos) || blockPos < gridPos || endPos < blockPos)
      r.fail(grid + " positions " + std::to_string(gridPos) + ", " + std::to_string(blockPos) + ", " +
             std::to_string(endPos) + " are out of order");
    r.limit = uint64_t(endPos);
  }
  if (h.version >= kPerGridCompressionVersion) {
    const uint32_t flags = r.u32(grid + " compression flags");
    if (flags & ~kKnownCompressionFlags) r.fail(grid + " compression flags " + std::to_string(flags) + " are unknown");
  }
  checkMetaMap(r, grid);
  r.string(grid + " transform type name");
  if (!h.hasGridOffsets) return false;
  r.pos = uint64_t(endPos);
  r.limit = r.size();
  return true;
}

}  // namespace

void checkVdbHeader(const std::string& path) {
  HeaderReader r(path);
  const FileHeader h = checkFileHeader(r);
  checkMetaMap(r, "file");
  const auto count = int32_t(r.u32("grid count"));
  const uint64_t leastDescriptor = 36;  // three empty strings and three positions
  if (count < 0 || uint64_t(count) > r.left() / leastDescriptor)
    r.fail("grid count " + std::to_string(count) + " exceeds what the " + std::to_string(r.left()) +
           " bytes left at byte " + std::to_string(r.pos) + " can hold");
  for (int32_t i = 0; i < count; ++i)
    if (!checkGrid(r, h, i)) break;
}

}  // namespace voxbrick::store
