// The frame ray caster's proxy (render/gl/volume/RayCastPass.h): one triangle covering the viewport at window depth 1/2, where
// marching fragments lie for the silhouette map's depth test (render/Marching.h). The fragment program
// (raycast.frag.glsl) finds its pixel's ray from gl_FragCoord alone. The filter precision probe
// (filter_probe.frag.glsl) and the mesh ray caster draw over it too.
void main() {
  const vec2 corner = vec2(float((gl_VertexID & 1) << 2) - 1.0, float((gl_VertexID & 2) << 1) - 1.0);
  gl_Position = vec4(corner, 0.0, 1.0);
}
