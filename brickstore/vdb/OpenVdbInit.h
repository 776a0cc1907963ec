// OpenVDB's one-time registration of grid types, shared by every part of the store that touches the library.
#pragma once

namespace voxbrick::store {

/// Calls openvdb::initialize() once per process; safe from any thread.
void initializeOpenVdb();

}  // namespace voxbrick::store
