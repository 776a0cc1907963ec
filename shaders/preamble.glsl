#version 430 core
// The preamble of every voxbrick program: version, precision, and helpers any stage may use. The feature #defines
// and a "#line 1 1" follow it, then the stage's own file.

precision highp float;
precision highp int;

// The corner of the unit cube with bit 0 = x, bit 1 = y, bit 2 = z (render/SliceTables.h numbers box corners so).
vec3 unitCorner(int corner) {
  return vec3(float(corner & 1), float((corner >> 1) & 1), float((corner >> 2) & 1));
}
