// Constructors of the concrete ingest sources; openSource() in SourceFactory.cpp picks one by the input's form.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "brickstore/VolumeSource.h"

namespace voxbrick::store {

/// Raw voxels: options.dims and options.type are required; options.bigEndian, headerBytes and spacing apply.
/// Throws InputError when the file size does not equal headerBytes + dims * type size.
std::unique_ptr<VolumeSource> openRawSource(const std::string& path, const SourceOptions& options);

/// NRRD (attached .nrrd or detached .nhdr header; raw or gzip encoding).
std::unique_ptr<VolumeSource> openNrrdSource(const std::string& path, const SourceOptions& options);

/// NIfTI-1 single file (.nii or .nii.gz), scl_slope/scl_inter applied.
std::unique_ptr<VolumeSource> openNiftiSource(const std::string& path, const SourceOptions& options);

/// An OpenVDB float grid (by name, or the first float grid), over its active voxels' bounding box.
std::unique_ptr<VolumeSource> openVdbSource(const std::string& path, const SourceOptions& options);

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

/// A TIFF stack: one multi-page file (`files` of size one) or single-page files in the given order; single channel
/// u8, u16, i16 or f32 pages of one size. Spacing is options.spacing (1,1,1 unless given).
std::unique_ptr<VolumeSource> openTiffSource(const std::vector<std::string>& files, const SourceOptions& options);

/// One time point and channel (options.time, options.channel) of an OME-Zarr directory (ZarrSource.cpp): level 0,
/// with the Zarr's own coarser levels offered through ownLevel() where they halve each axis.
std::unique_ptr<VolumeSource> openZarrSource(const std::string& dir, const SourceOptions& options);

/// A synthetic field; `spec` is what follows "synthetic:", e.g. "marschner-lobb,n=64".
std::unique_ptr<VolumeSource> openSyntheticSource(const std::string& spec, const SourceOptions& options);

}  // namespace voxbrick::store
