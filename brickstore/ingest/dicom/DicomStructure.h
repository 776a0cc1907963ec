// A bounds check of a DICOM file's element structure, made before GDCM parses it: Debian's GDCM is built with
// assertions, which abort the process on a truncated file instead of returning false.
#pragma once

#include <cstdint>
#include <string>

namespace voxbrick::store {

/// What the structure walk found of a file's pixel data.
struct DicomLayout {
  bool walked = false;         ///< false when the data set was not walked (see checkDicomStructure)
  bool hasPixelData = false;   ///< the data set holds PixelData (7FE0,0010)
  bool encapsulated = false;   ///< PixelData of undefined length: compressed fragments
  uint64_t pixelBytes = 0;     ///< PixelData's length when not encapsulated
  uint64_t fragmentBytes = 0;  ///< encapsulated: the bytes of every fragment (the offset table not counted)
  int64_t streamColumns = -1;  ///< encapsulated JPEG, JPEG-LS or JPEG 2000: the first frame's width as its
  int64_t streamRows = -1;     ///< codestream header (SOF, SIZ) states it; -1 when not found
  uint64_t inflatedBytes = 0;  ///< a deflated data set: its size once inflated
  bool guessed = false;        ///< no transfer syntax stated: the encoding was told from the first element
};

/// The pixel format as the header states it, to size the native pixel data.
struct DicomPixelFormat {
  int64_t rows = 0, columns = 0, frames = 1, samples = 1;
  int bitsAllocated = 0;
  bool encapsulatedSyntax = false;  ///< the transfer syntax is a compressed (encapsulated) one
  std::string syntaxName;           ///< for messages: "UID (name)"
  std::string syntaxUid;            ///< bounds the compression ratio of encapsulated pixel data (RLE, JPEG)
};

/// Walks the file's elements (the Part 10 meta header, then the data set in its transfer syntax; sequences and
/// encapsulated pixel data item by item) and throws InputError naming the file when one runs past the end of the
/// file, a sequence is not closed, or an explicit-VR element has no valid value representation (GDCM would reread
/// the file as implicit VR, and size values from its bytes). A deflated data set is inflated here first, at most
/// `maxInflatedBytes` of it (more is refused: GDCM would inflate it whole into memory), and walked as explicit VR
/// little endian. A file without the preamble or meta header (or a meta header without TransferSyntaxUID) is walked
/// in the encoding its first element shows (implicit VR little endian, explicit VR in either byte order); bytes that
/// are no element in any of them are refused as not DICOM. Throws IoError when the file cannot be read.
DicomLayout checkDicomStructure(const std::string& path, uint64_t maxInflatedBytes = uint64_t{128} << 20);

/// True when the file, without the preamble and "DICM", opens with two DICOM elements in order (of the meta header,
/// or of the identifying group 0008) in implicit VR little endian or explicit VR: a bare DICOM data set.
bool looksLikeDicomDataSet(const std::string& path);

/// Throws InputError naming the file when its pixel data does not match the header: no PixelData, encapsulated
/// pixel data under a native transfer syntax or native pixel data under a compressed one, or a native length other
/// than Rows x Columns x BitsAllocated/8 x SamplesPerPixel x NumberOfFrames (plus one padding byte when that is odd).
/// Encapsulated pixel data is bounded before any decoder sizes a buffer from the header: a codestream whose own
/// header (JPEG SOF, JPEG-LS SOF55, JPEG 2000 SIZ) states another size than Rows x Columns, and fragments too few to
/// hold the slice at the largest ratio the syntax can reach (RLE 64:1, Huffman JPEG 1024:1) are refused.
/// Nothing is checked when the data set was not walked.
void checkPixelData(const std::string& path, const DicomLayout& layout, const DicomPixelFormat& format);

}  // namespace voxbrick::store
