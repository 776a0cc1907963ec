// DICOM series input through GDCM: headers of every file read first (series, geometry, pixel format), the chosen
// series sorted along its slice normal and checked, then one file decoded per z-slice as prep streams.
#include <gdcmImage.h>
#include <gdcmImageReader.h>
#include <gdcmReader.h>
#include <gdcmStringFilter.h>
#include <gdcmTrace.h>
#include <gdcmTransferSyntax.h>
#include <gdcmUIDs.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "brickstore/Convert.h"
#include "brickstore/DicomStructure.h"
#include "brickstore/Errors.h"
#include "brickstore/Sources.h"

namespace voxbrick::store {
namespace {

using Vec = Orientation::Vec;

constexpr double kSpacingTolerance = 0.01;    // slice steps may differ from the series' step by 1 %
constexpr double kDirectionTolerance = 1e-4;  // direction cosines of two slices count as equal within this

/// What one file's header says, before any pixel is decoded.
struct SliceHeader {
  std::string file, seriesUid, description, photometric;
  gdcm::TransferSyntax syntax;
  int64_t rows = 0, columns = 0, frames = 1, samples = 1;
  int bitsAllocated = 0, bitsStored = 0, highBit = 0;
  bool isSigned = false;
  Vec position{}, row{}, column{};
  double rowSpacing = 0, columnSpacing = 0;  // PixelSpacing: between rows (along j), between columns (along i)
  double slope = 1, intercept = 0;
  double along = 0;    // position along the series' slice normal
  DicomLayout layout;  // what the structure walk found of the pixel data
};

Vec sub(const Vec& a, const Vec& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double dot(const Vec& a, const Vec& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
double norm(const Vec& a) { return std::sqrt(dot(a, a)); }
Vec cross(const Vec& a, const Vec& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec scaled(const Vec& a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
/// DICOM's patient frame is LPS; the store's is RAS.
Vec lpsToRas(const Vec& a) { return {-a[0], -a[1], a[2]}; }

std::string number(double v) {
  std::ostringstream s;
  s.precision(6);
  s << v;
  return s.str();
}

std::string vecText(const Vec& v) { return number(v[0]) + "\\" + number(v[1]) + "\\" + number(v[2]); }

/// "1.2.840.10008.1.2.4.100 (MPEG2 Main Profile / Main Level)".
std::string syntaxName(const gdcm::TransferSyntax& ts) {
  const char* uid = gdcm::TransferSyntax::GetTSString(ts);
  if (!uid) return "an unknown transfer syntax";
  gdcm::UIDs u;
  std::string text = uid;
  if (u.SetFromUID(uid) && u.GetName()) text += std::string(" (") + u.GetName() + ")";
  return text;
}

/// The syntaxes GDCM decodes here: native (implicit/explicit, either byte order, deflated), JPEG, JPEG-LS,
/// JPEG 2000 and RLE. Video (MPEG, H.264), JPIP references and vendor oddities are refused by name.
bool decodable(const gdcm::TransferSyntax& ts) {
  using T = gdcm::TransferSyntax;
  switch (T::TSType(ts)) {
    case T::ImplicitVRLittleEndian:
    case T::ExplicitVRLittleEndian:
    case T::DeflatedExplicitVRLittleEndian:
    case T::ExplicitVRBigEndian:
    case T::JPEGBaselineProcess1:
    case T::JPEGExtendedProcess2_4:
    case T::JPEGExtendedProcess3_5:
    case T::JPEGSpectralSelectionProcess6_8:
    case T::JPEGFullProgressionProcess10_12:
    case T::JPEGLosslessProcess14:
    case T::JPEGLosslessProcess14_1:
    case T::JPEGLSLossless:
    case T::JPEGLSNearLossless:
    case T::JPEG2000Lossless:
    case T::JPEG2000:
    case T::JPEG2000Part2Lossless:
    case T::JPEG2000Part2:
    case T::RLELossless: return true;
    default: return false;
  }
}

/// Reads tags of one file's data set as text (numbers of binary VRs in decimal), and checks what is required.
class TagReader {
 public:
  TagReader(const gdcm::File& file, std::string path) : mDataSet(file.GetDataSet()), mPath(std::move(path)) {
    mFilter.SetFile(file);
  }

  bool has(uint16_t group, uint16_t element) const {
    const gdcm::Tag tag(group, element);
    return mDataSet.FindDataElement(tag) && !mDataSet.GetDataElement(tag).IsEmpty();
  }
  /// The value with surrounding spaces and NULs removed; "" when absent.
  std::string text(uint16_t group, uint16_t element) const {
    if (!has(group, element)) return "";
    std::string s = mFilter.ToString(gdcm::Tag(group, element));
    const auto first = s.find_first_not_of(" \0"), last = s.find_last_not_of(std::string(" \0", 2));
    return first == std::string::npos ? "" : s.substr(first, last - first + 1);
  }
  /// Backslash-separated numbers; throws InputError naming the tag when absent (and required) or not `count` numbers.
  std::vector<double> numbers(uint16_t group, uint16_t element, const char* name, size_t count,
                              const std::vector<double>& fallback = {}) const {
    if (!has(group, element)) {
      if (!fallback.empty()) return fallback;
      throw InputError(mPath + ": missing DICOM tag " + name + " " + tagText(group, element));
    }
    const std::string s = text(group, element);
    std::vector<double> v;
    std::stringstream in(s);
    for (std::string item; std::getline(in, item, '\\');) {
      char* end = nullptr;
      const double d = std::strtod(item.c_str(), &end);
      while (end && *end == ' ') ++end;
      if (item.empty() || !end || *end != '\0' || !std::isfinite(d))
        throw InputError(mPath + ": DICOM tag " + name + " is not numeric: '" + s + "'");
      v.push_back(d);
    }
    if (v.size() != count)
      throw InputError(mPath + ": DICOM tag " + name + " has " + std::to_string(v.size()) + " values, expected " +
                       std::to_string(count) + ": '" + s + "'");
    return v;
  }
  double one(uint16_t group, uint16_t element, const char* name, double fallback = std::nan("")) const {
    return numbers(group, element, name, 1, std::isnan(fallback) ? std::vector<double>{} : std::vector{fallback})[0];
  }

 private:
  static std::string tagText(uint16_t group, uint16_t element) {
    char b[16];
    std::snprintf(b, sizeof b, "(%04X,%04X)", group, element);
    return b;
  }
  const gdcm::DataSet& mDataSet;
  gdcm::StringFilter mFilter;
  std::string mPath;
};

/// Fills the geometry and pixel format of `h` from its tags.
void readTags(const TagReader& t, SliceHeader& h) {
  h.seriesUid = t.text(0x0020, 0x000E);
  if (h.seriesUid.empty()) throw InputError(h.file + ": missing DICOM tag SeriesInstanceUID (0020,000E)");
  h.description = t.text(0x0008, 0x103E);
  h.photometric = t.text(0x0028, 0x0004);
  h.samples = int64_t(t.one(0x0028, 0x0002, "SamplesPerPixel", 1));
  h.frames = int64_t(t.one(0x0028, 0x0008, "NumberOfFrames", 1));
  h.rows = int64_t(t.one(0x0028, 0x0010, "Rows"));
  h.columns = int64_t(t.one(0x0028, 0x0011, "Columns"));
  h.bitsAllocated = int(t.one(0x0028, 0x0100, "BitsAllocated"));
  h.bitsStored = int(t.one(0x0028, 0x0101, "BitsStored", h.bitsAllocated));
  h.highBit = int(t.one(0x0028, 0x0102, "HighBit", h.bitsStored - 1));
  h.isSigned = t.one(0x0028, 0x0103, "PixelRepresentation") == 1;
  const auto p = t.numbers(0x0020, 0x0032, "ImagePositionPatient", 3);
  const auto o = t.numbers(0x0020, 0x0037, "ImageOrientationPatient", 6);
  const auto s = t.numbers(0x0028, 0x0030, "PixelSpacing", 2);
  h.position = {p[0], p[1], p[2]};
  h.row = {o[0], o[1], o[2]};
  h.column = {o[3], o[4], o[5]};
  h.rowSpacing = s[0];
  h.columnSpacing = s[1];
  h.slope = t.one(0x0028, 0x1053, "RescaleSlope", 1);
  h.intercept = t.one(0x0028, 0x1052, "RescaleIntercept", 0);
}

/// Refuses what this reader cannot turn into one scalar slice, by name.
void checkSupported(const SliceHeader& h) {
  const std::string& f = h.file;
  if (!decodable(h.syntax)) throw InputError(f + ": unsupported transfer syntax " + syntaxName(h.syntax));
  if (h.samples != 1 || (h.photometric != "" && h.photometric != "MONOCHROME1" && h.photometric != "MONOCHROME2"))
    throw InputError(f + ": colour images are not supported (SamplesPerPixel " + std::to_string(h.samples) +
                     ", PhotometricInterpretation '" + h.photometric + "'); only greyscale (MONOCHROME1/2)");
  if (h.frames != 1)
    throw InputError(f + ": multi-frame images are not supported (NumberOfFrames " + std::to_string(h.frames) +
                     "); give a series of one slice a file");
  if (h.bitsAllocated != 8 && h.bitsAllocated != 16)
    throw InputError(f + ": BitsAllocated " + std::to_string(h.bitsAllocated) + " is not supported (8 or 16)");
  if (h.bitsStored < 1 || h.bitsStored > h.bitsAllocated || h.highBit != h.bitsStored - 1)
    throw InputError(f + ": unsupported bit layout (BitsAllocated " + std::to_string(h.bitsAllocated) +
                     ", BitsStored " + std::to_string(h.bitsStored) + ", HighBit " + std::to_string(h.highBit) + ")");
  if (h.rows < 1 || h.columns < 1 || h.rows > 65535 || h.columns > 65535)
    throw InputError(f + ": bad image size " + std::to_string(h.columns) + "x" + std::to_string(h.rows));
  if (!(h.rowSpacing > 0) || !(h.columnSpacing > 0))
    throw InputError(f + ": PixelSpacing must be positive (" + number(h.rowSpacing) + "\\" + number(h.columnSpacing) +
                     ")");
  if (!(std::fabs(h.slope) > 0)) throw InputError(f + ": RescaleSlope is 0");
}

/// The header's pixel format, to check the pixel data's length and encoding against.
DicomPixelFormat pixelFormat(const SliceHeader& h) {
  const char* uid = gdcm::TransferSyntax::GetTSString(h.syntax);
  return {
      h.rows,        h.columns, h.frames, h.samples, h.bitsAllocated, h.syntax.IsEncapsulated(), syntaxName(h.syntax),
      uid ? uid : ""};
}

/// The most of a deflated data set inflated before it is refused: 128 MB (a 16-bit slice of 8192 x 8192 with its
/// header), less under a --memory below 512 MB.
uint64_t maxInflatedBytes(const SourceOptions& options) {
  constexpr uint64_t kMax = uint64_t{128} << 20;
  return options.memoryBudgetMB > 0 ? std::min(kMax, uint64_t(options.memoryBudgetMB) << 18) : kMax;
}

/// Reads one file's header (not its pixels). Every failure of GDCM becomes an InputError naming the file.
SliceHeader readHeader(const std::string& path, uint64_t maxInflated) {
  SliceHeader h;
  h.file = path;
  h.layout = checkDicomStructure(path, maxInflated);
  try {
    gdcm::Reader reader;
    reader.SetFileName(path.c_str());
    if (!reader.ReadUpToTag(gdcm::Tag(0x7FE0, 0x0010)))
      throw InputError(path + ": not a readable DICOM file (GDCM could not parse it)");
    h.syntax = reader.GetFile().GetHeader().GetDataSetTransferSyntax();
    readTags(TagReader(reader.GetFile(), path), h);
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(path + ": not a readable DICOM file (" + e.what() + ")");
  }
  return h;
}

/// "UID (12 files, 'desc')" per series, for the error that asks for --series.
std::string seriesList(const std::map<std::string, std::vector<SliceHeader>>& series) {
  std::string text;
  for (const auto& [uid, slices] : series)
    text += (text.empty() ? "" : "; ") + uid + " (" + std::to_string(slices.size()) + " files, '" +
            slices.front().description + "')";
  return text;
}

/// The slices of one series: options.seriesUid, else the series of `chosenFile`, else the only one.
std::vector<SliceHeader> selectSeries(std::vector<SliceHeader> all, const std::string& uid,
                                      const std::string& chosenFile, const std::string& what) {
  std::map<std::string, std::vector<SliceHeader>> series;
  std::string chosenUid = uid;
  for (SliceHeader& h : all) {
    if (uid.empty() && h.file == chosenFile) chosenUid = h.seriesUid;
    series[h.seriesUid].push_back(std::move(h));
  }
  if (chosenUid.empty() && series.size() == 1) chosenUid = series.begin()->first;
  if (chosenUid.empty())
    throw InputError(what + ": holds " + std::to_string(series.size()) +
                     " DICOM series; pick one with --series UID: " + seriesList(series));
  auto it = series.find(chosenUid);
  if (it == series.end()) throw InputError(what + ": no DICOM series " + chosenUid + "; found " + seriesList(series));
  return std::move(it->second);
}

bool sameDirection(const Vec& a, const Vec& b) {
  return std::fabs(a[0] - b[0]) <= kDirectionTolerance && std::fabs(a[1] - b[1]) <= kDirectionTolerance &&
         std::fabs(a[2] - b[2]) <= kDirectionTolerance;
}

/// Every slice must match the first in size, pixel format, orientation and pixel spacing.
void checkConsistent(const std::vector<SliceHeader>& slices) {
  const SliceHeader& a = slices.front();
  for (const SliceHeader& b : slices) {
    auto differ = [&](const std::string& what, const std::string& x, const std::string& y) {
      return InputError(b.file + ": " + what + " " + y + " differs from " + x + " in " + a.file);
    };
    if (b.rows != a.rows || b.columns != a.columns)
      throw differ("size", std::to_string(a.columns) + "x" + std::to_string(a.rows),
                   std::to_string(b.columns) + "x" + std::to_string(b.rows));
    if (b.bitsAllocated != a.bitsAllocated || b.bitsStored != a.bitsStored || b.isSigned != a.isSigned)
      throw differ(
          "pixel format (bits allocated/stored, signed)",
          std::to_string(a.bitsAllocated) + "/" + std::to_string(a.bitsStored) + (a.isSigned ? " signed" : ""),
          std::to_string(b.bitsAllocated) + "/" + std::to_string(b.bitsStored) + (b.isSigned ? " signed" : ""));
    if (!sameDirection(a.row, b.row) || !sameDirection(a.column, b.column))
      throw differ("ImageOrientationPatient", vecText(a.row) + "\\" + vecText(a.column),
                   vecText(b.row) + "\\" + vecText(b.column));
    if (std::fabs(a.rowSpacing - b.rowSpacing) > 1e-4 * a.rowSpacing ||
        std::fabs(a.columnSpacing - b.columnSpacing) > 1e-4 * a.columnSpacing)
      throw differ("PixelSpacing", number(a.rowSpacing) + "\\" + number(a.columnSpacing),
                   number(b.rowSpacing) + "\\" + number(b.columnSpacing));
  }
}

/// The unit row, column and normal directions (LPS) of the series; refuses non-orthogonal or zero vectors.
std::array<Vec, 3> directions(const SliceHeader& h) {
  const double r = norm(h.row), c = norm(h.column);
  if (!(r > 0.5 && c > 0.5)) throw InputError(h.file + ": ImageOrientationPatient holds a zero vector");
  const Vec row = scaled(h.row, 1 / r), column = scaled(h.column, 1 / c);
  if (std::fabs(dot(row, column)) > 1e-3)
    throw InputError(h.file + ": ImageOrientationPatient row and column directions are not orthogonal");
  const Vec n = cross(row, column);
  return {row, column, scaled(n, 1 / norm(n))};
}

/// Sorts the slices along the normal and returns the slice step; refuses duplicates, gaps, uneven steps and
/// slices not stacked along the normal (a tilted gantry).
double sortAlongNormal(std::vector<SliceHeader>& slices, const Vec& normal, const Vec& row, const Vec& column) {
  for (SliceHeader& s : slices) s.along = dot(s.position, normal);
  std::sort(slices.begin(), slices.end(), [](const SliceHeader& a, const SliceHeader& b) {
    return a.along != b.along ? a.along < b.along : a.file < b.file;
  });
  if (slices.size() < 2) return 1.0;
  std::vector<double> steps;
  for (size_t k = 1; k < slices.size(); ++k) steps.push_back(slices[k].along - slices[k - 1].along);
  std::vector<double> sorted = steps;
  std::nth_element(sorted.begin(), sorted.begin() + long(sorted.size() / 2), sorted.end());
  const double step = sorted[sorted.size() / 2];
  const double inPlaneTolerance = 1e-3 + kSpacingTolerance * std::min(slices[0].rowSpacing, slices[0].columnSpacing);
  for (size_t k = 1; k < slices.size(); ++k) {
    const SliceHeader &a = slices[k - 1], &b = slices[k];
    if (steps[k - 1] <= 1e-3 * std::max(step, 1e-3))
      throw InputError("duplicate slice position: " + a.file + " and " + b.file + " both lie at " + number(a.along) +
                       " mm along the slice normal");
    if (std::fabs(steps[k - 1] - step) > kSpacingTolerance * step)
      throw InputError("uneven slice spacing: " + a.file + " to " + b.file + " is " + number(steps[k - 1]) +
                       " mm along the slice normal, the series' step is " + number(step) + " mm (a missing slice?)");
    const Vec d = sub(b.position, slices[0].position);
    if (std::fabs(dot(d, row)) > inPlaneTolerance || std::fabs(dot(d, column)) > inPlaneTolerance)
      throw InputError(b.file + ": slice is shifted in-plane from " + slices[0].file +
                       " (ImagePositionPatient not along the slice normal: a tilted gantry?); not supported");
  }
  if (!(step > 0)) throw InputError(slices[0].file + ": zero slice step");
  return step;
}

/// The store type: the stored integers when every slice shares an integral rescale whose range fits u8, u16 or i16;
/// else f32.
ValueType outputType(const std::vector<SliceHeader>& slices) {
  const SliceHeader& a = slices.front();
  for (const SliceHeader& s : slices)
    if (s.slope != a.slope || s.intercept != a.intercept) return ValueType::F32;
  if (a.slope != std::round(a.slope) || a.intercept != std::round(a.intercept)) return ValueType::F32;
  const double rawLo = a.isSigned ? -std::ldexp(1.0, a.bitsStored - 1) : 0.0;
  const double rawHi = a.isSigned ? std::ldexp(1.0, a.bitsStored - 1) - 1 : std::ldexp(1.0, a.bitsStored) - 1;
  const double x = a.slope * rawLo + a.intercept, y = a.slope * rawHi + a.intercept;
  const double lo = std::min(x, y), hi = std::max(x, y);
  if (lo >= 0 && hi <= 255) return ValueType::U8;
  if (lo >= 0 && hi <= 65535) return ValueType::U16;
  if (lo >= -32768 && hi <= 32767) return ValueType::I16;
  return ValueType::F32;
}

/// The stored value of a raw sample: the low BitsStored bits, sign-extended for signed pixels.
inline int64_t storedValue(uint32_t bits, int bitsStored, bool isSigned) {
  bits &= bitsStored >= 32 ? ~0u : ((1u << bitsStored) - 1);
  if (isSigned && ((bits >> (bitsStored - 1)) & 1u)) return int64_t(bits) - (int64_t(1) << bitsStored);
  return int64_t(bits);
}

class DicomSource final : public VolumeSource {
 public:
  DicomSource(VolumeInfo info, std::vector<SliceHeader> slices, uint64_t maxInflated)
      : mInfo(std::move(info)), mSlices(std::move(slices)), mMaxInflated(maxInflated) {}

  const VolumeInfo& info() const override { return mInfo; }

  void readSlices(int64_t count, void* dst) override {
    if (count < 0 || mNextZ + count > mInfo.dims.z)
      throw InputError(mSlices.front().file + ": read past the last slice of the series");
    const int64_t plane = mInfo.dims.x * mInfo.dims.y;
    auto* out = static_cast<unsigned char*>(dst);
    for (int64_t k = 0; k < count; ++k, ++mNextZ)
      readSlice(mSlices[size_t(mNextZ)], out + k * plane * int64_t(valueSize(mInfo.type)));
  }

 private:
  /// Decodes one file (GDCM: native or compressed) and writes its rescaled values as the store type.
  void readSlice(const SliceHeader& h, unsigned char* dst) {
    const int64_t plane = mInfo.dims.x * mInfo.dims.y;
    const size_t bytes = size_t(plane) * size_t(h.bitsAllocated / 8);
    // Again: the file may have changed since the source opened.
    checkPixelData(h.file, checkDicomStructure(h.file, mMaxInflated), pixelFormat(h));
    try {
      gdcm::ImageReader reader;
      reader.SetFileName(h.file.c_str());
      if (!reader.Read()) throw InputError(h.file + ": GDCM could not read the image (" + syntaxName(h.syntax) + ")");
      const gdcm::Image& image = reader.GetImage();
      if (image.GetBufferLength() != bytes)
        throw InputError(h.file + ": decoded pixel data is " + std::to_string(image.GetBufferLength()) +
                         " bytes, expected " + std::to_string(bytes) + " for " + std::to_string(h.columns) + "x" +
                         std::to_string(h.rows) + " " + std::to_string(h.bitsAllocated) + "-bit pixels");
      mBuffer.resize(bytes);
      if (!image.GetBuffer(mBuffer.data()))
        throw InputError(h.file + ": GDCM could not decode the pixel data (" + syntaxName(h.syntax) + ")");
    } catch (const InputError&) {
      throw;
    } catch (const std::exception& e) {
      throw InputError(h.file + ": GDCM could not decode the pixel data (" + e.what() + ")");
    }
    convert(h, plane, dst);
  }

  void convert(const SliceHeader& h, int64_t count, unsigned char* dst) const {
    dispatchType(mInfo.type, [&](auto zero) {
      using T = decltype(zero);
      T* out = reinterpret_cast<T*>(dst);
      for (int64_t i = 0; i < count; ++i) {
        uint32_t bits;
        if (h.bitsAllocated == 8) {
          bits = uint8_t(mBuffer[size_t(i)]);
        } else {
          uint16_t b;
          std::memcpy(&b, mBuffer.data() + 2 * i, 2);
          bits = b;
        }
        const double v = h.slope * double(storedValue(bits, h.bitsStored, h.isSigned)) + h.intercept;
        if constexpr (std::is_floating_point_v<T>)
          out[i] = T(v);
        else
          out[i] = T(std::llround(v));
      }
    });
  }

  VolumeInfo mInfo;
  std::vector<SliceHeader> mSlices;
  std::vector<char> mBuffer;
  uint64_t mMaxInflated;
  int64_t mNextZ = 0;
};

/// The volume's dims, spacing, type, orientation and description from the sorted, checked slices.
VolumeInfo volumeInfo(const std::vector<SliceHeader>& slices, const std::array<Vec, 3>& axes, double step,
                      const SourceOptions& options) {
  const SliceHeader& a = slices.front();
  VolumeInfo info;
  info.dims = {a.columns, a.rows, int64_t(slices.size())};
  info.spacing = {a.columnSpacing, a.rowSpacing, step};
  if (options.spacingGiven) info.spacing = options.spacing;
  checkSpacing(info.spacing, a.file);
  info.type = outputType(slices);
  info.orientation.axes = {lpsToRas(axes[0]), lpsToRas(axes[1]), lpsToRas(axes[2])};
  info.orientation.origin = lpsToRas(a.position);
  info.orientation.patient = true;
  const bool rescaled = a.slope != 1 || a.intercept != 0;
  info.description = "DICOM series " + a.seriesUid + (a.description.empty() ? "" : " '" + a.description + "'") + " " +
                     std::to_string(a.bitsStored) + "-bit " + (a.isSigned ? "signed " : "") + dimsText(info.dims) +
                     " " + std::string(valueTypeName(info.type)) + (rescaled ? " (rescaled)" : "") + ", " +
                     syntaxName(a.syntax) + " (" + baseName(a.file) + ", ...)";
  return info;
}

}  // namespace

std::unique_ptr<VolumeSource> openDicomSeries(const std::vector<std::string>& files, const SourceOptions& options,
                                              const std::string& chosenFile, const std::string& what) {
  if (files.empty()) throw InputError(what + ": no DICOM files");
  // GDCM reports problems on stderr as well as by its return values; ours are the messages that count.
  gdcm::Trace::DebugOff();
  gdcm::Trace::WarningOff();
  gdcm::Trace::ErrorOff();
  std::vector<SliceHeader> headers;
  headers.reserve(files.size());
  for (const std::string& f : files) headers.push_back(readHeader(f, maxInflatedBytes(options)));
  std::vector<SliceHeader> slices = selectSeries(std::move(headers), options.seriesUid, chosenFile, what);
  for (const SliceHeader& s : slices) {
    checkSupported(s);
    // Before any decoder sizes a buffer from Rows x Columns: the slice must fit --memory, and its pixel data hold it.
    checkSliceFitsMemory(s.columns, s.rows, size_t(s.bitsAllocated / 8), options, s.file, "Rows x Columns");
    checkPixelData(s.file, s.layout, pixelFormat(s));
  }
  checkConsistent(slices);
  const std::array<Vec, 3> axes = directions(slices.front());
  const double step = sortAlongNormal(slices, axes[2], axes[0], axes[1]);
  VolumeInfo info = volumeInfo(slices, axes, step, options);
  return std::make_unique<DicomSource>(std::move(info), std::move(slices), maxInflatedBytes(options));
}

std::unique_ptr<VolumeSource> openDicomSource(const std::vector<std::string>& files, const SourceOptions& options) {
  return openDicomSeries(files, options, "", files.size() == 1 ? files.front() : "the DICOM input");
}

}  // namespace voxbrick::store
