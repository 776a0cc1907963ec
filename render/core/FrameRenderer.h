// The one call every renderer answers, whatever kind of dataset it draws. GL-free.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <span>

#include "image/Image.h"
#include "render/core/FrameStats.h"
#include "render/core/PartialFrame.h"
#include "render/core/Scene.h"

namespace voxbrick::render {

/// What the fragment stage does, and on what: the optical model, or for benchmarks the sampling roofline of the same
/// geometry, or the slices' corners alone.
enum class RenderMode {
  Normal,    ///< the optical model
  Roofline,  ///< exactly one sample per fragment, no classification, no blending
  /// Slices drawn as their corners (glPolygonMode GL_POINT), so that the fragment stage has almost nothing to do and
  /// the slicer's own time shows (Zellmann & Lang's "Points" mode). Slicing only: a frame drawn with texture slabs
  /// or the ray caster throws RenderInputError.
  Points,
};

/// How one frame is drawn, beyond its scene.
struct FrameOptions {
  RenderMode mode = RenderMode::Normal;
  /// Coarse-to-fine streaming: a brick that is not resident (in the GPU atlas or the host cache) is drawn from its
  /// nearest resident ancestor and paged for a later frame, so the frame never waits for the disk
  /// (FrameStats::bricksStandIn counts them). False: every brick is drawn at its own level, read now if need be.
  bool standIns = false;
  /// The most samples the frame may cost (FramePlan::estimatedSamples, checked before anything is paged or drawn);
  /// above it the frame throws RenderLimitError. 0: no limit.
  double maxSamples = 0;
  /// With level of detail on (Scene::lod > 0): bricks are coarsened until the frame's set fits the GPU atlas and the
  /// host cache (planFrame's budget), so that it stays resident and the next frame of the same view pages nothing.
  /// False: the levels the screen-space error chose, drawn batch by batch when the atlas cannot hold them.
  bool fitBudget = true;
  /// Asked between batches and texture slabs: true gives the frame up (FrameCancelled), leaving the context clean.
  /// With it the renderer also keeps at most two checkpoints of GL work queued, so that giving up takes effect
  /// within about one slab's work rather than after the whole queued frame. Empty: never cancelled.
  std::function<bool()> cancelled = {};
  /// The work between two checkpoints, in estimated samples (FramePlan::estimatedSamples' unit): full-screen passes
  /// are drawn in bands or tiles of about this many samples, so that a cancelled frame stops promptly at any size and
  /// step (render/gl/Bands.h). 0: the renderer's own bands. Only with `cancelled`.
  double checkpointSamples = 0;
  /// An interactive frame's rate (estimated samples per ms) to predict its cost with (render/core/Interactive.h);
  /// 0: the rate the engine has seen lately.
  double rateSamplesPerMs = 0;
  /// With rateSamplesPerMs: the time a frame takes besides its samples (RateGauge::fixedMs).
  double fixedMs = 0;
  /// An interactive frame (RenderEngine): returned at the size its rung drew (FrameStats::interactive's "width" and
  /// "height"), not scaled up to the scene's, so that the parts of a sort-last frame are composited at that size and
  /// the composite is scaled up once. False: at the scene's size.
  bool keepReducedSize = false;
  /// An interactive frame (RenderEngine): drawn at no more than this fraction of the scene's sides and returned at
  /// scaledSide(side, outputScale) of each, not at the scene's size: a session's video stream sent smaller
  /// (server/VideoStream.h) takes its frames at its own size, so no pixel is drawn or scaled up only to be thrown
  /// away. In (0, 1]; 1: the scene's size. Frames of other scenes ignore it.
  double outputScale = 1;
  /// Sort-last rendering (grids only): draw only the samples owned inside this box of level-0 voxels, and return the
  /// frame premultiplied (colour times opacity, and opacity) with no background, for compositing in visibility order
  /// (render/core/PartialFrame.h). Empty: the whole dataset, finished over the scene's background.
  std::optional<PartBox> part = std::nullopt;
  /// Sort-last rendering of a tetrahedral mesh: draw only the cells that meet this world-space box, each ray's
  /// integration clipped to it, premultiplied with no background as `part` is (render/core/PartialFrame.h). Empty:
  /// the whole mesh. A grid's renderer refuses it, a mesh's refuses `part`.
  std::optional<MeshPartBox> meshPart = std::nullopt;
  /// Grids, ray casting a frame of one batch: the cell table kept from the last frame and changed where the bricks
  /// changed (render/gl/volume/KeptCells.h). False fills it anew, as each batch of a larger frame does: the same
  /// image, the path it replaced, kept for measuring the two side by side.
  bool keepCellTable = true;
  /// Grids, ray casting: the cell table paged on the GPU whatever its size (by default only a table of more than
  /// kMaxDenseCells cells is: render/volume/FramePlan.h); the same image, for tests and measurement.
  bool pagedCellTable = false;
};

/// Where renderSequence8 hands each frame: its index in the sequence, its image and its statistics.
using FrameDelivery = std::function<void(size_t index, image::Image8&& image, const FrameStats& stats)>;

/// A renderer of one dataset on one GL context (so one render thread); it keeps its GPU state between frames.
class FrameRenderer {
 public:
  virtual ~FrameRenderer() = default;
  /// Renders `scene`; throws RenderInputError for an invalid scene and RenderError for GL failures.
  virtual image::ImageF render(const Scene& scene, FrameStats* stats = nullptr, const FrameOptions& options = {}) = 0;
  /// The frame as 8-bit RGBA, what servers send and files hold: the bytes image::toImage8(render(...)) gives. A
  /// renderer that can finish its frames on the GPU (the background composited and the channels rounded there)
  /// does, and reads back a quarter of the bytes; this default converts on the CPU.
  virtual image::Image8 render8(const Scene& scene, FrameStats* stats = nullptr, const FrameOptions& options = {}) {
    return image::toImage8(render(scene, stats, options));
  }
  /// Each frame of a sequence (`orbit`'s turntable) as render8 draws it, handed to `deliver` (its index, image and
  /// statistics) as soon as it is read back, in order. A renderer that can overlaps the next frame's planning with
  /// the GPU's drawing of this one; this default draws them one after the other.
  virtual void renderSequence8(std::span<const Scene> scenes, const FrameOptions& options,
                               const FrameDelivery& deliver) {
    for (size_t i = 0; i < scenes.size(); ++i) {
      FrameStats stats;
      image::Image8 image = render8(scenes[i], &stats, options);
      deliver(i, std::move(image), stats);
    }
  }
  /// GPU memory it holds for its data (the brick atlas), which its GPU budget bounds.
  virtual size_t gpuBytes() const = 0;
  /// The samples drawing `scene` would cost, as the frame's own estimate (FrameStats::samplesEstimated) would say,
  /// without drawing: what an interactive frame chooses its drawing by (render/core/Interactive.h).
  virtual double estimateSamples(const Scene& scene) = 0;
};

}  // namespace voxbrick::render
