// The frame ray caster's march (render/gl/volume/RayCastPass.h), shared by its two kernels: the fragment program
// (raycast.frag.glsl, one fragment per pixel) and the compute program (raycast.comp.glsl, one invocation per pixel).
// marchPixel gives a pixel's samples on the global planes, through every cell of the batch, composited front to back
// in registers (premultiplied), stopping at the termination threshold; what it did is counted (volume_counters.glsl).
// A sample belongs to the cell that owns its point as boxes decide between them (volume_ownership.glsl: on the
// 1/256-voxel grid, half-open with the face towards the eye included) and to the volume as slabs decide at its
// outline, so that it takes the samples slabs take. A cell of level m takes the planes whose index is a multiple of
// 2^m, each standing for a segment 2^m planes long. Cells with nothing to draw, and planes a coarse cell does not
// take, are stepped over to the cell's exit. With PRE_INTEGRATION each segment between two samples is classified from
// the pre-integrated table.
#if defined(FRAGMENT_STAGE) || defined(COMPUTE_STAGE)

// The cell table (render/gl/volume/CellTable.h). Per cell: its brick's atlas payload (xyz) and level (w); w = -1:
// nothing to draw there (x: log2 of the block to leap), -2: a brick of another batch. One grid of cells, or with
// PAGED_CELLS a directory holding per block of 8^3 cells its page, or -1 (every cell has nothing to draw) or -2
// (every cell is another batch's), over pages of 512 cells, x fastest.
#ifdef PAGED_CELLS
layout(binding = VB_UNIT_CELL_DIRECTORY) uniform isampler3D uCellDirectory;
layout(binding = VB_UNIT_CELLS) uniform isamplerBuffer uCells;
#else
layout(binding = VB_UNIT_CELLS) uniform isampler3D uCells;
#endif
uniform int uCellShift;     // a cell is 2^uCellShift level-0 voxels across
uniform vec3 uCellCount;   // cells along x, y, z
uniform float uPlaneIncr;    // distance between consecutive global planes
uniform float uTermination;  // early ray termination: stop once the ray's own opacity reaches it (> 1: never)

#ifdef RAY_REQUESTS
// Ray-driven residency (render/gl/volume/RayRequests.h): a bit per level-0 brick (x fastest, from word 1), set by a
// ray that reaches a cell marked VB_REQUEST_FLAG (its brick drawn from a stand-in while it is not resident), and in
// word 0 the number of bits set, so that a frame that requested nothing is read back as one word. A ray that stops at
// the termination threshold sets no bit for what lies behind.
layout(std430, binding = VB_BINDING_RAY_REQUESTS) buffer RayRequests { uint uRequests[]; };
uniform ivec4 uRequestGrid;  // level-0 bricks along x, y, z; w: level-0 voxels a brick
#endif

// The ray caster has no box: each sample's brick comes from the cell table, and is set here before the sample is
// read.
ivec4 gPayload = ivec4(0);
ivec4 brickPayload() { return gPayload; }

ivec4 cellEntry(ivec3 cell) {
#ifdef PAGED_CELLS
  const int page = texelFetch(uCellDirectory, cell >> 3, 0).x;
  if (page < 0) return page == -1 ? ivec4(3, 0, 0, -1) : ivec4(0, 0, 0, -2);
  const ivec3 local = cell & 7;
  return texelFetch(uCells, page * 512 + (local.z * 8 + local.y) * 8 + local.x);
#else
  return texelFetch(uCells, cell, 0);
#endif
}

// The ray of the pixel at window coordinates `window` (its centre) through the batch: premultiplied colour and
// opacity. A ray that misses the volume is not counted.
vec4 marchPixel(vec2 window) {
  const PixelRay ray = pixelRayAt(window);
  const vec3 origin = ray.origin, direction = ray.direction, o = ray.o, inv = ray.inv;
  const float along = ray.along, start = ray.start;
  const vec2 range = rayBoxRange(o, inv, vec3(-1.0 / 128.0), uDims + 1.0 / 128.0);
  if (range.x > range.y) return vec4(0.0);
  int k = int(floor((start + along * range.x) / uPlaneIncr)) - 1;
  const int last = int(ceil((start + along * range.y) / uPlaneIncr)) + 2;
  // Planes at least 1/64 voxel inside the volume, one plane in from either end, need no outline test.
  const vec2 inside = rayBoxRange(o, inv, vec3(1.0 / 64.0), uDims - 1.0 / 64.0);
  const int insideFirst = int(ceil((start + along * inside.x) / uPlaneIncr)) + 1;
  const int insideLast = int(floor((start + along * inside.y) / uPlaneIncr)) - 1;
  // The outline is tested on the unrounded point, except faces the planes are parallel to (as slabs test it).
  const bvec3 parallel = greaterThan(abs(uViewDir), vec3(0.9999));
  const bvec3 eyeAtHi = lessThan(uViewDir, vec3(0.0));  // the cell face at hi faces the eye: owned, lo is not
  const float cellScale = 1.0 / float(1 << uCellShift);
  const float ratio = segmentRatio(origin + direction);
#ifdef PRE_INTEGRATION
  float back = 0.0;
  int backPlane = k - 1;  // the plane `back` was read on
  ivec3 backCell = ivec3(-1);
#endif
  vec4 sum = vec4(0.0);
  uint taken = 0u, untaken = 0u;
#ifdef RAY_REQUESTS
  int requested = -1;  // the brick this ray last requested: one atomic per brick crossed, not per sample
#endif
  while (k < last) {
    if (sum.a >= uTermination) {
      untaken = uint(last - k);  // planes, an upper bound of the samples left
      break;
    }
    const float planeDistance = float(k) * uPlaneIncr;
    const float t = (planeDistance - start) / along;
    const vec3 world = origin + direction * t;
    const vec3 voxel = world * uInvSpacing + uHalfDims;
    const vec3 snapped = ownershipGrid(voxel);
    if (k < insideFirst || k > insideLast) {
      const vec3 outline = mix(voxel, snapped, parallel);
      if (t < 0.0 || !ownedBy(outline, outline, vec3(0.0), uDims)) {
        ++k;
        continue;
      }
    }
    const vec3 scaled = snapped * cellScale;
    const ivec3 cell = clamp(ivec3(mix(floor(scaled), ceil(scaled) - 1.0, eyeAtHi)), ivec3(0), ivec3(uCellCount) - 1);
    ivec4 entry = cellEntry(cell);
#ifdef RAY_REQUESTS
    if (entry.w >= VB_REQUEST_FLAG) {
      entry.w -= VB_REQUEST_FLAG;
      const ivec3 brick = (cell << uCellShift) / uRequestGrid.w;
      const int index = (brick.z * uRequestGrid.y + brick.y) * uRequestGrid.x + brick.x;
      if (index != requested) {
        const uint bit = 1u << uint(index & 31);
        if ((atomicOr(uRequests[1 + (index >> 5)], bit) & bit) == 0u) atomicAdd(uRequests[0], 1u);
        requested = index;
      }
    }
#endif
    const int level = levelOf(entry.w);
    const int stride = 1 << max(level, 0);
    if (level < 0 || (k & (stride - 1)) != 0) {
      // Nothing to draw in this cell, or a plane its level does not take. A cell with nothing to draw at all adds
      // nothing even on its faces (render/gl/volume/CellTable.h): on to the first plane at its exit. Otherwise on to the
      // plane one before the last the ray has in the cell, or the next plane the level takes if that comes first,
      // so that points near the faces are owned plane by plane. At least the next plane.
      // A cell with nothing to draw leaps out of its block of 2^entry.x cells with nothing to draw.
      const int leap = level == -1 ? entry.x : 0;
      const ivec3 blockLo = (cell >> leap) << (leap + uCellShift);
      const float exitT = rayBoxRange(o, inv, vec3(blockLo), vec3(blockLo + (1 << (leap + uCellShift)))).y;
      const float exitPlane = (start + along * exitT) / uPlaneIncr;
      const int next = level == -1 ? int(ceil(exitPlane - 0.01))
                       : level < 0 ? int(floor(exitPlane)) - 1
                                   : min(int(floor(exitPlane)) - 1, (k + stride - 1) & ~(stride - 1));
      k = max(k + 1, next);
      continue;
    }
    gPayload = entry;
#ifdef PRE_INTEGRATION
    // As slabs: the back sample from this cell's brick, within half a voxel of the cell.
    const float value = backPlane == k && backCell == cell ? back : sampleAt(voxel);
    const vec3 next = voxelOnPlane(origin, direction, start, along, planeDistance + uPlaneIncr * float(stride));
    back = sampleAt(clamp(next, vec3(cell << uCellShift) - 0.5, vec3((cell + 1) << uCellShift) + 0.5));
    backPlane = k + stride;
    backCell = cell;
#else
    const float value = sampleAt(voxel);
#endif
    ++taken;
#ifdef ROOFLINE
    sum = vec4(value * 1e-9);  // below any termination threshold: every sample taken
#elif defined(PRE_INTEGRATION)
    sum += (1.0 - sum.a) * shade(preIntegrated(value, back, layerCoordinate(ratio * float(stride))), world, voxel);
#else
    sum += (1.0 - sum.a) * shadeSample(world, voxel, value, ratio * float(stride));
#endif
    ++k;
  }
  count(VB_COUNTER_FRAGMENTS, 1u);
  if (taken > 0u) count(VB_COUNTER_SAMPLES, taken);
  if (untaken > 0u) count(VB_COUNTER_SAMPLES_TERMINATED, untaken);
  return sum;
}

#endif
