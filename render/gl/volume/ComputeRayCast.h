// The frame ray caster's compute kernel (shaders/raycast.comp.glsl): the batch's march dispatched in workgroups of
// VB_RAYCAST_GROUP_X x VB_RAYCAST_GROUP_Y pixels (render/gl/Bindings.h), each invocation compositing its pixel into
// the compositor's target itself, instead of one blended fragment per pixel. The march is the fragment kernel's
// (shaders/volume_march.glsl), so the samples, their order and their sum are the same; only the last blend is done
// in the program rather than by the blending unit.
//
// Why a second kernel: on a data-centre GPU (NVIDIA Hopper) the graphics pipeline reaches only a few of the chip's
// clusters, while compute work is spread over all of them. On llvmpipe both run on the same threads.
#pragma once

#include "render/gl/Checkpoints.h"
#include "render/gl/Compositor.h"
#include "render/gl/GlContext.h"
#include "render/gl/volume/VolumePrograms.h"

namespace voxbrick::render {

/// Dispatches `program` (a compute ray caster variant, its frame and cells set) over width x height pixels of
/// `compositor`'s target, in bands or tiles of whole workgroups sized as drawInBands sizes its bands
/// (render/gl/Bands.h: forEachTile), pacing `checkpoints` after each so that a cancelled frame stops within one.
/// Between batches no silhouette map is needed: the program leaves pixels whose opacity reached the threshold.
/// Ends with the memory barriers that make its image stores visible to the next batch's loads, to the readback, to
/// a clear and to the counters' read, also when FrameCancelled is thrown.
void dispatchRayCast(const Gl& gl, const VolumeProgram& program, const Compositor& compositor, int width, int height,
                     Checkpoints& checkpoints, double samplesPerPixel);

}  // namespace voxbrick::render
