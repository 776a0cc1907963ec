// Vertex program of texture slabs: the back faces of one box per instance (a brick, or a sub-block box), drawn once
// per slab of consecutive global planes. The fragment program (slab.frag.glsl) marches its pixel's ray
// through the slab's planes and keeps the samples in the voxels the box owns.
//
// Why back faces of the box, and not the slab's front plane: a ray can enter the box through a side face between
// two planes of the slab, where the front plane's polygon does not cover its pixel. The faces of a convex box facing
// away from the eye cover every pixel whose ray crosses the box exactly once, also with the eye inside the box
// (where front faces lie behind the near plane). Layout: SlabInstance in render/volume/SliceTables.h.
//
// Each pixel whose ray crosses the box gets one fragment per slab, also where its ray has no sample in the slab
// inside the box (the fragment then blends nothing); back faces in front of the slab are clipped away.

layout(location = 0) in vec3 aBoxMin;
layout(location = 1) in vec3 aBoxMax;
layout(location = 3) in ivec4 aPayload;
layout(location = 4) in int aFirstPlane;
layout(location = 5) in ivec3 aOwnLo;
layout(location = 6) in ivec3 aOwnHi;
layout(location = 7) in int aPlaneCount;

uniform mat4 uViewProj;
uniform vec3 uPlaneNormal;  // unit, from the eye into the scene
uniform float uPlaneIncr;   // distance between consecutive global planes

out vec3 vWorld;
flat out ivec4 vPayload;
flat out ivec3 vOwnLo;
flat out ivec3 vOwnHi;
flat out float vPlaneDistance;
flat out int vFirstPlane;
flat out int vPlaneCount;

// The 12 triangles of a box, two per face, counter-clockwise seen from outside (corner bits: 1 = x, 2 = y, 4 = z).
const int kCorners[36] = int[36](0, 2, 3, 0, 3, 1,   // -z
                                 4, 5, 7, 4, 7, 6,   // +z
                                 0, 4, 6, 0, 6, 2,   // -x
                                 1, 3, 7, 1, 7, 5,   // +x
                                 0, 1, 5, 0, 5, 4,   // -y
                                 2, 6, 7, 2, 7, 3);  // +y

void main() {
  const int corner = kCorners[gl_VertexID];
  const vec3 world = mix(aBoxMin, aBoxMax, bvec3((corner & 1) != 0, (corner & 2) != 0, (corner & 4) != 0));
  vWorld = world;
  vPayload = aPayload;
  vOwnLo = aOwnLo;
  vOwnHi = aOwnHi;
  vPlaneDistance = 0.0;
  vFirstPlane = aFirstPlane;
  vPlaneCount = aPlaneCount;
  gl_Position = uViewProj * vec4(world, 1.0);
  // Every fragment of a slab gets the same window depth, exactly: render/gl/volume/SlabPass.h draws with depth clamping and a
  // depth range of one value (glDepthRange(d, d)), so that the silhouette map can test it for equality.
  gl_Position.z = 0.0;
  // A ray with samples in this slab inside the box leaves the box behind the slab's first plane, so back faces in
  // front of that plane (less one plane, for round-off) cover no such ray: clip them away. (Those behind the slab's
  // last plane cannot be clipped so: a ray crossing the slab may leave the box far behind it.)
  gl_ClipDistance[0] = dot(uPlaneNormal, world) - float(aFirstPlane - 1) * uPlaneIncr;
}
