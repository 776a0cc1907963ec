// The reference renderer: the optical model of ARCHITECTURE.md on the CPU in double precision, the judge of every fast
// path.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "brickstore/format/StoreMeta.h"
#include "brickstore/ingest/synthetic/SyntheticField.h"
#include "brickstore/read/BrickCache.h"
#include "image/Image.h"
#include "render/core/Scene.h"

namespace voxbrick::render {

class ReferenceBricks;

/// How the reference integrates. It converges to the continuous emission–absorption integral along each ray through
/// a pixel centre, from the near plane to where the ray leaves the volume's box: the limit of the discrete
/// model as the step goes to 0 (extinction −ln(1 − α) / L_ref, emission the transfer function's colour).
struct ReferenceOptions {
  /// Length of one integration segment along the ray, in voxels of the smallest level-0 spacing. Each ray's
  /// interval is cut into equal segments no longer than this, sampled at their midpoints (the composite midpoint
  /// rule), so the error falls with the square of the step where the integrand is smooth.
  double step = 0.125;
  /// Sample this analytic field (placed on the store's box) instead of the store's trilinear grid: the difference
  /// between the two images is the reconstruction error alone. Empty-space skipping is off then, since brick
  /// ranges do not bound the function between samples.
  std::optional<store::SyntheticField> analytic;
  /// Level of detail: the pyramid level sampled inside each level-0 brick's voxels (x fastest over level 0's brick
  /// grid), as a frame plan chose them (brickLevels() in render/volume/FramePlan.h); empty: level 0 everywhere. Level m
  /// is reconstructed trilinearly at the level-0 voxel coordinate times 2^-m, clamp-to-edge, as on the GPU.
  std::vector<uint8_t> brickLevels;
};

/// What one reference frame did.
struct ReferenceStats {
  int64_t rays = 0;           ///< rays that met the volume
  int64_t samples = 0;        ///< field samples taken (gradient samples not counted)
  int64_t bricksSkipped = 0;  ///< brick crossings skipped because the transfer function makes them transparent
  double ms = 0;              ///< wall time
};

/// Renders a scene from the same store as VolumeRenderer, with the same camera, clip range, value window and
/// background, but the transfer function evaluated exactly (piecewise linear, not through a table), opacity
/// corrected as 1 − (1 − α)^(Δs / L_ref), trilinear reconstruction of level 0 with clamp-to-edge at cell centres,
/// compositing in double, and optional shading with the GPU's formula (central differences half a voxel each way,
/// two-sided Phong headlight). Rows run in parallel (oneTBB).
///
/// Exact shortcuts only: a brick whose [min, max] the transfer function maps to zero opacity contributes exactly
/// nothing, so rays jump over it; a ray stops once its transmittance is below 1e-9 (the rest could change a pixel
/// by at most 1.25e-9, the largest shaded colour times that).
///
/// Memory: every brick a frame samples is held (through the cache's handles) until the renderer is destroyed,
/// so the reference is meant for volumes that fit in host memory.
class ReferenceRenderer {
 public:
  /// `cache` supplies the bricks (empty ones read as the store's background).
  explicit ReferenceRenderer(std::shared_ptr<store::BrickCache> cache);
  ~ReferenceRenderer();
  ReferenceRenderer(const ReferenceRenderer&) = delete;
  ReferenceRenderer& operator=(const ReferenceRenderer&) = delete;

  /// Renders `scene` (its step, culling and slicer do not apply; skipEmpty turns the exact brick skipping off, to
  /// check it); throws RenderInputError for an invalid scene or a step outside [1e-4, 64] voxels.
  image::ImageF render(const Scene& scene, const ReferenceOptions& options = {}, ReferenceStats* stats = nullptr);

 private:
  std::shared_ptr<store::BrickCache> mCache;
  std::unique_ptr<ReferenceBricks> mBricks;
};

/// The analytic field a synthetic store was made from: `spec` is "NAME[,key=value...]" as after "synthetic:"; the
/// store's dims are used when the spec gives none, and its spacing always. Throws RenderInputError if the store was
/// not made from that field (by its recorded source) or the dims differ, store::InputError for a malformed spec.
store::SyntheticField analyticFieldFor(const store::StoreMeta& meta, const std::string& spec);

}  // namespace voxbrick::render
