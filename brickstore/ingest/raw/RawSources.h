// The dense file readers: raw voxels, NRRD and NIfTI-1, their voxels streamed through a DenseSource.
#pragma once

#include <memory>
#include <string>

#include "brickstore/source/VolumeSource.h"

namespace voxbrick::store {

/// Raw voxels: options.dims and options.type are required; options.bigEndian, headerBytes and spacing apply.
/// Throws InputError when the file size does not equal headerBytes + dims * type size.
std::unique_ptr<VolumeSource> openRawSource(const std::string& path, const SourceOptions& options);

/// NRRD (attached .nrrd or detached .nhdr header; raw or gzip encoding).
std::unique_ptr<VolumeSource> openNrrdSource(const std::string& path, const SourceOptions& options);

/// NIfTI-1 single file (.nii or .nii.gz), scl_slope/scl_inter applied.
std::unique_ptr<VolumeSource> openNiftiSource(const std::string& path, const SourceOptions& options);

}  // namespace voxbrick::store
