// Quantities as people read them.
#pragma once

#include <string>

namespace voxbrick::common {

/// A byte count in decimal units, "12.3 MB" ("512 B" below a kilobyte).
std::string formatBytes(double bytes);

}  // namespace voxbrick::common
