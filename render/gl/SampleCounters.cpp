// The counters of marching fragments.
#include "render/gl/SampleCounters.h"

#include <array>

#include "render/gl/Bindings.h"

namespace voxbrick::render {
namespace {

// SlabCounters of volume_counters.glsl (and tet_ray.frag.glsl): VB_COUNTERS counters of (low, high) words each.
constexpr size_t kCounters = VB_COUNTERS;

}  // namespace

void SampleCounters::reset() {
  const std::array<uint32_t, 2 * kCounters> zero{};
  mBuffer.allocate(GL_SHADER_STORAGE_BUFFER, sizeof(zero), zero.data(), GL_DYNAMIC_COPY);
  mGl.glBindBufferBase(GL_SHADER_STORAGE_BUFFER, VB_BINDING_SAMPLE_COUNTERS, mBuffer.id());
}

void SampleCounters::read(FrameStats& stats) const {
  std::array<uint32_t, 2 * kCounters> words{};
  mBuffer.read(0, sizeof(words), words.data());
  auto counter = [&](size_t i) { return int64_t((uint64_t(words[2 * i + 1]) << 32) | words[2 * i]); };
  stats.fragments = counter(VB_COUNTER_FRAGMENTS);
  stats.samples = counter(VB_COUNTER_SAMPLES);
  stats.samplesTerminated = counter(VB_COUNTER_SAMPLES_TERMINATED);
}

}  // namespace voxbrick::render
