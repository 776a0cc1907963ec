// What the DICOM reader learns from a file's header before decoding any pixel: first what the file is (its series,
// SOP class, whether it is an image at all), then, for the files of the chosen series only, the geometry and pixel
// format of each slice (a single-frame file, or each frame of an enhanced multi-frame image or RT dose grid).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "brickstore/format/Orientation.h"
#include "brickstore/ingest/dicom/DicomStructure.h"

namespace voxbrick::store {

/// What one file says of itself, read before any file is validated as an image.
struct DicomFileEntry {
  std::string file, seriesUid, sopClass, sopInstance, modality, description;
  std::string notImage;  ///< "" for an image; else what the file is ("RT plan", "structured report", "DICOMDIR")
  bool dose = false;     ///< an RT dose grid (RT Dose Storage): a volume of its own, read as doses
  int64_t rows = 0, columns = 0, frames = 1;  ///< as stated (0 when absent), for listings only
  DicomLayout layout;                         ///< what the structure walk found of the pixel data
};

/// One slice of a volume: a single-frame file, or one frame of a multi-frame file.
struct SliceHeader {
  using Vec = Orientation::Vec;
  std::string file, seriesUid, description, photometric, modality;
  std::string syntaxUid, syntaxText;  ///< the transfer syntax: its UID, and "UID (name)" for messages
  bool decodable = false;             ///< GDCM decodes the syntax here (native, JPEG family, JPEG 2000, RLE)
  bool encapsulatedSyntax = false;    ///< the syntax holds compressed (encapsulated) pixel data
  int64_t rows = 0, columns = 0, frames = 1, samples = 1;
  int64_t frame = -1;  ///< the frame's index in a multi-frame file; -1 for a single-frame file
  int bitsAllocated = 0, bitsStored = 0, highBit = 0;
  bool isSigned = false;
  bool dose = false;  ///< an RT dose grid: values are DoseGridScaling x stored value (Gy), stored as f32
  Vec position{}, row{}, column{};
  double rowSpacing = 0, columnSpacing = 0;  ///< PixelSpacing: between rows (along j), between columns (along i)
  double slope = 1, intercept = 0;
  double along = 0;    ///< position along the series' slice normal
  DicomLayout layout;  ///< what the structure walk found of the file's pixel data

  /// The file, and the frame when it is one of several: for messages.
  std::string name() const { return frame < 0 ? file : file + " frame " + std::to_string(frame + 1); }
};

/// Walks the file's structure (checkDicomStructure, bounded by `maxInflated`) and reads its identity. Throws
/// InputError naming the file when it is damaged, or is an image without SeriesInstanceUID; not for missing image
/// tags: those are checked by readSliceHeaders, for the chosen series only.
DicomFileEntry identifyDicomFile(const std::string& path, uint64_t maxInflated);

/// The slices of one image file: one for a single-frame file; one a frame for an enhanced multi-frame image
/// (positions, orientation, spacing and rescale from the per-frame and shared functional groups) or an RT dose grid
/// (GridFrameOffsetVector from ImagePositionPatient along the normal, DoseGridScaling as the slope). Throws
/// InputError naming the file and the tag for missing or malformed geometry, and for a multi-frame file whose frames
/// are not one volume (several stacks or temporal positions; other orientations are refused with the series' checks).
std::vector<SliceHeader> readSliceHeaders(const DicomFileEntry& entry);

/// Silences GDCM's own reports on stderr (debug, warnings, errors): it says what fails by its return values as well,
/// and the reader's messages, naming the file and the tag, are the ones that count.
void quietGdcm();

/// The dot and cross products of two vectors.
double dot(const Orientation::Vec& a, const Orientation::Vec& b);
Orientation::Vec cross(const Orientation::Vec& a, const Orientation::Vec& b);

/// The unit row, column and normal directions (LPS) of a slice's ImageOrientationPatient; throws InputError naming
/// the file for a zero vector, or row and column directions that are not orthogonal.
std::array<Orientation::Vec, 3> directions(const SliceHeader& h);

}  // namespace voxbrick::store
