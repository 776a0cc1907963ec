// Bounds check of a DICOM file's element structure (see DicomStructure.h): tags, value representations and lengths
// only; no value is interpreted except the transfer syntax.
#include "brickstore/DicomStructure.h"

#include <cctype>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string_view>
#include <vector>

#include "brickstore/Errors.h"

namespace voxbrick::store {
namespace {

constexpr uint32_t kUndefinedLength = 0xFFFFFFFF;

/// A cursor over the file's bytes in one encoding (VR explicit or implicit, byte order).
class Walker {
 public:
  Walker(const std::vector<char>& bytes, std::string path) : mBytes(bytes), mPath(std::move(path)) {}

  size_t pos = 0;
  bool explicitVr = true;
  bool bigEndian = false;

  bool atEnd() const { return pos >= mBytes.size(); }
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
    if (length != kUndefinedLength) return skipValue(length, depth);
    // Undefined length: items up to the sequence delimiter; an undefined-length UN holds implicit-VR items.
    const bool saved = explicitVr;
    explicitVr = explicitVr && !unknownVr;
    walk(true, depth + 1);
    explicitVr = saved;
  }

  /// Refuses a value representation that is none of DICOM's: GDCM would give up on explicit VR and reread the
  /// data set as implicit VR, taking lengths from bytes that are not lengths.
  void checkVr(std::string_view vr, size_t at) const {
    static constexpr std::string_view kAll =
        "AE AS AT CS DA DS DT FD FL IS LO LT OB OD OF OL OV OW PN SH SL SQ SS ST SV TM UC UI UL UN UR US UT UV";
    for (size_t k = 0; k < kAll.size(); k += 3)
      if (kAll.substr(k, 2) == vr) return;
    char tag[16];
    std::snprintf(tag, sizeof tag, "(%04X,%04X)", u16(at), u16(at + 2));
    std::string shown;
    for (char c : vr) shown += std::isprint(static_cast<unsigned char>(c)) ? c : '?';
    fail(std::string("element ") + tag + " at byte " + std::to_string(at) + " has no valid value representation: '" +
         shown + "'");
  }

  DicomLayout layout;

  void skipValue(uint32_t length, int depth) {
    if (length == kUndefinedLength) return walk(true, depth + 1);
    need(pos, length);
    pos += length;
  }

 private:
  const std::vector<char>& mBytes;
  std::string mPath;
};

std::vector<char> readAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(errnoMessage(path));
  std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw IoError(errnoMessage(path));
  return bytes;
}

/// The meta header (group 0002, explicit VR little endian) from pos; returns the transfer syntax UID.
std::string walkMetaHeader(Walker& w) {
  std::string syntax;
  while (!w.atEnd() && w.u16(w.pos) == 0x0002) {
    const size_t start = w.pos;
    const bool isSyntax = w.u16(start + 2) == 0x0010;
    w.skipElement(0);
    if (isSyntax) {
      const size_t header = 8;
      syntax.assign(w.text(start + header, w.pos - start - header));
      while (!syntax.empty() && (syntax.back() == '\0' || syntax.back() == ' ')) syntax.pop_back();
    }
  }
  return syntax;
}

}  // namespace

DicomLayout checkDicomStructure(const std::string& path) {
  const std::vector<char> bytes = readAll(path);
  Walker w(bytes, path);
  if (bytes.size() >= 132 && std::memcmp(bytes.data() + 128, "DICM", 4) == 0) {
    w.pos = 132;
    const std::string syntax = walkMetaHeader(w);
    if (syntax.empty()) throw InputError(path + ": malformed DICOM file (no TransferSyntaxUID in the meta header)");
    if (syntax == "1.2.840.10008.1.2.1.99") return {};  // deflated: GDCM inflates and parses it
    w.explicitVr = syntax != "1.2.840.10008.1.2";
    w.bigEndian = syntax == "1.2.840.10008.1.2.2";
  } else {
    // No preamble: a bare data set, explicit VR when a VR's two capital letters follow the first tag.
    if (bytes.size() < 8) throw InputError(path + ": not a DICOM file (" + std::to_string(bytes.size()) + " bytes)");
    w.explicitVr = std::isupper((unsigned char)bytes[4]) && std::isupper((unsigned char)bytes[5]);
  }
  if (w.atEnd()) throw InputError(path + ": truncated DICOM file (no data set)");
  w.walk(false, 0);
  w.layout.walked = true;
  return w.layout;
}

void checkPixelData(const std::string& path, const DicomLayout& layout, const DicomPixelFormat& f) {
  if (!layout.walked) return;
  if (!layout.hasPixelData) throw InputError(path + ": no PixelData (7FE0,0010) in the DICOM file");
  if (f.encapsulatedSyntax && !layout.encapsulated)
    throw InputError(path + ": transfer syntax " + f.syntaxName + " needs encapsulated (compressed) pixel data, but " +
                     "PixelData holds " + std::to_string(layout.pixelBytes) + " bytes of native pixels");
  if (!f.encapsulatedSyntax && layout.encapsulated)
    throw InputError(path + ": transfer syntax " + f.syntaxName +
                     " needs native pixel data, but PixelData is encapsulated (compressed fragments)");
  if (layout.encapsulated) return;
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
