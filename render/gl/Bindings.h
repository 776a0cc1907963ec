// The binding points that the C++ passes and the GLSL programs share, defined once: texture units (samplers are
// declared layout(binding = VB_UNIT_...)), image units (layout(binding = VB_IMAGE_...)), shader storage binding points
// (layout(std430, binding = VB_BINDING_...)), the layout of the storage buffers both sides read, and the workgroup
// of the compute programs.
//
// Written in the common subset of C++ and GLSL (include guard, #define, // comments only): C++ includes it, and
// ProgramSources::fromFiles appends it to every program's preamble (embedded as "Bindings.h" by
// cmake/EmbedShaders.cmake), so that a shader and the code that binds its resources use the same names.
#ifndef VOXBRICK_GL_BINDINGS_H
#define VOXBRICK_GL_BINDINGS_H

// Texture units. Two programs may share a unit when they are never drawn with each other's textures.
#define VB_UNIT_ATLAS 0           // the brick atlas (sampler3D uAtlas), render/gl/volume/BrickAtlas.h
#define VB_UNIT_TRANSFER 1        // the transfer function's table (sampler1D uTransfer)
#define VB_UNIT_ACCUMULATED 2     // the compositor's accumulated colour, read by termination.frag.glsl
#define VB_UNIT_PRE_INTEGRATED 3  // the pre-integrated segment table (sampler3D uPreIntegrated), grids and meshes
#define VB_UNIT_CELLS 4           // the frame ray caster's cell pages (isamplerBuffer uCells), gl/volume/CellTable.h
#define VB_UNIT_TET_ENTRY 4       // the mesh ray caster's entry pass: its tet and face (usampler2D uEntry)
#define VB_UNIT_TET_ENTRY_DEPTH 5  // and its depth (sampler2D uEntryDepth)
#define VB_UNIT_CELL_DIRECTORY 6  // the cell table's directory of pages (isampler3D uCellDirectory), CellTable.h

// Image units.
#define VB_IMAGE_ACCUMULATED 0  // the compositor's target, read and written by raycast.comp.glsl (Compositor::bindImage)

// Shader storage buffer binding points.
#define VB_BINDING_SAMPLE_COUNTERS 0   // SlabCounters: the marching fragments' counters, render/gl/SampleCounters.h
#define VB_BINDING_TET_VERTICES 1      // TetVertices: four vec4 a tet (position xyz, scalar w)
#define VB_BINDING_TET_ORDER 2         // TetOrder: the projected tets' visibility order (uint a tet)
#define VB_BINDING_TET_NEIGHBOURS 3    // TetNeighbours: across each face the neighbour (ivec4 a tet)
#define VB_BINDING_BOUNDARY_CORNERS 4  // BoundaryCorners: three vec4 a boundary face
#define VB_BINDING_BOUNDARY_FACES 5    // BoundaryFaces: a boundary face's tet and face (uint)
#define VB_BINDING_RAY_EXITS 6         // RayExits: per pixel, where the last pass left the mesh (float)
#define VB_BINDING_ENTRY_COUNT 7       // EntryCount: the entry pass's kept fragments (uint)
#define VB_BINDING_RAY_REQUESTS 8      // RayRequests: a bit per level-0 brick a ray reached and did not find resident
                                       // (ray-driven residency, render/gl/volume/RayRequests.h)
#define VB_BINDING_FRAME8 9            // Frame8: the finished 8-bit frame, a uint a pixel (finish.comp.glsl)

// Added to a cell table entry's w (a level and rotation, below 4096) where the cell's brick is drawn from a stand-in
// and a ray reaching it records a request (RAY_REQUESTS).
#define VB_REQUEST_FLAG 4096

// SlabCounters: VB_COUNTERS 64-bit counters, each as two uint words (low, high), indexed by these.
#define VB_COUNTER_FRAGMENTS 0           // marching fragments started
#define VB_COUNTER_SAMPLES 1             // samples taken
#define VB_COUNTER_SAMPLES_TERMINATED 2  // samples left untaken when a fragment's opacity reached the threshold
#define VB_COUNTERS 3

// The compute ray caster's workgroup (raycast.comp.glsl, render/gl/volume/ComputeRayCast.h): a tile of pixels, so
// that neighbouring rays, which read neighbouring texels, run together. On llvmpipe groups of 64 invocations or more
// (8 x 8, 16 x 8, 16 x 16, 32 x 1, 64 x 1) ran alike and smaller ones (4 x 4, 8 x 4) up to twice as long
// (bench/results/render/raycaster-groups.md); 8 x 8 is two of NVIDIA's warps of 32.
#define VB_RAYCAST_GROUP_X 8
#define VB_RAYCAST_GROUP_Y 8

// The workgroup of the 8-bit finish (finish.comp.glsl, Compositor::finish8): a pixel an invocation, nothing shared.
#define VB_FINISH_GROUP_X 8
#define VB_FINISH_GROUP_Y 8

#endif
