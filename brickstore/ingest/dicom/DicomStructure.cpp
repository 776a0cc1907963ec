// Bounds check of a DICOM file's element structure (see DicomStructure.h): tags, value representations and lengths
// only; no value is interpreted except the transfer syntax.
#include "brickstore/ingest/dicom/DicomStructure.h"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string_view>
#include <utility>
#include <vector>

#include <zlib.h>

#include "brickstore/format/Errors.h"

namespace voxbrick::store {
namespace {

constexpr uint32_t kUndefinedLength = 0xFFFFFFFF;

/// Whether `vr` is one of DICOM's value representations.
bool isDicomVr(std::string_view vr) {
  static constexpr std::string_view kAll =
      "AE AS AT CS DA DS DT FD FL IS LO LT OB OD OF OL OV OW PN SH SL SQ SS ST SV TM UC UI UL UN UR US UT UV";
  for (size_t k = 0; k < kAll.size(); k += 3)
    if (kAll.substr(k, 2) == vr) return true;
  return false;
}

/// A cursor over the file's bytes in one encoding (VR explicit or implicit, byte order).
class Walker {
 public:
  Walker(const std::vector<char>& bytes, std::string path)
      : mBytes(bytes), mPath(std::move(path)), mLimit(bytes.size()) {}

  size_t pos = 0;
  bool explicitVr = true;
  bool bigEndian = false;

  bool atEnd() const { return pos >= mLimit; }
  uint16_t u16(size_t at) const {
    need(at, 2);
    const auto* b = reinterpret_cast<const unsigned char*>(mBytes.data() + at);
    return bigEndian ? uint16_t(b[0] << 8 | b[1]) : uint16_t(b[1] << 8 | b[0]);
  }
  uint32_t u32(size_t at) const {
    const uint32_t a = u16(at), b = u16(at + 2);
    return bigEndian ? (a << 16 | b) : (b << 16 | a);
  }
  std::string_view text(size_t at, size_t n) const {
    need(at, n);
    return {mBytes.data() + at, n};
  }
  /// Throws unless [at, at + n) lies inside the file.
  void need(size_t at, size_t n) const {
    if (at > mBytes.size() || n > mBytes.size() - at)
      throw InputError(mPath + ": truncated DICOM file (an element runs past the end at byte " + std::to_string(at) +
                       " of " + std::to_string(mBytes.size()) + ")");
  }
  [[noreturn]] void fail(const std::string& why) const {
    throw InputError(mPath + ": malformed DICOM file (" + why + ")");
  }

  /// Elements from pos; until a delimiter (FFFE,E00D or E0DD) when `untilDelimiter`, else to the end of the file.
  void walk(bool untilDelimiter, int depth) {
    if (depth > 64) fail("sequences nested too deep");
    while (!atEnd()) {
      const uint16_t group = u16(pos), element = u16(pos + 2);
      if (group == 0xFFFE) {
        const uint32_t length = u32(pos + 4);
        pos += 8;
        if (element == 0xE00D || element == 0xE0DD) {
          if (untilDelimiter) return;
          fail("a delimiter outside a sequence");
        }
        if (mInPixelData && depth == 1 && element == 0xE000 && mItems++ > 0 && length != kUndefinedLength) {
          if (layout.fragmentBytes == 0) firstFragment = {pos, length};
          layout.fragmentBytes += length;  // items after the basic offset table: the compressed frames
        }
        if (element == 0xE000 && !mInPixelData && length != kUndefinedLength)
          walkBounded(length, depth, "item");
        else
          skipValue(length, depth);
        continue;
      }
      skipElement(depth);
    }
    if (untilDelimiter) need(pos, 8);  // an open sequence or item at the end of the file
  }

  /// One element at pos: its header, then its value (by length, or item by item when undefined). PixelData at the
  /// top level is recorded in `layout`.
  void skipElement(int depth) {
    const bool isPixelData = depth == 0 && u16(pos) == 0x7FE0 && u16(pos + 2) == 0x0010;
    const size_t start = pos;
    uint32_t length;
    bool unknownVr = false;
    if (explicitVr) {
      const std::string_view vr = text(pos + 4, 2);
      checkVr(vr, start);
      static const char* const kLong[] = {"OB", "OD", "OF", "OL", "OV", "OW", "SQ", "SV", "UC", "UN", "UR", "UT", "UV"};
      bool isLong = false;
      for (const char* l : kLong) isLong = isLong || vr == l;
      unknownVr = vr == "UN";
      length = isLong ? u32(pos + 8) : u16(pos + 6);
      pos += isLong ? 12 : 8;
    } else {
      length = u32(pos + 4);
      pos += 8;
    }
    if (isPixelData) {
      layout.hasPixelData = true;
      layout.encapsulated = length == kUndefinedLength;
      layout.pixelBytes = layout.encapsulated ? 0 : length;
    }
    if (length != kUndefinedLength && explicitVr && text(start + 4, 2) == "SQ")
      return walkBounded(length, depth, "sequence");
    if (length != kUndefinedLength) return skipValue(length, depth);
    // Undefined length: items up to the sequence delimiter; an undefined-length UN holds implicit-VR items.
    const bool saved = explicitVr;
    explicitVr = explicitVr && !unknownVr;
    mInPixelData = isPixelData;
    walk(true, depth + 1);
    mInPixelData = false;
    explicitVr = saved;
  }

  /// Refuses a value representation that is none of DICOM's: GDCM would give up on explicit VR and reread the
  /// data set as implicit VR, taking lengths from bytes that are not lengths.
  void checkVr(std::string_view vr, size_t at) const {
    if (isDicomVr(vr)) return;
    char tag[16];
    std::snprintf(tag, sizeof tag, "(%04X,%04X)", u16(at), u16(at + 2));
    std::string shown;
    for (char c : vr) shown += std::isprint(static_cast<unsigned char>(c)) ? c : '?';
    fail(std::string("element ") + tag + " at byte " + std::to_string(at) + " has no valid value representation: '" +
         shown + "'");
  }

  DicomLayout layout;
  std::pair<size_t, size_t> firstFragment{0, 0};  ///< offset and length of the first compressed frame's bytes

  /// Walks [pos, pos + length) as elements (a defined-length item's or sequence's content, which GDCM parses):
  /// fails when one of them runs past that end.
  void walkBounded(uint32_t length, int depth, const char* what) {
    if (depth > 64) fail("sequences nested too deep");
    need(pos, length);
    const size_t end = pos + length, saved = mLimit;
    mLimit = end;
    walk(false, depth + 1);
    mLimit = saved;
    if (pos != end)
      fail(std::string("an element runs past the end of its ") + what + " (" + std::to_string(length) +
           " bytes, ending at byte " + std::to_string(end) + ")");
  }

  void skipValue(uint32_t length, int depth) {
    if (length == kUndefinedLength) return walk(true, depth + 1);
    need(pos, length);
    pos += length;
  }

 private:
  const std::vector<char>& mBytes;
  std::string mPath;
  size_t mLimit;              // the end of what is walked now: the file, or a defined-length item or sequence
  bool mInPixelData = false;  // walking the items of encapsulated PixelData
  int mItems = 0;             // items of it seen: the basic offset table, then fragments
};

std::vector<char> readAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(errnoMessage(path));
  std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw IoError(errnoMessage(path));
  return bytes;
}

/// The meta header (group 0002, explicit VR little endian) from pos; returns the transfer syntax UID.
/// Its FileMetaInformationGroupLength (0002,0000), when stated, must be the length of the elements after it: GDCM
/// reads the meta header by that length (and aborts on an assertion when it ends inside an element).
std::string walkMetaHeader(Walker& w) {
  std::string syntax;
  int64_t groupLength = -1;
  size_t afterGroupLength = 0;
  while (!w.atEnd() && w.u16(w.pos) == 0x0002) {
    const size_t start = w.pos;
    const uint16_t element = w.u16(start + 2);
    w.skipElement(0);
    if (element == 0x0010) {
      const size_t header = 8;
      syntax.assign(w.text(start + header, w.pos - start - header));
      while (!syntax.empty() && (syntax.back() == '\0' || syntax.back() == ' ')) syntax.pop_back();
    }
    if (element == 0x0000 && w.pos - start == 12) {
      groupLength = w.u32(start + 8);
      afterGroupLength = w.pos;
    }
  }
  if (groupLength >= 0 && uint64_t(groupLength) != w.pos - afterGroupLength)
    w.fail("the meta header's FileMetaInformationGroupLength (0002,0000) is " + std::to_string(groupLength) +
           " bytes, but its elements after it take " + std::to_string(w.pos - afterGroupLength));
  return syntax;
}

/// A data set's encoding, guessed from its first element when no transfer syntax is stated.
enum class Encoding { ImplicitLittle, ExplicitLittle, ExplicitBig, None };

/// Whether the two bytes at `at` are a value representation.
bool isValidVr(const std::vector<char>& bytes, size_t at) {
  return at + 2 <= bytes.size() && isDicomVr(std::string_view(bytes.data() + at, 2));
}

/// Whether the bytes open with a meta header element (group 0002, explicit VR little endian), as they do after the
/// preamble, or first in a file without one.
bool opensWithMetaHeader(const std::vector<char>& bytes) {
  return bytes.size() >= 8 && bytes[0] == 2 && bytes[1] == 0 && isValidVr(bytes, 4);
}

/// Sets the walker to read the data set in encoding `e` (not None).
void setEncoding(Walker& w, Encoding e) {
  w.explicitVr = e != Encoding::ImplicitLittle;
  w.bigEndian = e == Encoding::ExplicitBig;
}

/// A group a data set can open with: an even (standard) group of the data set, or 0x0008..0x0009 (identifying).
bool plausibleFirstGroup(uint32_t group) {
  return group >= 0x0008 && group <= 0x7FE0 && (group % 2 == 0 || group == 9);
}

/// The encoding whose reading of the first element makes sense: a valid VR after a plausible group (explicit, in
/// the byte order that gives the smaller plausible group), else a plausible group with a length that fits the file
/// (implicit VR little endian, the default transfer syntax).
Encoding guessEncoding(const std::vector<char>& bytes, size_t at) {
  if (at + 8 > bytes.size()) return Encoding::None;
  const auto* b = reinterpret_cast<const unsigned char*>(bytes.data() + at);
  const uint32_t little = b[0] | b[1] << 8, big = b[0] << 8 | b[1];
  if (isValidVr(bytes, at + 4)) {  // both byte orders may give a plausible group: the smaller is the data set's
    if (plausibleFirstGroup(little) && (!plausibleFirstGroup(big) || little < big)) return Encoding::ExplicitLittle;
    if (plausibleFirstGroup(big)) return Encoding::ExplicitBig;
  }
  const uint64_t length = uint64_t(b[4]) | uint64_t(b[5]) << 8 | uint64_t(b[6]) << 16 | uint64_t(b[7]) << 24;
  if (plausibleFirstGroup(little) && (length == kUndefinedLength || length <= bytes.size() - at - 8))
    return Encoding::ImplicitLittle;
  return Encoding::None;
}

/// Why a file whose first data set bytes are no element is not read as DICOM: what it lacks and what it holds.
std::string notAnElement(const std::vector<char>& bytes, size_t at, bool part10, bool meta) {
  char hex[64] = {};
  for (size_t k = 0; k < 8 && at + k < bytes.size(); ++k)
    std::snprintf(hex + 3 * k, 4, "%02x ", unsigned(static_cast<unsigned char>(bytes[at + k])));
  std::string shown(hex);
  if (!shown.empty()) shown.pop_back();
  const std::string lacks = part10 || meta ? "its meta header states no TransferSyntaxUID"
                                           : "no 128-byte preamble with 'DICM' and no meta header";
  return "not a DICOM file (" + lacks + ", and the bytes at " + std::to_string(at) + " (" + shown +
         ") are not a DICOM element in implicit or explicit VR)";
}

uint32_t bigEndian(const unsigned char* b, int n) {
  uint32_t v = 0;
  for (int k = 0; k < n; ++k) v = v << 8 | b[k];
  return v;
}

/// The frame size a JPEG (any process, JPEG-LS included) or JPEG 2000 codestream states in its header: the first
/// SOF marker segment's X and Y, or the SIZ segment's Xsiz - XOsiz and Ysiz - YOsiz. {-1, -1} when the bytes hold
/// neither (another codec, or a header past what it holds).
std::pair<int64_t, int64_t> codestreamSize(const unsigned char* b, size_t n) {
  if (n >= 4 + 38 && b[0] == 0xFF && b[1] == 0x4F && b[2] == 0xFF && b[3] == 0x51) {  // J2K: SOC, then SIZ
    const unsigned char* siz = b + 4 + 2 + 2;                                         // marker, Lsiz, Rsiz
    return {int64_t(bigEndian(siz, 4)) - int64_t(bigEndian(siz + 8, 4)),
            int64_t(bigEndian(siz + 4, 4)) - int64_t(bigEndian(siz + 12, 4))};
  }
  if (n < 4 || b[0] != 0xFF || b[1] != 0xD8) return {-1, -1};
  size_t at = 2;
  while (at + 4 <= n) {
    if (b[at] != 0xFF) return {-1, -1};
    const unsigned marker = b[at + 1];
    if (marker == 0xFF) {  // fill byte
      ++at;
      continue;
    }
    const size_t length = bigEndian(b + at + 2, 2);
    const bool sof = (marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC) ||
                     marker == 0xF7;  // SOF0..15 (not DHT, JPG, DAC), SOF55 (JPEG-LS)
    if (sof) {
      if (at + 4 + 5 > n || length < 7) return {-1, -1};
      return {int64_t(bigEndian(b + at + 7, 2)), int64_t(bigEndian(b + at + 5, 2))};
    }
    if (marker == 0xDA || length < 2) return {-1, -1};  // scan data before any SOF
    at += 2 + length;
  }
  return {-1, -1};
}

/// The raw-deflated data set after the meta header, inflated: at most `maxBytes`, else InputError.
std::vector<char> inflateDataSet(const std::vector<char>& bytes, size_t from, uint64_t maxBytes,
                                 const std::string& path) {
  z_stream z{};
  if (inflateInit2(&z, -MAX_WBITS) != Z_OK) throw InputError(path + ": cannot start inflating the data set");
  std::vector<char> out;
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data() + from));
  z.avail_in = uInt(bytes.size() - from);
  int rc = Z_OK;
  while (rc == Z_OK) {
    if (out.size() >= maxBytes) break;
    const size_t have = out.size(), chunk = size_t(std::min<uint64_t>(maxBytes - have, 1 << 20));
    out.resize(have + chunk);
    z.next_out = reinterpret_cast<Bytef*>(out.data() + have);
    z.avail_out = uInt(chunk);
    rc = inflate(&z, Z_NO_FLUSH);
    out.resize(have + chunk - z.avail_out);
    if (rc == Z_BUF_ERROR && z.avail_in == 0) break;  // the input ended before the stream did
  }
  inflateEnd(&z);
  if (rc == Z_STREAM_END) return out;
  if (out.size() >= maxBytes)
    throw InputError(path + ": deflated data set inflates to more than " + std::to_string(maxBytes >> 20) +
                     " MB (refused before GDCM inflates it into memory)");
  throw InputError(path + ": deflated data set is " + (rc == Z_DATA_ERROR ? "corrupt" : "truncated") + " after " +
                   std::to_string(out.size()) + " inflated bytes");
}

/// The largest decoded-to-compressed ratio a syntax's pixel data can reach; 0 where it has none worth stating
/// (JPEG-LS and JPEG 2000 code runs of constant pixels in a few bits: their codestream's header is checked instead).
uint64_t maxCompressionRatio(const std::string& uid) {
  if (uid == "1.2.840.10008.1.2.5") return 64;  // RLE: a two-byte replicate run is at most 128 bytes
  // Huffman JPEG: at least one bit per 8x8 block per scan (two bytes a sample): 1024 bytes a byte.
  if (uid.rfind("1.2.840.10008.1.2.4.", 0) == 0) {
    const int process = std::atoi(uid.c_str() + 20);
    if (process >= 50 && process <= 70) return 1024;
  }
  return 0;
}

}  // namespace

bool looksLikeDicomDataSet(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::vector<char> head(4096);
  if (!in.read(head.data(), std::streamsize(head.size())) && in.gcount() <= 0) return false;
  head.resize(size_t(in.gcount()));
  if (head.size() < 16) return false;
  const bool meta = opensWithMetaHeader(head);
  const Encoding e = meta ? Encoding::ExplicitLittle : guessEncoding(head, 0);
  if (e == Encoding::None) return false;
  Walker w(head, path);
  setEncoding(w, e);
  try {
    // Two elements in order, of the meta header or the identifying group: raw voxels hardly look like that.
    const uint32_t group = w.u16(0), element = w.u16(2);
    if (group != 0x0002 && group != 0x0008) return false;
    w.skipElement(0);
    const uint32_t nextGroup = w.u16(w.pos), nextElement = w.u16(w.pos + 2);
    return (nextGroup == group && nextElement > element) || (group == 0x0002 && nextGroup == 0x0008);
  } catch (const InputError&) {
    return false;
  }
}

DicomLayout checkDicomStructure(const std::string& path, uint64_t maxInflatedBytes) {
  const std::vector<char> bytes = readAll(path);
  Walker w(bytes, path);
  const bool part10 = bytes.size() >= 132 && std::memcmp(bytes.data() + 128, "DICM", 4) == 0;
  w.pos = part10 ? 132 : 0;
  // A meta header (group 0002, explicit VR little endian) after the preamble, or first in a file without one.
  const bool meta = part10 || opensWithMetaHeader(bytes);
  const std::string syntax = meta ? walkMetaHeader(w) : "";
  if (syntax == "1.2.840.10008.1.2.1.99") {  // deflated: inflated here (bounded), walked as explicit VR
    const std::vector<char> inflated = inflateDataSet(bytes, w.pos, maxInflatedBytes, path);
    Walker d(inflated, path);
    if (d.atEnd()) throw InputError(path + ": truncated DICOM file (no data set)");
    d.walk(false, 0);
    d.layout.walked = true;
    d.layout.inflatedBytes = inflated.size();
    return d.layout;
  }
  if (!syntax.empty()) {
    w.explicitVr = syntax != "1.2.840.10008.1.2";
    w.bigEndian = syntax == "1.2.840.10008.1.2.2";
  } else {
    // No transfer syntax stated (no meta header, or one without TransferSyntaxUID): the data set's first element
    // tells its encoding, as GDCM guesses it.
    if (w.atEnd()) throw InputError(path + ": truncated DICOM file (no data set)");
    const Encoding e = guessEncoding(bytes, w.pos);
    if (e == Encoding::None) throw InputError(path + ": " + notAnElement(bytes, w.pos, part10, meta));
    setEncoding(w, e);
    w.layout.guessed = true;
  }
  if (w.atEnd()) throw InputError(path + ": truncated DICOM file (no data set)");
  w.walk(false, 0);
  w.layout.walked = true;
  if (w.layout.encapsulated && w.firstFragment.second > 0) {
    const auto [columns, rows] = codestreamSize(
        reinterpret_cast<const unsigned char*>(bytes.data()) + w.firstFragment.first, w.firstFragment.second);
    w.layout.streamColumns = columns;
    w.layout.streamRows = rows;
  }
  return w.layout;
}

namespace {

/// Encapsulated pixel data against the header: the codestream's own size, and enough bytes for the slice.
void checkEncapsulated(const std::string& path, const DicomLayout& layout, const DicomPixelFormat& f) {
  const std::string size = "Rows " + std::to_string(f.rows) + " x Columns " + std::to_string(f.columns);
  if (layout.fragmentBytes == 0)
    throw InputError(path + ": PixelData is encapsulated but holds no compressed fragment");
  if (layout.streamColumns >= 0 && (layout.streamColumns != f.columns || layout.streamRows != f.rows))
    throw InputError(path + ": the compressed frame's header says " + std::to_string(layout.streamColumns) + "x" +
                     std::to_string(layout.streamRows) + " pixels, but " + size + " in the DICOM header");
  const uint64_t decoded =
      uint64_t(f.rows) * uint64_t(f.columns) * uint64_t(f.bitsAllocated / 8) * uint64_t(f.samples) * uint64_t(f.frames);
  const uint64_t ratio = maxCompressionRatio(f.syntaxUid);
  if (ratio > 0 && decoded > ratio * layout.fragmentBytes + 64)
    throw InputError(path + ": " + size + " x " + std::to_string(f.bitsAllocated / 8) + " bytes (BitsAllocated " +
                     std::to_string(f.bitsAllocated) + ") is " + std::to_string(decoded) + " bytes, more than " +
                     std::to_string(layout.fragmentBytes) + " bytes of " + f.syntaxName + " fragments can hold (at " +
                     std::to_string(ratio) + ":1)");
}

}  // namespace

void checkPixelData(const std::string& path, const DicomLayout& layout, const DicomPixelFormat& f) {
  if (!layout.walked) return;
  if (!layout.hasPixelData) throw InputError(path + ": no PixelData (7FE0,0010) in the DICOM file");
  if (f.encapsulatedSyntax && !layout.encapsulated)
    throw InputError(path + ": transfer syntax " + f.syntaxName + " needs encapsulated (compressed) pixel data, but " +
                     "PixelData holds " + std::to_string(layout.pixelBytes) + " bytes of native pixels");
  if (!f.encapsulatedSyntax && layout.encapsulated)
    throw InputError(path + ": transfer syntax " + f.syntaxName +
                     " needs native pixel data, but PixelData is encapsulated (compressed fragments)");
  if (layout.encapsulated) return checkEncapsulated(path, layout, f);
  const uint64_t expected =
      uint64_t(f.rows) * uint64_t(f.columns) * uint64_t(f.bitsAllocated / 8) * uint64_t(f.samples) * uint64_t(f.frames);
  if (layout.pixelBytes == expected || (expected % 2 == 1 && layout.pixelBytes == expected + 1)) return;
  throw InputError(path + ": PixelData holds " + std::to_string(layout.pixelBytes) + " bytes, but the header needs " +
                   std::to_string(expected) + " (Rows " + std::to_string(f.rows) + " x Columns " +
                   std::to_string(f.columns) + " x " + std::to_string(f.bitsAllocated / 8) + " bytes (BitsAllocated " +
                   std::to_string(f.bitsAllocated) + ") x SamplesPerPixel " + std::to_string(f.samples) +
                   " x NumberOfFrames " + std::to_string(f.frames) + ")");
}

}  // namespace voxbrick::store
