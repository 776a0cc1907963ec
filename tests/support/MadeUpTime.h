#pragma once
// Made-up instants for tests that drive time-dependent code (a link's pacing, a stream's bitrate) with chosen times
// instead of waiting: at(ms) is `ms` milliseconds after one fixed instant of the steady clock.
#include <chrono>
#include <cstdint>

namespace voxbrick::test {

inline std::chrono::steady_clock::time_point at(double ms) {
  static const std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
  return start + std::chrono::microseconds(int64_t(ms * 1000));
}

}  // namespace voxbrick::test
