// An OpenVDB float grid as prep's input.
#pragma once

#include <memory>
#include <string>

#include "brickstore/source/VolumeSource.h"

namespace voxbrick::store {

/// An OpenVDB float grid (by name, or the first float grid), over its active voxels' bounding box.
std::unique_ptr<VolumeSource> openVdbSource(const std::string& path, const SourceOptions& options);

}  // namespace voxbrick::store
