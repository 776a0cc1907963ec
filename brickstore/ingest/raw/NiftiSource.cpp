// NIfTI-1 single-file input (.nii, .nii.gz): 348-byte header of either byte order, scl_slope/scl_inter scaling.
#include <cmath>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "brickstore/format/Convert.h"
#include "brickstore/format/Errors.h"
#include "brickstore/format/Orientation.h"
#include "brickstore/format/StoreMeta.h"
#include "brickstore/ingest/raw/DenseSource.h"
#include "brickstore/ingest/raw/RawSources.h"
#include "brickstore/source/ByteStream.h"

namespace voxbrick::store {
namespace {

constexpr int32_t kHeaderSize = 348;
constexpr int32_t kNifti2HeaderSize = 540;
constexpr int64_t kMinVoxOffset = 352;  // header plus the 4-byte extension flag

// Offsets of the fields used, from the NIfTI-1 header layout (nifti1.h).
constexpr size_t kDimOffset = 40;
constexpr size_t kDatatypeOffset = 70;
constexpr size_t kBitpixOffset = 72;
constexpr size_t kPixdimOffset = 76;
constexpr size_t kVoxOffsetOffset = 108;
constexpr size_t kSclSlopeOffset = 112;
constexpr size_t kSclInterOffset = 116;
constexpr size_t kQformCodeOffset = 252;
constexpr size_t kSformCodeOffset = 254;
constexpr size_t kQuaternOffset = 256;  // quatern_b, c, d, then qoffset_x, y, z
constexpr size_t kSrowOffset = 280;     // srow_x, srow_y, srow_z: 4 floats each
constexpr size_t kMagicOffset = 344;

// Reads header fields in the file's byte order.
class HeaderView {
 public:
  HeaderView(const std::vector<char>& bytes, bool swap) : mBytes(bytes), mSwap(swap) {}

  int16_t i16(size_t offset) const {
    uint16_t v;
    std::memcpy(&v, mBytes.data() + offset, 2);
    if (mSwap) v = __builtin_bswap16(v);
    return static_cast<int16_t>(v);
  }
  int32_t i32(size_t offset) const {
    uint32_t v;
    std::memcpy(&v, mBytes.data() + offset, 4);
    if (mSwap) v = __builtin_bswap32(v);
    return static_cast<int32_t>(v);
  }
  float f32(size_t offset) const {
    uint32_t v = static_cast<uint32_t>(i32(offset));
    float f;
    std::memcpy(&f, &v, 4);
    return f;
  }

 private:
  const std::vector<char>& mBytes;
  bool mSwap;
};

std::string datatypeName(int code) {
  switch (code) {
    case 1: return "binary";
    case 2: return "uint8";
    case 4: return "int16";
    case 8: return "int32";
    case 16: return "float32";
    case 32: return "complex64";
    case 64: return "float64";
    case 128: return "RGB24";
    case 256: return "int8";
    case 512: return "uint16";
    case 768: return "uint32";
    case 1024: return "int64";
    case 1280: return "uint64";
    case 1536: return "float128";
    case 1792: return "complex128";
    case 2048: return "complex256";
    case 2304: return "RGBA32";
    default: return "unknown";
  }
}

std::optional<FileValueType> datatypeValue(int code) {
  switch (code) {
    case 2: return FileValueType::U8;
    case 4: return FileValueType::I16;
    case 8: return FileValueType::I32;
    case 16: return FileValueType::F32;
    case 64: return FileValueType::F64;
    case 256: return FileValueType::I8;
    case 512: return FileValueType::U16;
    case 768: return FileValueType::U32;
    default: return std::nullopt;
  }
}

// pixdim[1..3], the voxel size along i, j, k (qfac lives in pixdim[0]).
Vec3d pixdimSpacing(const HeaderView& h) {
  return {h.f32(kPixdimOffset + 4), h.f32(kPixdimOffset + 8), h.f32(kPixdimOffset + 12)};
}

// sform: the affine rows srow_x, srow_y, srow_z; column a is the world step of index axis a, column 3 the origin.
Directions sformDirections(const HeaderView& h) {
  Directions d;
  for (int row = 0; row < 3; ++row) {
    for (int a = 0; a < 3; ++a) d.columns[a][row] = h.f32(kSrowOffset + 16 * row + 4 * a);
    d.origin[row] = h.f32(kSrowOffset + 16 * row + 12);
  }
  return d;
}

// qform: the rotation of the quaternion (b, c, d) with a = sqrt(1 - b^2 - c^2 - d^2), the k axis negated when
// qfac (pixdim[0]) is negative, scaled by pixdim[1..3] (NIfTI-1 standard, method 2).
Directions qformDirections(const HeaderView& h) {
  const double b = h.f32(kQuaternOffset), c = h.f32(kQuaternOffset + 4), d = h.f32(kQuaternOffset + 8);
  double a = 1.0 - (b * b + c * c + d * d);
  // nifti1_io: a (nearly) non-positive remainder means a 180-degree rotation, a = 0 with (b, c, d) renormalised.
  double bn = b, cn = c, dn = d;
  if (a < 1e-7) {
    const double n = std::sqrt(b * b + c * c + d * d);
    a = 0.0, bn = b / n, cn = c / n, dn = d / n;
  } else {
    a = std::sqrt(a);
  }
  const double r[3][3] = {{a * a + bn * bn - cn * cn - dn * dn, 2 * (bn * cn - a * dn), 2 * (bn * dn + a * cn)},
                          {2 * (bn * cn + a * dn), a * a + cn * cn - bn * bn - dn * dn, 2 * (cn * dn - a * bn)},
                          {2 * (bn * dn - a * cn), 2 * (cn * dn + a * bn), a * a + dn * dn - cn * cn - bn * bn}};
  const double qfac = h.f32(kPixdimOffset) < 0 ? -1.0 : 1.0;
  const Vec3d pixdim = pixdimSpacing(h);  // checked by niftiSpacing
  const double step[3] = {pixdim.x, pixdim.y, qfac * pixdim.z};
  Directions out;
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) out.columns[col][row] = r[row][col] * step[col];
    out.origin[row] = h.f32(kQuaternOffset + 12 + 4 * size_t(row));
  }
  return out;
}

// NIfTI-1's precedence: the sform when sform_code > 0, else the qform when qform_code > 0, else no patient frame
// (the identity, as nifti1_io's method 1 gives only pixdim scaling). Both frames are RAS.
Orientation niftiOrientation(const HeaderView& h, const std::string& path, Vec3d& spacing) {
  Directions d;
  if (h.i16(kSformCodeOffset) > 0) {
    d = sformDirections(h);
  } else if (h.i16(kQformCodeOffset) > 0) {
    d = qformDirections(h);
  } else {
    return Orientation{};
  }
  return fromDirections(d, path + (h.i16(kSformCodeOffset) > 0 ? ": sform" : ": qform"), spacing);
}

/// The spacing and the orientation: pixdim[1..3] where no sform is given (each in range, where --spacing does not
/// replace it), or the sform's column lengths (in range too).
Orientation niftiSpacing(const HeaderView& h, const std::string& path, const SourceOptions& options, Vec3d& spacing) {
  const bool sform = h.i16(kSformCodeOffset) > 0, qform = h.i16(kQformCodeOffset) > 0;
  spacing = pixdimSpacing(h);
  if (!sform && (qform || !options.spacingGiven))
    for (int a = 0; a < 3; ++a) checkSpacingInRange(spacing[a], path + ": pixdim[" + std::to_string(a + 1) + "]");
  const Orientation orientation = niftiOrientation(h, path, spacing);
  if (sform && !options.spacingGiven)
    for (int a = 0; a < 3; ++a)
      checkSpacingInRange(spacing[a], path + ": sform (srow_x, srow_y, srow_z) column " + std::to_string(a));
  if (options.spacingGiven) spacing = options.spacing;
  return orientation;
}

/// Checks sizeof_hdr (in either byte order), the header's length and the single-file magic; returns whether the
/// header's byte order is the other one.
bool checkHeaderStart(const std::vector<char>& bytes, const std::string& path) {
  if (bytes.size() < 4) throw InputError(path + ": not a NIfTI-1 file (shorter than a header)");
  int32_t sizeofHdr;
  std::memcpy(&sizeofHdr, bytes.data(), 4);
  bool swap = false;
  if (sizeofHdr != kHeaderSize) {
    if (static_cast<int32_t>(__builtin_bswap32(static_cast<uint32_t>(sizeofHdr))) == kHeaderSize) {
      swap = true;
    } else if (sizeofHdr == kNifti2HeaderSize ||
               static_cast<int32_t>(__builtin_bswap32(static_cast<uint32_t>(sizeofHdr))) == kNifti2HeaderSize) {
      throw InputError(path + ": not a NIfTI-1 file (NIfTI-2 headers are not supported)");
    } else {
      throw InputError(path + ": not a NIfTI-1 file (sizeof_hdr is " + std::to_string(sizeofHdr) + ", expected 348)");
    }
  }
  if (bytes.size() < static_cast<size_t>(kHeaderSize)) {
    throw InputError(path + ": truncated header (" + std::to_string(bytes.size()) + " of 348 bytes)");
  }
  const char* magic = bytes.data() + kMagicOffset;
  if (std::memcmp(magic, "ni1\0", 4) == 0) {
    throw InputError(path +
                     ": is the header of a NIfTI-1 .hdr/.img pair (magic 'ni1'); only single-file .nii "
                     "is supported");
  }
  if (std::memcmp(magic, "n+1\0", 4) != 0) {
    throw InputError(path + ": not a NIfTI-1 file (no 'n+1' magic; an ANALYZE 7.5 header?)");
  }
  return swap;
}

/// dim[1..3]; every further dimension must be 1.
Vec3i niftiDims(const HeaderView& h, const std::string& path) {
  const int dimCount = h.i16(kDimOffset);
  if (dimCount < 1 || dimCount > 7) {
    throw InputError(path + ": bad dim[0] " + std::to_string(dimCount) + " (expected 1 to 7)");
  }
  if (dimCount < 3) {
    throw InputError(path + ": only 3D scalar volumes are supported (dim[0] is " + std::to_string(dimCount) + ")");
  }
  for (int d = 4; d <= dimCount; ++d) {
    const int extent = h.i16(kDimOffset + 2 * static_cast<size_t>(d));
    if (extent != 1) {
      throw InputError(path + ": only 3D scalar volumes are supported (dim[" + std::to_string(d) + "] is " +
                       std::to_string(extent) + ")");
    }
  }
  return {h.i16(kDimOffset + 2), h.i16(kDimOffset + 4), h.i16(kDimOffset + 6)};
}

/// The datatype, which must be a supported scalar type whose size bitpix agrees with.
FileValueType niftiValueType(const HeaderView& h, const std::string& path) {
  const int datatype = h.i16(kDatatypeOffset);
  const std::optional<FileValueType> fileType = datatypeValue(datatype);
  if (!fileType) {
    throw InputError(path + ": unsupported NIfTI datatype " + std::to_string(datatype) + " (" + datatypeName(datatype) +
                     ")");
  }
  const int bitpix = h.i16(kBitpixOffset);
  if (bitpix != static_cast<int>(8 * fileValueSize(*fileType))) {
    throw InputError(path + ": datatype " + std::to_string(datatype) + " (" + datatypeName(datatype) + ") has bitpix " +
                     std::to_string(bitpix) + ", expected " + std::to_string(8 * fileValueSize(*fileType)));
  }
  return *fileType;
}

/// vox_offset, a float holding a whole number of bytes at least past the header and its extension flag.
int64_t niftiVoxOffset(const HeaderView& h, const std::string& path) {
  const double voxOffsetValue = h.f32(kVoxOffsetOffset);
  if (!std::isfinite(voxOffsetValue) || voxOffsetValue < static_cast<double>(kMinVoxOffset) ||
      voxOffsetValue != std::floor(voxOffsetValue) || voxOffsetValue > 1e15) {
    throw InputError(path + ": bad vox_offset " + std::to_string(voxOffsetValue) +
                     " (a single-file .nii needs a whole number >= 352)");
  }
  return static_cast<int64_t>(voxOffsetValue);
}

/// The values' conversion: the byte order, and scl_slope/scl_inter where they scale.
Conversion niftiConversion(const HeaderView& h, FileValueType fileType, bool swap) {
  Conversion conversion;
  conversion.from = fileType;
  conversion.swapBytes = swap;
  const double slope = h.f32(kSclSlopeOffset);
  double inter = h.f32(kSclInterOffset);
  if (!std::isfinite(inter)) inter = 0.0;
  // NIfTI: a zero (or unusable) slope means "no scaling"; identity scaling keeps the integer type.
  if (slope != 0.0 && std::isfinite(slope) && (slope != 1.0 || inter != 0.0)) {
    conversion.scaled = true;
    conversion.slope = slope;
    conversion.inter = inter;
  }
  return conversion;
}

}  // namespace

std::unique_ptr<VolumeSource> openNiftiSource(const std::string& path, const SourceOptions& options) {
  const bool gzip = isGzipFile(path);
  const std::vector<char> bytes = readFilePrefix(path, kHeaderSize);
  const bool swap = checkHeaderStart(bytes, path);
  const HeaderView h(bytes, swap);
  const Vec3i dims = niftiDims(h, path);
  const FileValueType fileType = niftiValueType(h, path);
  const int64_t dataBytes = checkedVolumeBytes(dims, fileValueSize(fileType), path);
  checkSliceFitsMemory(dims.x, dims.y, fileValueSize(fileType), options, path, "dim[1] x dim[2]");
  const int64_t voxOffset = niftiVoxOffset(h, path);

  Vec3d spacing;
  const Orientation orientation = niftiSpacing(h, path, options, spacing);
  checkSpacing(spacing, path);

  const Conversion conversion = niftiConversion(h, fileType, swap);
  std::unique_ptr<ByteStream> stream = openVoxelData(path, 0, voxOffset, gzip, dataBytes);

  VolumeInfo info;
  info.dims = dims;
  info.spacing = spacing;
  info.orientation = orientation;
  info.type = conversion.to();
  info.background = 0.0;
  const bool bigEndian = swap == needsSwap(true);
  const int datatype = h.i16(kDatatypeOffset);
  info.description = "NIfTI-1 " + datatypeName(datatype) + (gzip ? " gzip " : " ") + (bigEndian ? "big-endian " : "") +
                     dimsText(dims) + (conversion.scaled ? " scaled to f32" : "") + " (" + baseName(path) + ")";
  return std::make_unique<DenseSource>(std::move(info), std::move(stream), conversion, path);
}

}  // namespace voxbrick::store
