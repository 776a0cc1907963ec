// The slab silhouette map's termination pass: one triangle covering the viewport, at depth 0 (window), so that
// where the fragment program keeps a fragment the depth test (GL_LESS against 1) writes 0: the pixel is terminated.
void main() {
  const vec2 corner = vec2(float((gl_VertexID & 1) << 2) - 1.0, float((gl_VertexID & 2) << 1) - 1.0);
  gl_Position = vec4(corner, -1.0, 1.0);
}
