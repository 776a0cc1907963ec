// The counters of marching fragments.
#include "render/gl/SampleCounters.h"

#include <array>

namespace voxbrick::render {
namespace {

constexpr size_t kCounters = 3;  // fragments, samples taken, samples left by termination: (low, high) words each

}  // namespace

void SampleCounters::reset() {
  const std::array<uint32_t, 2 * kCounters> zero{};
  mBuffer.allocate(GL_SHADER_STORAGE_BUFFER, sizeof(zero), zero.data(), GL_DYNAMIC_COPY);
  mGl.glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, mBuffer.id());
}

void SampleCounters::read(FrameStats& stats) const {
  std::array<uint32_t, 2 * kCounters> words{};
  mBuffer.read(0, sizeof(words), words.data());
  auto counter = [&](size_t i) { return int64_t((uint64_t(words[2 * i + 1]) << 32) | words[2 * i]); };
  stats.fragments = counter(0);
  stats.samples = counter(1);
  stats.samplesTerminated = counter(2);
}

}  // namespace voxbrick::render
