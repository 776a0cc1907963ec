// The filter precision probe (FilterProbe.h): one draw of kFilterProbeFractions fragments, each a known fraction
// between two texels (shaders/filter_probe.frag.glsl over raycast.vert.glsl's full-screen triangle).
#include "render/gl/FilterProbe.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "render/gl/GlObjects.h"

namespace voxbrick::render {

FilterPrecision measureFilterPrecision(const GlContext& context, GLenum internalFormat) {
  const Gl& gl = context.gl();
  Texture texels(gl, GL_TEXTURE_3D);
  texels.bind(0);
  const float values[2] = {0.0f, 1.0f};
  gl.glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  gl.glTexImage3D(GL_TEXTURE_3D, 0, GLint(internalFormat), 2, 1, 1, 0, GL_RED, GL_FLOAT, values);
  gl.glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  gl.glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  for (GLenum wrap : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R})
    gl.glTexParameteri(GL_TEXTURE_3D, wrap, GL_CLAMP_TO_EDGE);

  const Program program(
      gl, ProgramSources::fromFiles(
              "filter-probe", {{GL_VERTEX_SHADER, "raycast.vert.glsl"}, {GL_FRAGMENT_SHADER, "filter_probe.frag.glsl"}},
              {"PROBE_FRACTIONS " + std::to_string(kFilterProbeFractions)}));
  program.set(program.requireUniform("uTexels"), 0);
  const VertexArray vao(gl);
  const Framebuffer target = Framebuffer::withColor(gl, kFilterProbeFractions, 1, GL_RGBA32F);
  target.bind();
  program.use();
  vao.bind();
  gl.glDrawArrays(GL_TRIANGLES, 0, 3);
  const std::vector<float> pixels = target.readRgba();
  gl.glUseProgram(0);
  gl.glBindVertexArray(0);
  gl.glBindFramebuffer(GL_FRAMEBUFFER, 0);
  gl.glBindTexture(GL_TEXTURE_3D, 0);
  checkGlError(gl, "measureFilterPrecision");

  FilterPrecision out;
  std::vector<float> fetched;
  for (int i = 0; i < kFilterProbeFractions; ++i) {
    const double exact = (i + 0.5) / kFilterProbeFractions;
    out.maxWeightError = std::max(out.maxWeightError, std::abs(double(pixels[size_t(i) * 4]) - exact));
    fetched.push_back(pixels[size_t(i) * 4]);
  }
  std::sort(fetched.begin(), fetched.end());
  fetched.erase(std::unique(fetched.begin(), fetched.end()), fetched.end());
  if (fetched.size() < size_t(kFilterProbeFractions)) {
    // Quantised: the weights take fewer values than there are fractions; their step is the smallest gap.
    double step = 1;
    for (size_t i = 1; i < fetched.size(); ++i) step = std::min(step, double(fetched[i]) - double(fetched[i - 1]));
    out.weightStep = step;
  }
  return out;
}

}  // namespace voxbrick::render
