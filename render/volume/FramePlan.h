// The first stage of a frame, without GL: camera and clip range, value window and the transfer function's range
// test, the bricks to draw in visibility order, slice-plane spacing and normal, the margins boxes are drawn with,
// and the pixel rays of exact ownership. Later stages (residency, geometry, drawing passes) only read it.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "brickstore/read/BrickStore.h"
#include "render/core/Camera.h"
#include "render/core/PartialFrame.h"
#include "render/core/PixelRays.h"
#include "render/core/Scene.h"
#include "render/volume/Slicing.h"
#include "render/volume/Traversal.h"
#include "render/volume/WorkingSet.h"

namespace voxbrick::render {

/// The value window [lo, hi] that maps raw values to [0, 1].
struct ValueWindow {
  double lo = 0, hi = 1;
  double inverseWidth = 1;  ///< 1 / (hi - lo)
};

/// The scene's value window over `meta`'s values (default the store's range; a constant volume gets [v, v + 1]).
/// A scene's window is in the input's values, mapped onto a quantised store's steps (StoreMeta::storedValue).
/// The GPU renderer and the reference take it from here, so that they normalise alike.
ValueWindow valueWindow(const Scene& scene, const store::StoreMeta& meta);

/// The scene's camera resolved on `meta`'s grid: around the world box volumeBox(dims, spacing) (the voxels' box
/// centred on the origin, a voxel coordinate is world / spacing + dims / 2), in the store's world frame, at the
/// image's aspect. planFrame, the parts' visibility order (partView) and the reference all take it from here.
Camera gridCamera(const Scene& scene, const store::StoreMeta& meta);

/// What a plan's range test (FramePlan::contributes) depends on: the value window, the transfer table's size and the
/// transfer function's opacity points. Two plans with equal keys classify every value range alike, so what one
/// skipped as empty (bricks, sub-blocks) the other skips too.
struct ClassificationKey {
  double lo = 0, hi = 0;
  int tableTexels = 0;
  std::vector<std::pair<double, double>> opacity;  ///< (x, alpha) of each point
  bool operator==(const ClassificationKey&) const = default;
};

struct FramePlan {
  Box volume;  ///< the volume's world box
  Camera camera;
  double nearPlane = 0, farPlane = 0;
  glm::dmat4 viewProj{1.0};  ///< world to clip
  ValueWindow window;
  /// Whether raw range [min, max] gets any opacity from the GPU's transfer table: the range test over the table
  /// entries a filtered lookup in [min, max] reads (exact at the window's ends: background at the low end is skipped
  /// when the transfer function is transparent there).
  RangePredicate contributes;
  ClassificationKey classification;  ///< what `contributes` depends on
  TraversalResult visible;  ///< bricks to draw, front to back, and what the traversal skipped
  /// With level of detail on, the budget the bricks were fitted to (coarsenToFit); {} when none was given.
  BrickBudget budget;
  int64_t bricksWanted = 0;         ///< bricks the level choice by screen-space error wanted, before the fit
  glm::dvec3 planeNormal{0, 0, 1};  ///< unit, from the eye into the scene
  double step = 1;                  ///< world distance between global slice planes
  double referenceLength = 1;       ///< the length transfer-function opacities are given for
  int subBlock = 0;                 ///< sub-block edge in voxels; 0 draws whole bricks
  int slab = 0;                     ///< planes per texture slab; 0 slices (ignored when ray casting)
  bool raycast = false;             ///< frame ray casting (render/gl/volume/RayCastPass.h) instead of slicing or slabs
  int cellSize = 0;  ///< ray casting: the cell table's cell edge in level-0 voxels (render/gl/volume/CellTable.h)
  /// Ray casting: the cell table paged (a directory over pages of the blocks something is drawn in) rather than one
  /// grid of cells, for tables of more than kMaxDenseCells cells.
  bool pagedCells = false;
  /// Ray casting with ray-driven residency (Scene::residency rays, a whole frame): the bricks are paged as the rays
  /// request them (render/gl/volume/RayRequests.h), when the frame is one batch.
  bool rayResidency = false;
  double ert = 0;    ///< early ray termination threshold when marching; 0 off (always 0 when slicing)
  bool preIntegration = false;  ///< pre-integrated classification (when marching)
  bool ess = false;             ///< empty-space silhouette maps (slabs only)
  int coarsestLevel = 0;        ///< the coarsest pyramid level drawn: of plan.visible's bricks' sources
  int width = 0, height = 0;    ///< image size in pixels
  PixelRays rays;
  /// Why the frame is not drawn as the scene asked (FrameStats::fallback); empty when it is.
  std::string fallback;
  /// Sort-last rendering (FrameOptions::part): the level-0 voxels this frame draws. plan.visible then holds only the
  /// bricks owning voxels in it, at the levels the whole frame chose, and each is cut to the box (BrickWalk); its
  /// counts of bricks drawn (per level, coarse) are the part's, those skipped and culled the whole volume's.
  std::optional<PartBox> part;
  /// With a part: the box (local frame) of the bricks kept, min above max when none is (FrameStats::drawnBox).
  std::optional<Box> partDrawn;

  /// Whether every box owns exactly its voxels, tested on the pixel's ray (sub-blocks and bricks of different levels,
  /// whose boxes meet at T-junctions, and slabs, which march rays); else whole bricks share their rasterised faces
  /// and only the volume's outline is tested.
  /// A part's frame owns exactly too, so that its boxes stop at the part's faces.
  bool exactOwnership() const { return subBlock > 0 || marches() || coarsestLevel > 0 || part.has_value(); }
  /// Whether fragments march rays through several planes (slabs or the frame ray caster), rather than slice.
  bool marches() const { return slab > 0 || raycast; }
  /// Planes a box of pyramid level `level` samples: every one when slicing, every 2^level-th when marching.
  int planeStride(int level) const { return marches() ? 1 << level : 1; }

  /// The shortest and longest segment between two planes along any pixel's ray, in reference lengths: step / L
  /// over the cosine of the ray's angle to the view axis (1 for an orthographic camera), over the image's corners and
  /// centre (the cosine is largest at the centre or a corner and smallest at a corner, being a ratio of a linear
  /// to a convex function of window position). The longest is that of the coarsest level's plane stride.
  std::pair<double, double> segmentRatios() const;

  /// An upper estimate of the samples the frame takes, its cost: for each brick to draw, the pixels of the screen
  /// rectangle around its projected box times the planes through it at its level's stride (every plane when
  /// slicing, so slicing's finer levels cost what they do). No GL, a few operations per brick.
  double estimatedSamples() const;

  /// The box to draw for voxel box `b`: larger than the voxels it owns, so that the fragment stage's ownership test
  /// decides coverage. At the volume's surface by kSurfaceMargin voxels; between boxes by kInteriorMargin with
  /// exact ownership, else not at all.
  Box drawBox(const Box& b, const store::Vec3d& spacing) const;

  /// How far past its voxels a box is drawn, in voxels (far above the rasterised edges' round-off).
  static constexpr double kSurfaceMargin = 0.25;
  static constexpr double kInteriorMargin = 1.0 / 64;
};

/// The pyramid level of each level-0 brick in `visible` (x fastest over `meta`'s level-0 brick grid): the level of
/// each draw's source() inside the voxels it owns, 0 elsewhere. What ReferenceOptions::brickLevels takes, so that the
/// reference samples the same level as the GPU everywhere.
std::vector<uint8_t> brickLevels(const TraversalResult& visible, const store::StoreMeta& meta);

/// The most blocks of 8^3 cells a ray-casting frame's cell table may span: the table is paged (its pages hold the
/// blocks with something to draw, render/gl/volume/CellTable.h), but its directory has an entry per block (4 bytes).
/// Cells are the sub-blocks, doubled until the directory fits, at most bricks: 16 MiB of directory covers a volume
/// of 16384^3 voxels in sub-blocks of 8. Only a side beyond 32767 voxels (past the table's 16-bit offsets) is drawn
/// with texture slabs instead.
inline constexpr int64_t kMaxRayCastBlocks = int64_t{1} << 22;

/// The most cells a ray-casting frame's cell table holds as one grid (8 bytes each, 32 MiB): a larger table is paged.
/// One grid takes one fetch a sample where pages take two (llvmpipe: the MRI's frames 5-10 % faster).
inline constexpr int64_t kMaxDenseCells = int64_t{1} << 22;

/// Cells of `cellSize` voxels a side over `dims` voxels (the last along each axis partial).
int64_t rayCastCells(const store::Vec3i& dims, int64_t cellSize);

/// The cell edge of a ray-casting frame's cell table over `dims` voxels: the sub-block (or with none the brick),
/// doubled while the directory would exceed kMaxRayCastBlocks; 0 when even bricks would, or a side exceeds 32767
/// voxels.
int rayCastCellSize(const store::Vec3i& dims, int subBlock, int brickSize);

/// Texels of the GPU renderer's transfer-function table (VolumeRenderer), so that a plan made away from the GL
/// renderer (the server's paging ahead) skips what the GPU would.
inline constexpr int kTransferTableTexels = 4096;

/// Plans a frame of `scene` over `store`. `transferTableTexels` is the size of the GPU's transfer-function table
/// (the range test covers the entries a lookup reads). With level of detail on (Scene::lod > 0) and a `budget`, the
/// bricks are coarsened until they fit it (coarsenToFit); lod 0 draws level 0 everywhere, in batches when it must.
/// With `part` (sort-last rendering), only the bricks owning level-0 voxels inside it are kept, and the budget is
/// theirs. Throws RenderInputError for an invalid scene or a part that is not a non-empty box inside the volume.
FramePlan planFrame(const Scene& scene, const store::BrickStore& store, int transferTableTexels,
                    const BrickBudget& budget = {}, const std::optional<PartBox>& part = std::nullopt);

}  // namespace voxbrick::render
