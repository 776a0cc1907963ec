// DICOM input: a series of files, an enhanced multi-frame image or RT dose grid, a DICOMDIR. Read by the GDCM module
// (brickstore/modules/gdcm), which each of these loads the first time (common::ModuleError if it cannot).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "brickstore/source/VolumeSource.h"

namespace voxbrick::store {

/// A DICOM series, one slice a file in any order, or an enhanced multi-frame image or RT dose grid: files are grouped
/// by SeriesInstanceUID, files that are not images (reports, plans, structure sets, ...) skipped (options.seriesUid
/// picks one image series when there are several), slices (or frames) sorted along the slice normal, checked for
/// gaps, duplicates and mismatched slices, and rescaled (RescaleSlope/Intercept, DoseGridScaling). Slices are decoded
/// one at a time as readSlices() asks for them.
std::unique_ptr<VolumeSource> openDicomSource(const std::vector<std::string>& files, const SourceOptions& options);

/// As openDicomSource, for the DICOM files of a directory: the series `chosenFile` (one of `files`, or "") belongs
/// to unless options.seriesUid names one; `what` names the input in errors.
std::unique_ptr<VolumeSource> openDicomSeries(const std::vector<std::string>& files, const SourceOptions& options,
                                              const std::string& chosenFile, const std::string& what);

/// Whether the DICOM file `file` is a volume of its own (an enhanced multi-frame image, an RT dose grid), which is read
/// alone, without the files beside it; false for one slice of a series. Throws InputError for a file that cannot be
/// identified.
bool isDicomVolumeFile(const std::string& file, const SourceOptions& options);

/// The DICOM files a DICOMDIR references (its directory records' ReferencedFileID, under its directory), opened as
/// openDicomSeries opens a folder's.
std::unique_ptr<VolumeSource> openDicomDir(const std::string& path, const SourceOptions& options);

/// The GDCM module's table, given by its entry VOXBRICK_DICOM_ENTRY (common/Modules.h; the name changes with the
/// table): the functions above.
struct DicomModule {
  std::unique_ptr<VolumeSource> (*openDicomSource)(const std::vector<std::string>& files, const SourceOptions& options);
  std::unique_ptr<VolumeSource> (*openDicomSeries)(const std::vector<std::string>& files, const SourceOptions& options,
                                                   const std::string& chosenFile, const std::string& what);
  bool (*isDicomVolumeFile)(const std::string& file, const SourceOptions& options);
  std::unique_ptr<VolumeSource> (*openDicomDir)(const std::string& path, const SourceOptions& options);
};
#define VOXBRICK_DICOM_ENTRY voxbrick_module_gdcm_dicom_v1

}  // namespace voxbrick::store
