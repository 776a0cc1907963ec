// The filter precision probe (FilterProbe.h): one draw of 4096 fragments, each a known fraction between two texels.
#include "render/gl/FilterProbe.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "render/gl/GlObjects.h"

namespace voxbrick::render {

namespace {

constexpr int kFractions = 4096;

// A full-screen triangle from gl_VertexID; fragment column i fetches at texel coordinate 0.5 + (i + 0.5) / 4096 of
// a 2-texel row, i.e. the normalised coordinate (0.5 + f) / 2, which is exact in float.
constexpr const char* kVertex = R"(
void main() {
  const vec2 corner = vec2(float((gl_VertexID & 1) << 2) - 1.0, float((gl_VertexID & 2) << 1) - 1.0);
  gl_Position = vec4(corner, 0.0, 1.0);
}
)";

constexpr const char* kFragment = R"(
uniform sampler3D uTexels;
out vec4 fragColor;
void main() {
  const float f = (floor(gl_FragCoord.x) + 0.5) / 4096.0;
  fragColor = vec4(texture(uTexels, vec3((0.5 + f) * 0.5, 0.5, 0.5)).r, f, 0.0, 1.0);
}
)";

}  // namespace

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

  ProgramSources sources;
  sources.name = "filter-probe";
  sources.preamble = "#version 430 core\n";
  sources.stages = {{GL_VERTEX_SHADER, "filter_probe.vert", kVertex},
                    {GL_FRAGMENT_SHADER, "filter_probe.frag", kFragment}};
  const Program program(gl, sources);
  program.set(program.requireUniform("uTexels"), 0);
  const VertexArray vao(gl);
  const Framebuffer target = Framebuffer::withColor(gl, kFractions, 1, GL_RGBA32F);
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
  for (int i = 0; i < kFractions; ++i) {
    const double exact = (i + 0.5) / kFractions;
    out.maxWeightError = std::max(out.maxWeightError, std::abs(double(pixels[size_t(i) * 4]) - exact));
    fetched.push_back(pixels[size_t(i) * 4]);
  }
  std::sort(fetched.begin(), fetched.end());
  fetched.erase(std::unique(fetched.begin(), fetched.end()), fetched.end());
  if (fetched.size() < size_t(kFractions)) {
    // Quantised: the weights take fewer values than there are fractions; their step is the smallest gap.
    double step = 1;
    for (size_t i = 1; i < fetched.size(); ++i) step = std::min(step, double(fetched[i]) - double(fetched[i - 1]));
    out.weightStep = step;
    out.subTexelBits = int(std::lround(std::log2(1 / step)));
  }
  return out;
}

}  // namespace voxbrick::render
