// Writes DICOM series for tests (through GDCM, linked by the test target): a phantom given as a function of the
// world (RAS) position, at any dims, spacing and orientation, so that tests in any folder can write "the same
// phantom" as DICOM that they write in another format.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace voxbrick::test {

using Vec3 = std::array<double, 3>;

/// One series: geometry in DICOM's patient frame (LPS) and the pixel format.
struct DicomSeriesSpec {
  std::array<int, 3> dims{8, 8, 8};  ///< columns (index i, along rowLps), rows (j, along columnLps), slices (k)
  Vec3 spacing{1, 1, 1};             ///< mm between columns, between rows, between slices
  Vec3 rowLps{1, 0, 0};              ///< unit direction of increasing i (first ImageOrientationPatient vector)
  Vec3 columnLps{0, 1, 0};           ///< unit direction of increasing j (second vector); slices step along row x column
  Vec3 originLps{0, 0, 0};           ///< ImagePositionPatient of slice 0: the centre of voxel (0, 0, 0)
  double slope = 1, intercept = 0;   ///< RescaleSlope / RescaleIntercept: value = stored * slope + intercept
  int bitsAllocated = 16;            ///< 8 or 16 (BitsStored the same)
  bool isSigned = true;              ///< PixelRepresentation 1
  std::string seriesUid = "1.2.826.0.1.3680043.9.7777.1";
  std::string description = "phantom";
  std::string prefix = "slice";  ///< files are PREFIXnnn.dcm
  uint32_t shuffleSeed = 1;      ///< file names number the slices in a shuffled order (0: in slice order)
  /// "" writes explicit VR little endian; "jpegls" and "rle" compress losslessly (JPEG-LS, RLE); any other text is
  /// written as the meta header's TransferSyntaxUID over an explicit little-endian data set (to test refusals).
  std::string transferSyntax;
};

/// The RAS world position of voxel (i, j, k)'s centre, where a reader must place it.
Vec3 dicomVoxelRas(const DicomSeriesSpec& spec, int i, int j, int k);

/// Writes slice k of the series to `file`: stored values round((value(ras) - intercept) / slope), clamped to the
/// pixel type. Throws std::runtime_error when GDCM cannot write it.
void writeDicomSlice(const std::filesystem::path& file, const DicomSeriesSpec& spec, int k,
                     const std::function<double(const Vec3& ras)>& value);

/// Writes the whole series into `dir` (created if needed), one file a slice, names in shuffled order. Returns the
/// files in slice order.
std::vector<std::filesystem::path> writeDicomSeries(const std::filesystem::path& dir, const DicomSeriesSpec& spec,
                                                    const std::function<double(const Vec3& ras)>& value);

}  // namespace voxbrick::test
