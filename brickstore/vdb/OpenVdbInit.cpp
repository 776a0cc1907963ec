// One-time OpenVDB initialisation.
#include "brickstore/vdb/OpenVdbInit.h"

#include <openvdb/openvdb.h>

#include <mutex>

namespace voxbrick::store {

void initializeOpenVdb() {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
}

}  // namespace voxbrick::store
