// The filter precision probe (render/gl/FilterProbe.h), drawn over raycast.vert.glsl's full-screen triangle into a
// PROBE_FRACTIONS x 1 frame: fragment column i fetches the 2-texel row uTexels (0 and 1, GL_LINEAR) at texel
// coordinate 0.5 + f, f = (i + 0.5) / PROBE_FRACTIONS, i.e. the normalised coordinate (0.5 + f) / 2, exact in float.
// Red: what the filter returned; green: f.
uniform sampler3D uTexels;
out vec4 fragColor;

void main() {
  const float f = (floor(gl_FragCoord.x) + 0.5) / float(PROBE_FRACTIONS);
  fragColor = vec4(texture(uTexels, vec3((0.5 + f) * 0.5, 0.5, 0.5)).r, f, 0.0, 1.0);
}
