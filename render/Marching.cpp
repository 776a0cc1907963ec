// The termination pass and the counters of marching fragments.
#include "render/Marching.h"

#include <algorithm>
#include <array>

namespace voxbrick::render {
namespace {

constexpr size_t kCounters = 3;  // fragments, samples taken, samples left by termination: (low, high) words each

}  // namespace

TerminationPass::TerminationPass(const Gl& gl)
    : mGl(gl),
      mProgram(gl, ProgramSources::fromFiles("termination", {{GL_VERTEX_SHADER, "termination.vert.glsl"},
                                                              {GL_FRAGMENT_SHADER, "termination.frag.glsl"}})),
      mTerminationAt(mProgram.requireUniform("uTermination")),
      mAccumulatedAt(mProgram.requireUniform("uAccumulated")),
      mNoAttributes(gl) {}

void TerminationPass::run(double threshold, Compositor& compositor) const {
  compositor.bindSilhouette();
  compositor.accumulated().bind(2);
  mProgram.use();
  mProgram.set(mAccumulatedAt, 2);
  mProgram.set(mTerminationAt, float(threshold));
  mNoAttributes.bind();
  mGl.glDepthMask(GL_TRUE);
  mGl.glDrawArrays(GL_TRIANGLES, 0, 3);
  mGl.glDepthMask(GL_FALSE);
  compositor.bindTarget();
}

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

void drawInBands(const Gl& gl, int width, int height, Checkpoints& checkpoints) {
  gl.glEnable(GL_SCISSOR_TEST);
  try {
    for (int y = 0; y < height; y += kBandRows) {
      gl.glScissor(0, y, width, std::min(kBandRows, height - y));
      gl.glDrawArrays(GL_TRIANGLES, 0, 3);
      checkpoints.pace();
    }
  } catch (...) {
    gl.glDisable(GL_SCISSOR_TEST);  // a cancelled frame leaves the state every pass expects
    throw;
  }
  gl.glDisable(GL_SCISSOR_TEST);
}

}  // namespace voxbrick::render
