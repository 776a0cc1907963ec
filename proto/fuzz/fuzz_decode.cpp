// libFuzzer entry point: any input, read as a stream of protocol messages (see FuzzCheck.h), under tight limits and
// under none.
#include <cstddef>
#include <cstdint>

#include "proto/fuzz/FuzzCheck.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  voxbrick::proto::fuzz::checkStream({data, size}, voxbrick::proto::fuzz::kFuzzLimits);
  voxbrick::proto::fuzz::checkStream({data, size}, voxbrick::proto::fuzz::kNoLimits);
  return 0;
}
