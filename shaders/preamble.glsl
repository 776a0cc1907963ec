#version 430 core
// The preamble of every voxbrick program: version and precision, then render/gl/Bindings.h (the binding points C++
// shares). The stage's own #define follows (VERTEX_STAGE, GEOMETRY_STAGE, FRAGMENT_STAGE, COMPUTE_STAGE), then the
// feature #defines, then a program's libraries of helpers if it has any (slicer.glsl, volume_*.glsl, tet.glsl: source
// strings 2, 3, ... after "#line 1 N"), then "#line 1 1" and the stage's own file.

precision highp float;
precision highp int;
