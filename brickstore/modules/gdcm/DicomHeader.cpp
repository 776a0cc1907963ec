// Reading DICOM headers through GDCM (see DicomHeader.h): what a file is, then the slices an image file holds, with
// the geometry of each frame of an enhanced multi-frame image or an RT dose grid.
#include "brickstore/modules/gdcm/DicomHeader.h"

#include <gdcmDataSet.h>
#include <gdcmReader.h>
#include <gdcmSequenceOfItems.h>
#include <gdcmStringFilter.h>
#include <gdcmTrace.h>
#include <gdcmTransferSyntax.h>
#include <gdcmUIDs.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <sstream>
#include <string_view>

#include "brickstore/format/Errors.h"
#include "brickstore/format/InputErrors.h"
#include "brickstore/source/DicomClasses.h"

namespace voxbrick::store {
namespace {

using Vec = SliceHeader::Vec;

constexpr const char* kRtDose = "1.2.840.10008.5.1.4.1.1.481.2";  // RT Dose Storage

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

std::string tagText(uint16_t group, uint16_t element) {
  char b[16];
  std::snprintf(b, sizeof b, "(%04X,%04X)", group, element);
  return b;
}

/// Reads tags of one data set (the file's, or an item of a sequence in it) as text (numbers of binary VRs in
/// decimal), and checks what is required. `where` names the file (and the item) in messages.
class Tags {
 public:
  Tags(const gdcm::File& file, const gdcm::DataSet& dataSet, std::string where)
      : mDataSet(dataSet), mWhere(std::move(where)) {
    mFilter.SetFile(file);
  }

  bool has(uint16_t group, uint16_t element) const {
    const gdcm::Tag tag(group, element);
    return mDataSet.FindDataElement(tag) && !mDataSet.GetDataElement(tag).IsEmpty();
  }
  /// The value with surrounding spaces and NULs removed; "" when absent.
  std::string text(uint16_t group, uint16_t element) const {
    if (!has(group, element)) return "";
    std::string s = mFilter.ToString(mDataSet.GetDataElement(gdcm::Tag(group, element)));
    const auto first = s.find_first_not_of(std::string(" \0", 2)), last = s.find_last_not_of(std::string(" \0", 2));
    return first == std::string::npos ? "" : s.substr(first, last - first + 1);
  }
  /// Backslash-separated numbers; throws InputError naming the tag when absent (and required), not numeric (a value
  /// of only spaces included) or not `count` numbers (any count, at least one, when `count` is 0).
  std::vector<double> numbers(uint16_t group, uint16_t element, const char* name, size_t count,
                              const std::vector<double>& fallback = {}) const {
    if (!has(group, element)) {
      if (!fallback.empty()) return fallback;
      throw InputError(mWhere + ": missing DICOM tag " + name + " " + tagText(group, element));
    }
    const std::string s = text(group, element);
    std::vector<double> v;
    std::stringstream in(s);
    for (std::string item; std::getline(in, item, '\\');) {
      char* end = nullptr;
      const double d = std::strtod(item.c_str(), &end);
      while (end && *end == ' ') ++end;
      if (item.empty() || !end || *end != '\0' || !std::isfinite(d))
        throw InputError(mWhere + ": DICOM tag " + name + " is not numeric: '" + s + "'");
      v.push_back(d);
    }
    if (v.empty())  // a value of only spaces
      throw InputError(mWhere + ": DICOM tag " + name + " " + tagText(group, element) + " is not numeric: '" + s + "'");
    if (count > 0 && v.size() != count)
      throw InputError(mWhere + ": DICOM tag " + name + " has " + std::to_string(v.size()) + " values, expected " +
                       std::to_string(count) + ": '" + s.substr(0, 200) + "'");
    return v;
  }
  double one(uint16_t group, uint16_t element, const char* name, double fallback = std::nan("")) const {
    return numbers(group, element, name, 1, std::isnan(fallback) ? std::vector<double>{} : std::vector{fallback})[0];
  }
  /// A number for listings: 0 when absent or not a number.
  int64_t lenient(uint16_t group, uint16_t element) const {
    return std::strtoll(text(group, element).c_str(), nullptr, 10);  // saturates on overflow
  }
  /// A count (NumberOfFrames, Rows, ...): an integer in [0, 2^31), else InputError naming the tag.
  int64_t count(uint16_t group, uint16_t element, const char* name, double fallback = std::nan("")) const {
    const double v = one(group, element, name, fallback);
    if (!(v >= 0 && v < 2147483648.0) || v != std::floor(v))
      throw InputError(mWhere + ": DICOM tag " + name + " " + tagText(group, element) + " is not a count: '" +
                       text(group, element) + "'");
    return int64_t(v);
  }

  /// The first item of a sequence in this data set, or nullptr when there is none.
  const gdcm::DataSet* item(uint16_t group, uint16_t element) const {
    const gdcm::Tag tag(group, element);
    if (!mDataSet.FindDataElement(tag)) return nullptr;
    const gdcm::SmartPointer<gdcm::SequenceOfItems> sq = mDataSet.GetDataElement(tag).GetValueAsSQ();
    if (!sq || sq->GetNumberOfItems() == 0) return nullptr;
    return &sq->GetItem(1).GetNestedDataSet();
  }
  /// The items of a sequence in this data set (none when absent).
  gdcm::SmartPointer<gdcm::SequenceOfItems> sequence(uint16_t group, uint16_t element) const {
    const gdcm::Tag tag(group, element);
    if (!mDataSet.FindDataElement(tag)) return nullptr;
    return mDataSet.GetDataElement(tag).GetValueAsSQ();
  }
  const std::string& where() const { return mWhere; }

 private:
  const gdcm::DataSet& mDataSet;
  gdcm::StringFilter mFilter;
  std::string mWhere;
};

/// What a file that holds no image is, by its SOP class (dicomNonImageKind) or its being a DICOMDIR; "" for an image
/// (or a class not known here, read as an image).
std::string nonImageKind(const std::string& sop, const std::string& mediaSop, const std::string& path) {
  if (mediaSop == "1.2.840.10008.1.3.10" || std::filesystem::path(path).filename() == "DICOMDIR") return "DICOMDIR";
  return dicomNonImageKind(sop);
}

/// The file read through GDCM up to its pixel data, after the structure walk; GDCM's failures become InputErrors.
gdcm::Reader& readUpToPixels(gdcm::Reader& reader, const std::string& path) {
  reader.SetFileName(path.c_str());
  if (!namingInput({path}, [&] { return reader.ReadUpToTag(gdcm::Tag(0x7FE0, 0x0010)); }))
    throw InputError(path + ": not a readable DICOM file (GDCM could not parse it)");
  return reader;
}

}  // namespace

DicomFileEntry identifyDicomFile(const std::string& path, uint64_t maxInflated) {
  DicomFileEntry e;
  e.file = path;
  e.layout = checkDicomStructure(path, maxInflated);
  gdcm::Reader reader;
  const gdcm::File& file = readUpToPixels(reader, path).GetFile();
  const Tags t(file, file.GetDataSet(), path);
  const Tags meta(file, file.GetHeader(), path);
  e.seriesUid = t.text(0x0020, 0x000E);
  e.sopClass = t.text(0x0008, 0x0016);
  e.sopInstance = t.text(0x0008, 0x0018);
  e.modality = t.text(0x0008, 0x0060);
  e.description = t.text(0x0008, 0x103E);
  e.rows = t.lenient(0x0028, 0x0010);
  e.columns = t.lenient(0x0028, 0x0011);
  e.frames = std::max<int64_t>(1, t.lenient(0x0028, 0x0008));
  e.notImage = nonImageKind(e.sopClass, meta.text(0x0002, 0x0002), path);
  e.dose = e.sopClass == kRtDose;
  if (e.notImage.empty() && e.seriesUid.empty())
    throw InputError(path + ": missing DICOM tag SeriesInstanceUID (0020,000E)");
  return e;
}

namespace {

/// Fills the pixel format of `h` from the file's tags.
void readPixelFormat(const Tags& t, SliceHeader& h) {
  h.photometric = t.text(0x0028, 0x0004);
  h.samples = t.count(0x0028, 0x0002, "SamplesPerPixel", 1);
  h.frames = t.count(0x0028, 0x0008, "NumberOfFrames", 1);
  h.rows = t.count(0x0028, 0x0010, "Rows");
  h.columns = t.count(0x0028, 0x0011, "Columns");
  h.bitsAllocated = int(t.count(0x0028, 0x0100, "BitsAllocated"));
  h.bitsStored = int(t.count(0x0028, 0x0101, "BitsStored", h.bitsAllocated));
  h.highBit = int(t.count(0x0028, 0x0102, "HighBit", h.bitsStored - 1));
  h.isSigned = t.one(0x0028, 0x0103, "PixelRepresentation") == 1;
}

/// Geometry of a single-frame image (or of an RT dose grid's first frame): the image plane module.
void readPlane(const Tags& t, SliceHeader& h) {
  const auto p = t.numbers(0x0020, 0x0032, "ImagePositionPatient", 3);
  const auto o = t.numbers(0x0020, 0x0037, "ImageOrientationPatient", 6);
  const auto s = t.numbers(0x0028, 0x0030, "PixelSpacing", 2);
  h.position = {p[0], p[1], p[2]};
  h.row = {o[0], o[1], o[2]};
  h.column = {o[3], o[4], o[5]};
  h.rowSpacing = s[0];
  h.columnSpacing = s[1];
}

/// An RT dose grid: one slice a frame, GridFrameOffsetVector along the normal from ImagePositionPatient (relative
/// when its first value is 0, else absolute: the frames' coordinates along the normal), DoseGridScaling the slope.
std::vector<SliceHeader> doseFrames(const Tags& t, SliceHeader h) {
  readPlane(t, h);
  h.dose = true;
  h.slope = t.one(0x3004, 0x000E, "DoseGridScaling", 1);
  h.intercept = 0;
  std::vector<double> offsets(1, 0.0);
  if (h.frames > 1 || t.has(0x3004, 0x000C)) offsets = t.numbers(0x3004, 0x000C, "GridFrameOffsetVector", 0);
  if (h.frames == 1) offsets = {offsets.front()};  // one frame: its offset (some writers keep them all)
  if (int64_t(offsets.size()) != h.frames)
    throw InputError(h.file + ": GridFrameOffsetVector (3004,000C) holds " + std::to_string(offsets.size()) +
                     " offsets for NumberOfFrames " + std::to_string(h.frames));
  const Vec n = directions(h)[2], origin = h.position;
  const double along0 = dot(n, origin);
  const double base = offsets[0] == 0 ? 0 : along0;  // absolute offsets are coordinates along the normal
  std::vector<SliceHeader> slices;
  for (int64_t k = 0; k < h.frames; ++k) {
    SliceHeader f = h;
    f.frame = h.frames > 1 ? k : -1;
    const double d = offsets[size_t(k)] - base;
    f.position = {origin[0] + d * n[0], origin[1] + d * n[1], origin[2] + d * n[2]};
    slices.push_back(std::move(f));
  }
  return slices;
}

/// A functional group of frame k: the per-frame item's, else the shared one; nullptr when neither holds it.
const gdcm::DataSet* group(const Tags* perFrame, const Tags* shared, uint16_t g, uint16_t e) {
  const gdcm::DataSet* d = perFrame ? perFrame->item(g, e) : nullptr;
  return d ? d : (shared ? shared->item(g, e) : nullptr);
}

/// Frame `k`'s geometry and rescale from its functional groups (Plane Position, Plane Orientation, Pixel Measures,
/// Pixel Value Transformation), and its stack and temporal position (Frame Content) for the one-volume check.
void readFrame(const gdcm::File& file, const Tags* perFrame, const Tags* shared, SliceHeader& f, std::string& stack,
               std::string& temporal) {
  const std::string where = f.name();
  auto need = [&](uint16_t g, uint16_t e, const char* name) {
    const gdcm::DataSet* d = group(perFrame, shared, g, e);
    if (!d)
      throw InputError(where + ": missing " + name + " " + tagText(g, e) +
                       " in the per-frame and shared functional groups");
    return Tags(file, *d, where + " " + name);
  };
  const auto p = need(0x0020, 0x9113, "PlanePositionSequence").numbers(0x0020, 0x0032, "ImagePositionPatient", 3);
  const auto o = need(0x0020, 0x9116, "PlaneOrientationSequence").numbers(0x0020, 0x0037, "ImageOrientationPatient", 6);
  const auto s = need(0x0028, 0x9110, "PixelMeasuresSequence").numbers(0x0028, 0x0030, "PixelSpacing", 2);
  f.position = {p[0], p[1], p[2]};
  f.row = {o[0], o[1], o[2]};
  f.column = {o[3], o[4], o[5]};
  f.rowSpacing = s[0];
  f.columnSpacing = s[1];
  if (const gdcm::DataSet* d = group(perFrame, shared, 0x0028, 0x9145)) {
    const Tags r(file, *d, where + " PixelValueTransformationSequence");
    f.slope = r.one(0x0028, 0x1053, "RescaleSlope", 1);
    f.intercept = r.one(0x0028, 0x1052, "RescaleIntercept", 0);
  }
  if (const gdcm::DataSet* d = group(perFrame, shared, 0x0020, 0x9111)) {
    const Tags c(file, *d, where);
    stack = c.text(0x0020, 0x9056);
    temporal = c.text(0x0020, 0x9128);
  }
}

/// Refuses the frames of one file that are not one volume, saying why: several stacks or temporal positions. (Frames
/// of another orientation are refused later as slices are, by the series' consistency check; frames at one position
/// as duplicates.)
void checkOneVolume(const std::vector<SliceHeader>& frames, const std::vector<std::string>& stacks,
                    const std::vector<std::string>& temporal) {
  const SliceHeader& a = frames.front();
  auto distinct = [](std::vector<std::string> v) {
    std::sort(v.begin(), v.end());
    return std::unique(v.begin(), v.end()) - v.begin();
  };
  const std::string why = a.file + ": the " + std::to_string(frames.size()) + " frames are not one volume (";
  if (const auto n = distinct(stacks); n > 1)
    throw InputError(why + std::to_string(n) + " stacks by StackID (0020,9056)); not supported");
  if (const auto n = distinct(temporal); n > 1)
    throw InputError(why + "a time series: " + std::to_string(n) +
                     " temporal positions by TemporalPositionIndex (0020,9128)); not supported");
}

/// An enhanced multi-frame image: one slice a frame, from the functional groups.
std::vector<SliceHeader> enhancedFrames(const gdcm::File& file, const Tags& t, const SliceHeader& h) {
  const auto perFrame = t.sequence(0x5200, 0x9230);
  const gdcm::DataSet* sharedSet = t.item(0x5200, 0x9229);
  if (!perFrame && !sharedSet)
    throw InputError(h.file + ": multi-frame image without per-frame positions (NumberOfFrames " +
                     std::to_string(h.frames) +
                     "; no PerFrameFunctionalGroupsSequence (5200,9230)); not supported: give one slice a file or an "
                     "enhanced image");
  const int64_t items = perFrame ? int64_t(perFrame->GetNumberOfItems()) : 0;
  if (items != h.frames)
    throw InputError(h.file + ": PerFrameFunctionalGroupsSequence (5200,9230) holds " + std::to_string(items) +
                     " items for NumberOfFrames " + std::to_string(h.frames));
  std::optional<Tags> shared;
  if (sharedSet) shared.emplace(file, *sharedSet, h.file + " SharedFunctionalGroupsSequence");
  std::vector<SliceHeader> frames;
  std::vector<std::string> stacks, temporal;
  for (int64_t k = 0; k < h.frames; ++k) {
    SliceHeader f = h;
    f.frame = k;
    const Tags item(file, perFrame->GetItem(size_t(k + 1)).GetNestedDataSet(), f.name());
    stacks.emplace_back();
    temporal.emplace_back();
    readFrame(file, &item, shared ? &*shared : nullptr, f, stacks.back(), temporal.back());
    frames.push_back(std::move(f));
  }
  checkOneVolume(frames, stacks, temporal);
  return frames;
}

}  // namespace

std::vector<SliceHeader> readSliceHeaders(const DicomFileEntry& entry) {
  SliceHeader h;
  h.file = entry.file;
  h.layout = entry.layout;
  h.seriesUid = entry.seriesUid;
  h.description = entry.description;
  h.modality = entry.modality;
  gdcm::Reader reader;
  const gdcm::File& file = readUpToPixels(reader, entry.file).GetFile();
  return namingInput({entry.file}, [&]() -> std::vector<SliceHeader> {
    const gdcm::TransferSyntax ts = file.GetHeader().GetDataSetTransferSyntax();
    const char* uid = gdcm::TransferSyntax::GetTSString(ts);
    h.syntaxUid = uid ? uid : "";
    h.syntaxText = syntaxName(ts);
    h.decodable = decodable(ts);
    h.encapsulatedSyntax = ts.IsEncapsulated();
    const Tags t(file, file.GetDataSet(), entry.file);
    readPixelFormat(t, h);
    if (t.has(0x0028, 0x0009) && !t.has(0x0028, 0x0008))  // GDCM's image reader aborts on an assertion
      throw InputError(entry.file + ": FrameIncrementPointer (0028,0009) without NumberOfFrames (0028,0008)");
    if (entry.dose) return doseFrames(t, h);
    if (h.frames > 1) return enhancedFrames(file, t, h);
    readPlane(t, h);
    h.slope = t.one(0x0028, 0x1053, "RescaleSlope", 1);
    h.intercept = t.one(0x0028, 0x1052, "RescaleIntercept", 0);
    return {h};
  });
}

void quietGdcm() {
  gdcm::Trace::DebugOff();
  gdcm::Trace::WarningOff();
  gdcm::Trace::ErrorOff();
}

double dot(const Vec& a, const Vec& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

Vec cross(const Vec& a, const Vec& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

std::array<Vec, 3> directions(const SliceHeader& h) {
  auto scaled = [](const Vec& a, double s) { return Vec{a[0] * s, a[1] * s, a[2] * s}; };
  const double r = std::sqrt(dot(h.row, h.row)), c = std::sqrt(dot(h.column, h.column));
  if (!(r > 0.5 && c > 0.5)) throw InputError(h.file + ": ImageOrientationPatient holds a zero vector");
  const Vec row = scaled(h.row, 1 / r), column = scaled(h.column, 1 / c);
  if (std::fabs(dot(row, column)) > 1e-3)
    throw InputError(h.file + ": ImageOrientationPatient row and column directions are not orthogonal");
  const Vec n = cross(row, column);
  return {row, column, scaled(n, 1 / std::sqrt(dot(n, n)))};
}

}  // namespace voxbrick::store
