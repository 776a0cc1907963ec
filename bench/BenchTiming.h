// Timing for the bench tools: the median of repeated runs.
#pragma once

#include <algorithm>
#include <chrono>
#include <vector>

namespace voxbrick::bench {

/// The median time of `repeats` runs of `f`, in milliseconds.
template <class F>
double medianMs(int repeats, F&& f) {
  std::vector<double> ms;
  for (int i = 0; i < repeats; ++i) {
    const auto start = std::chrono::steady_clock::now();
    f();
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  }
  std::sort(ms.begin(), ms.end());
  return ms[ms.size() / 2];
}

}  // namespace voxbrick::bench
