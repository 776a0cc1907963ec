// Opening an input by its form (openSource), and every reader's own opener, for a caller that names the format.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "brickstore/ingest/dicom/DicomSources.h"
#include "brickstore/ingest/raw/RawSources.h"
#include "brickstore/ingest/synthetic/SyntheticSource.h"
#include "brickstore/ingest/tiff/TiffSource.h"
#include "brickstore/ingest/vdb/VdbSource.h"
#include "brickstore/ingest/zarr/ZarrSource.h"
#include "brickstore/source/VolumeSource.h"

namespace voxbrick::store {

/// Opens INPUT by its form: "synthetic:NAME[,k=v...]", *.vdb, *.nrrd / *.nhdr, *.nii / *.nii.gz, a DICOM file
/// (*.dcm or a file with the DICM preamble: the series it belongs to, from its directory), *.tif / *.tiff (a stack of
/// pages), an OME-Zarr directory (its levels too, VolumeSource::ownLevel), a directory (its DICOM series or its TIFF
/// files), a glob pattern ("dir/*.tif"), a DICOMweb series or study (dicomweb[s]://HOST/PATH/studies/UID[/series/UID]:
/// fetched into a folder under options.dicomWeb.downloadDir, removed with the source, and read as that folder), else
/// raw.
/// Throws InputError naming the file and the problem.
std::unique_ptr<VolumeSource> openSource(const std::string& input, const SourceOptions& options);

/// Opens several files as one volume: all DICOM (one series, one slice a file) or all TIFF (single-page files,
/// z in natural name order). One input is the same as openSource(input). Throws InputError otherwise.
std::unique_ptr<VolumeSource> openSource(const std::vector<std::string>& inputs, const SourceOptions& options);

}  // namespace voxbrick::store
