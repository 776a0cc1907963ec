// Constructors of the concrete ingest sources; openSource() in SourceFactory.cpp picks one by the input's form.
#pragma once

#include <memory>
#include <string>

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

/// A synthetic field; `spec` is what follows "synthetic:", e.g. "marschner-lobb,n=64".
std::unique_ptr<VolumeSource> openSyntheticSource(const std::string& spec, const SourceOptions& options);

}  // namespace voxbrick::store
