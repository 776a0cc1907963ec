// The programs of the slicing technique: one variant per small descriptor, each with its uniforms located once
// when it is built, and the per-frame uniform values taken from the frame plan.
#pragma once

#include <map>

#include "render/core/PreIntegration.h"
#include "render/core/Scene.h"
#include "render/gl/GlObjects.h"
#include "render/gl/volume/BrickAtlas.h"
#include "render/volume/FramePlan.h"

namespace voxbrick::render {

/// What the fragment stage computes.
enum class FragmentModel {
  Plain,     ///< the optical model
  Shaded,    ///< with gradients and a Phong headlight (SHADING)
  Roofline,  ///< one atlas fetch, no classification, no blending (ROOFLINE): the sampling roofline
};

/// Which program variant a frame needs. Each field is the choice of the technique's stages (slicer, slab, raycast:
/// which files, shaders/README.md) or one #define of its fragment program.
struct ProgramKey {
  Slicer slicer = Slicer::Vertex;  ///< the stages that slice (Vertex where the key does not slice)
  FragmentModel model = FragmentModel::Plain;
  bool exactOwnership = false;  ///< EXACT_OWNERSHIP (slicing): samples from the pixel ray, owned per box (sub-blocks,
                                ///< levels, parts: FramePlan::exactOwnership); slabs and the ray caster need no define
  bool slab = false;            ///< texture slabs: box proxies (slab.vert.glsl, slab.frag.glsl), several samples
                                ///< per fragment
  bool preIntegration = false;  ///< PRE_INTEGRATION (slabs, the ray caster): segments classified from a table
  bool emptyTest = false;       ///< EMPTY_TEST (slabs): the empty-space silhouette pass, no colour
  bool raycast = false;         ///< the frame ray caster: a full-screen proxy (raycast.vert.glsl, raycast.frag.glsl), a
                                ///< pixel's whole ray per fragment
  bool compute = false;         ///< with raycast: its compute kernel instead (raycast.comp.glsl), a pixel's whole ray
                                ///< per invocation (render/gl/volume/ComputeRayCast.h)
  bool pagedCells = false;      ///< PAGED_CELLS (the ray caster): the cell table as a directory over pages, not one
                                ///< cell grid (FramePlan::pagedCells, render/gl/volume/CellTable.h)
  bool multiOriented = false;   ///< MULTI_ORIENTED: bricks lie in the atlas with rotated axes (AtlasBricking)
  bool rayRequests = false;     ///< RAY_REQUESTS (the ray caster): rays record the bricks they need (RayRequests.h)
  auto operator<=>(const ProgramKey&) const = default;
};

/// The stages of `slicer` before the fragment program and their library (none for the CPU slicer), as program
/// `name`: what a slicing variant is built of, and what the tests capture with transform feedback.
ProgramSources slicerSources(Slicer slicer, std::string name);

/// A linked slicing program and the locations of its uniforms (-1 where a variant does not use one).
class VolumeProgram {
 public:
  /// Compiles and links the variant `key`; for the vertex slicer uploads the slicer tables once. Throws RenderError,
  /// naming the slicer when a slicing variant cannot be built.
  VolumeProgram(const Gl& gl, const ProgramKey& key);

  const Program& program() const { return mProgram; }
  /// Sets every per-frame uniform from `plan` (with the path table of Zellmann & Lang's slicers, which follows the
  /// view direction); the atlas is on texture unit VB_UNIT_ATLAS, the transfer table on VB_UNIT_TRANSFER
  /// (render/gl/Bindings.h, declared by the shaders).
  void setFrame(const FramePlan& plan, const BrickAtlas& atlas, const store::StoreMeta& meta) const;
  /// Sets the pre-integration table's mapping (PRE_INTEGRATION variants); the table is on VB_UNIT_PRE_INTEGRATED.
  void setTable(const PreIntegrationSpec& spec) const;
  /// Sets the cell table's grid (ray caster variants): `cells` cells of 2^`shift` voxels; the table is on
  /// VB_UNIT_CELLS.
  void setCells(const glm::ivec3& cells, int shift) const;
  /// Sets the ray-request grid (RAY_REQUESTS variants): level-0 bricks along xyz, w the brick's voxels.
  void setRequestGrid(const glm::ivec4& grid) const { mProgram.set(mRequestGrid, grid); }
  /// The compute ray caster's tile (compute variants): the pixels [xy, zw) of the next dispatch.
  void setTile(const glm::ivec4& tile) const { mProgram.set(mTile, tile); }
  /// Whether it is a compute program (ProgramKey::compute), dispatched rather than drawn.
  bool compute() const { return mCompute; }

 private:
  Program mProgram;
  struct Locations {
    GLint viewProj, planeNormal, planeIncr, invAtlasSize, invSpacing, dims, halfDims, windowLo, windowScale,
        stepOverReference, eye, viewDir, orthographic, rayOrigin, rayOriginDx, rayOriginDy, rayDirection,
        rayDirectionDx, rayDirectionDy, termination, tableResolution, ratioMin, layerScale, layers, cellShift,
        cellCount;
  } mAt;
  GLint mPaths = -1;         // uPaths of the vertex-lean, geometry and vertex-geometry slicers
  GLint mTile = -1;          // uTile of the compute ray caster
  GLint mRequestGrid = -1;   // uRequestGrid of the RAY_REQUESTS variants
  bool mCompute = false;     // a compute ray caster variant
  bool mStripOrder = false;  // its rows in strip order (the geometry slicer)
};

/// The variants built so far on one context, built on first use.
class VolumePrograms {
 public:
  explicit VolumePrograms(const Gl& gl) : mGl(gl) {}
  const VolumeProgram& get(const ProgramKey& key);

 private:
  const Gl& mGl;
  std::map<ProgramKey, VolumeProgram> mPrograms;
};

}  // namespace voxbrick::render
