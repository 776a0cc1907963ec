#version 430 core
// The preamble of every voxbrick program: version and precision. The feature #defines follow it, then a program's
// library of helpers if it has one (slicer.glsl, after "#line 1 2"), then "#line 1 1" and the stage's own file.

precision highp float;
precision highp int;
