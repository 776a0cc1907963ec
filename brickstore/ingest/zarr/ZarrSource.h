// An OME-Zarr as prep's input.
#pragma once

#include <memory>
#include <string>

#include "brickstore/source/VolumeSource.h"

namespace voxbrick::store {

/// One time point and channel (options.time, options.channel) of an OME-Zarr directory (ZarrSource.cpp): level 0,
/// with the Zarr's own coarser levels offered through ownLevel() where they halve each axis.
std::unique_ptr<VolumeSource> openZarrSource(const std::string& dir, const SourceOptions& options);

}  // namespace voxbrick::store
