// Full-screen passes drawn in bands of rows, so that a cancelled frame stops within a band's work (the frame ray
// caster and the mesh ray caster).
#pragma once

#include "render/gl/Checkpoints.h"
#include "render/gl/GlObjects.h"

namespace voxbrick::render {

/// Rows of a band of drawInBands.
inline constexpr int kBandRows = 64;

/// Draws the bound program's full-screen triangle (three vertices, no attributes) over a width x height target in
/// bands of kBandRows rows, scissored, pacing `checkpoints` after each band, so that a frame given up stops within
/// a band's work. The scissor test is off afterwards, also when FrameCancelled is thrown.
void drawInBands(const Gl& gl, int width, int height, Checkpoints& checkpoints);

}  // namespace voxbrick::render
