// Frame latency percentiles over a bounded window.
#include "server/LatencyWindow.h"

#include <algorithm>
#include <vector>

namespace voxbrick::server {

void LatencyWindow::record(double ms) {
  std::lock_guard lock(mMutex);
  mSamples.push_back({Clock::now(), ms});
  if (mSamples.size() > kKeep) mSamples.pop_front();
}

nlohmann::json LatencyWindow::toJson() const {
  std::vector<double> ms;
  int64_t recent = 0;
  {
    std::lock_guard lock(mMutex);
    const auto now = Clock::now();
    for (const Sample& s : mSamples) {
      ms.push_back(s.ms);
      if (now - s.at < std::chrono::seconds(10)) ++recent;
    }
  }
  std::sort(ms.begin(), ms.end());
  auto pct = [&](double p) { return ms.empty() ? 0.0 : ms[std::min(ms.size() - 1, size_t(p * double(ms.size())))]; };
  return {{"samples", ms.size()},
          {"p50", pct(0.50)},
          {"p95", pct(0.95)},
          {"p99", pct(0.99)},
          {"max", ms.empty() ? 0.0 : ms.back()},
          {"frames_per_s_last_10s", double(recent) / 10.0}};
}

}  // namespace voxbrick::server
