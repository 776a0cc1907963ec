// A bounds check of an OpenVDB file's header, made before OpenVDB reads it: OpenVDB sizes strings, metadata and
// vectors from lengths and counts in the file without comparing them to the file's size, so one damaged field can
// make it allocate (and fill) gigabytes before it fails.
#pragma once

#include <string>

namespace voxbrick::store {

/// Walks the parts of `path` that OpenVDB sizes its allocations from: the file header (magic number, format
/// version), the file's metadata, the grid count, and for each grid its descriptor (name, type, instance parent,
/// stream positions), its compression flags, its metadata (names, type names, value sizes, delayed-load tables) and
/// its transform's type name. Each length and count must fit in the bytes left in the file (and in the grid, where
/// the file records where the grid ends). Throws InputError "<path>: not a readable OpenVDB file (<field> ...)"
/// naming the first field that does not, and IoError when the file cannot be read. Reads a few kilobytes; the tree
/// (topology and voxel buffers) is left to OpenVDB.
void checkVdbHeader(const std::string& path);

}  // namespace voxbrick::store
