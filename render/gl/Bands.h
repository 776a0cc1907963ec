// Full-screen passes drawn in bands of rows (or tiles of a row), sized by their predicted cost, so that a cancelled
// frame stops within an interval's work (the frame ray caster and the mesh ray caster); and any draw split the same
// way by the scissor (texture slabs).
#pragma once

#include <functional>

#include "render/gl/Checkpoints.h"
#include "render/gl/GlObjects.h"

namespace voxbrick::render {

/// Rows of a band of drawInBands when the cost does not ask for fewer.
inline constexpr int kBandRows = 64;

/// Calls `tile(x, y, w, h)` once per rectangle covering width x height, pacing `checkpoints` after each: bands of
/// kBandRows rows, or, when the checkpoints have an interval (Checkpoints::intervalSamples) and `samplesPerPixel`
/// (the most samples a pixel of the pass may take) is given, bands of as many rows as the interval holds, down to
/// tiles of part of a row. Each pixel is in exactly one rectangle. What drawTiled and the compute ray caster's
/// dispatches (render/gl/volume/ComputeRayCast.h) split their passes by.
void forEachTile(int width, int height, Checkpoints& checkpoints, double samplesPerPixel,
                 const std::function<void(int x, int y, int w, int h)>& tile);

/// Calls `draw` once per rectangle of forEachTile, with the scissor set to it, pacing `checkpoints` after each. The
/// scissor test is off afterwards, also when FrameCancelled is thrown. Splitting never changes a pixel: each is
/// drawn once, by the same draw.
void drawTiled(const Gl& gl, int width, int height, Checkpoints& checkpoints, double samplesPerPixel,
               const std::function<void()>& draw);

/// drawTiled of the bound program's full-screen triangle (three vertices, no attributes).
void drawInBands(const Gl& gl, int width, int height, Checkpoints& checkpoints, double samplesPerPixel = 0);

/// The bound compute program (workgroups of VB_RAYCAST_GROUP_X x VB_RAYCAST_GROUP_Y pixels, render/gl/Bindings.h)
/// dispatched over width x height pixels in bands or tiles of whole workgroups, sized as drawInBands sizes its bands
/// (each group a pixel of its pixels' cost, so that a band of one row does not leave most of each group idle), pacing
/// `checkpoints` after each. `setTile` is given each dispatch's pixels [xy, zw) before it. Ends with the memory
/// barriers that make the program's image and buffer stores visible to what follows (the next pass's loads, the
/// readback, a clear, the counters' read), also when FrameCancelled is thrown.
void dispatchInTiles(const Gl& gl, int width, int height, Checkpoints& checkpoints, double samplesPerPixel,
                     const std::function<void(const glm::ivec4& tile)>& setTile);

}  // namespace voxbrick::render
