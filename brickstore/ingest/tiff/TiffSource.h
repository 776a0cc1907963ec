// TIFF stacks (libtiff, private to this folder).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "brickstore/source/VolumeSource.h"

namespace voxbrick::store {

/// A TIFF stack: one multi-page file (`files` of size one) or single-page files in the given order; single channel
/// u8, u16, i16 or f32 pages of one size. Spacing is options.spacing (1,1,1 unless given).
std::unique_ptr<VolumeSource> openTiffSource(const std::vector<std::string>& files, const SourceOptions& options);

}  // namespace voxbrick::store
