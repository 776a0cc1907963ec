#version 430 core
// The preamble of every voxbrick program: version and precision. The stage's own #define follows it (VERTEX_STAGE,
// GEOMETRY_STAGE, FRAGMENT_STAGE, COMPUTE_STAGE), then the feature #defines, then a program's library of helpers if
// it has one (slicer.glsl, after "#line 1 2"), then "#line 1 1" and the stage's own file.

precision highp float;
precision highp int;
