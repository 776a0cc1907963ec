// Checks shared by the ingest tests: a call is refused with a store::InputError whose message names the problem;
// opening and reading a whole input, or its values; finding a DICOM element to damage.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "brickstore/format/Errors.h"
#include "brickstore/ingest/Sources.h"

namespace voxbrick::test {

/// Expects `fn` to throw store::InputError with every one of `words` in its message.
inline void expectRefused(const std::function<void()>& fn, const std::vector<std::string>& words) {
  try {
    fn();
    ADD_FAILURE() << "no error; expected one with '" << words.front() << "'";
  } catch (const store::InputError& e) {
    const std::string m = e.what();
    for (const std::string& w : words) EXPECT_NE(m.find(w), std::string::npos) << "missing '" << w << "' in: " << m;
  }
}

/// Opens `input` as a volume source and reads every slice: what prep does before writing anything.
inline std::function<void()> openAndRead(const std::filesystem::path& input, store::SourceOptions options = {}) {
  return [input, options] {
    auto source = store::openSource(input.string(), options);
    const store::VolumeInfo& info = source->info();
    std::vector<char> slab(size_t(info.dims.x * info.dims.y) * store::valueSize(info.type));
    for (int64_t z = 0; z < info.dims.z; ++z) source->readSlices(1, slab.data());
  };
}

/// The whole volume of `source` as doubles, read `batch` slices at a time.
inline std::vector<double> readValues(store::VolumeSource& source, int64_t batch = 1) {
  const store::VolumeInfo& info = source.info();
  const int64_t plane = info.dims.x * info.dims.y;
  std::vector<double> out;
  std::vector<unsigned char> bytes(size_t(plane * batch) * store::valueSize(info.type));
  for (int64_t z = 0; z < info.dims.z; z += batch) {
    const int64_t n = std::min(batch, info.dims.z - z);
    source.readSlices(n, bytes.data());
    store::dispatchType(info.type, [&](auto zero) {
      using T = decltype(zero);
      const T* v = reinterpret_cast<const T*>(bytes.data());
      for (int64_t i = 0; i < n * plane; ++i) out.push_back(double(v[i]));
    });
  }
  return out;
}

/// The offset of an explicit-VR element's header (tag and VR, little endian) in `bytes`.
inline size_t elementAt(const std::vector<char>& bytes, uint16_t group, uint16_t element, const char* vr) {
  const char header[6] = {char(group & 0xFF), char(group >> 8), char(element & 0xFF), char(element >> 8), vr[0], vr[1]};
  const auto it = std::search(bytes.begin(), bytes.end(), header, header + 6);
  EXPECT_NE(it, bytes.end()) << "no element " << group << "," << element;
  return size_t(it - bytes.begin());
}

}  // namespace voxbrick::test
