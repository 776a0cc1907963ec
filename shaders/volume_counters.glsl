// What the marching fragments (slab.frag.glsl, raycast.frag.glsl) and the compute ray caster's invocations
// (raycast.comp.glsl, each counted as a fragment) did, as 64-bit counters of two words (low, high): fragments
// started, samples taken, samples left untaken when the fragment's own opacity reached the termination threshold
// (VB_COUNTER_... of render/gl/Bindings.h; render/gl/SampleCounters.h reads them).
#if defined(FRAGMENT_STAGE) || defined(COMPUTE_STAGE)

layout(std430, binding = VB_BINDING_SAMPLE_COUNTERS) buffer SlabCounters { uint uCounters[2 * VB_COUNTERS]; };

void count(int counter, uint n) {
  const uint before = atomicAdd(uCounters[2 * counter], n);
  if (before + n < before) atomicAdd(uCounters[2 * counter + 1], 1u);
}

#endif
