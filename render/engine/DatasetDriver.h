// Everything that depends on a dataset's kind, in one object per kind: how a dataset of the kind is recognised and
// opened by path, the renderer that draws it and the GPU memory that renderer wants, what to page ahead for a
// coming camera, its CPU reference, the summary of a frame, and whether (and how) sort-last rendering splits it into
// parts. RenderEngine and the callers above it ask the driver of a dataset's kind (driverFor) and never test a kind
// or cast a dataset themselves, so that a new kind is one folder and one line in Drivers.cpp
// (docs/design/dataset-kinds.md). The header is GL-free: a driver's renderer is made on a context it only names.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "brickstore/read/BrickStore.h"
#include "image/Image.h"
#include "render/core/Dataset.h"
#include "render/core/FrameRenderer.h"
#include "render/core/FrameStats.h"
#include "render/core/PartialFrame.h"
#include "render/core/Scene.h"
#include "render/engine/EngineOptions.h"

namespace voxbrick::render {

class GlContext;  // render/gl/GlContext.h: only the drivers' sources see it

/// What a driver makes a renderer with: the engine's context and settings, and the GPU bytes left for it.
struct RendererSetup {
  GlContext& context;
  const RenderEngineOptions& options;
  size_t gpuBytesLeft = 0;
};

/// How the CPU reference of a frame is drawn (`render --backend reference`).
struct ReferenceSettings {
  double step = 0.125;   ///< a grid's sampling step in voxels
  std::string analytic;  ///< a grid: sample this synthetic field's formula instead of the stored voxels ("" none)
};

/// A reference frame and what it cost.
struct ReferenceFrame {
  image::ImageF image;
  nlohmann::json stats;  ///< its counters (rays, samples or segments, ms)
  std::string summary;   ///< one phrase: "with the reference (trilinear grid, step 0.125 voxels): 4096 rays, ..."
};

/// Sort-last rendering's split of one dataset into parts, each a convex box drawn by one rank (a grid's of level-0
/// voxels, FrameOptions::part; a mesh's in world space, FrameOptions::meshPart), and the parts' front-to-back order
/// for a camera.
class SortLastParts {
 public:
  virtual ~SortLastParts() = default;
  /// How many parts there are.
  virtual int count() const = 0;
  /// Sets `options` to draw part `part` (0 <= part < count()) alone: its box as the kind's part option.
  virtual void select(int part, FrameOptions& options) const = 0;
  /// The parts' indices, nearest first, for `scene`'s camera.
  virtual std::vector<int> frontToBack(const Scene& scene) const = 0;
  /// The rectangle of a width × height drawing of `scene` (the scene's own size, or an interactive frame's reduced
  /// one) outside which part `part` draws nothing: its box's projection with a margin (the compositor takes the
  /// pixels outside as empty, mostly without reading them), cut to what the frame drew when its statistics `drawn`
  /// say (a grid's FrameStats::drawnBox). Default: the whole frame.
  virtual PixelRect footprint(int part, const Scene& scene, int width, int height,
                              const FrameStats* drawn = nullptr) const;
};

/// `voxbrick info` of a dataset: what it holds, for people and as JSON.
struct DatasetReport {
  std::string text;     ///< lines, each ending in a newline
  nlohmann::json json;  ///< one object; describeDataset adds "path" and "kind"
};

class DatasetDriver {
 public:
  virtual ~DatasetDriver() = default;

  /// The kind it drives: Dataset::kind() of the datasets it opens.
  virtual std::string_view kind() const = 0;

  /// Whether `path` holds a dataset of this kind.
  virtual bool recognises(const std::filesystem::path& path) const = 0;
  /// The files whose change on disk means the dataset at `path` was replaced.
  virtual std::vector<std::filesystem::path> files(const std::filesystem::path& path) const = 0;
  /// Opens the dataset at `path` (recognised) under `name`, within `cacheBytes` of host memory; `options` are a
  /// store's opening options (a .vdb's grid and brick size, an OME-Zarr's time point and channel).
  virtual std::shared_ptr<const Dataset> open(std::string name, const std::filesystem::path& path, size_t cacheBytes,
                                              const store::StoreOpenOptions& options) const = 0;

  /// What the dataset at `path` (recognised, or for the brick store kind any path no kind recognises: its errors say
  /// what a store directory lacks) holds, opened with `options` as by open. Default: a line naming its path and kind.
  virtual DatasetReport describe(const std::filesystem::path& path, const store::StoreOpenOptions& options) const;

  /// The GPU bytes a new renderer of `dataset` would hold under the engine's whole budget (what the engine makes
  /// room for by releasing others).
  virtual size_t gpuBytesWanted(const Dataset& dataset, const RendererSetup& setup) const = 0;
  /// A renderer of `dataset` within setup.gpuBytesLeft, on setup.context (current).
  virtual std::unique_ptr<FrameRenderer> makeRenderer(const Dataset& dataset, const RendererSetup& setup) const = 0;
  /// Pages ahead for `scene`, a frame likely to come: queues on the dataset's host cache what it will draw, fitted
  /// to what `renderer` (this kind's, made by makeRenderer; null if none yet) can hold. Advisory; never throws.
  virtual void prefetch(const Dataset& dataset, const Scene& scene, const FrameRenderer* renderer) const;

  /// The CPU reference frame of `scene` (double precision; what judges every fast path). Throws RenderInputError
  /// for settings the kind has no use for.
  virtual ReferenceFrame reference(const Dataset& dataset, const Scene& scene,
                                   const ReferenceSettings& settings) const = 0;
  /// The lines `voxbrick render` prints about a frame drawn (`written`: "wrote OUT (WxH)"), one per element.
  virtual std::vector<std::string> summary(const Dataset& dataset, const Scene& scene, const FrameStats& stats,
                                           const std::string& written) const = 0;
  /// Checks a sub-block size given explicitly against the dataset (a grid's must cut its bricks); throws
  /// RenderInputError naming the option. Default: the kind has no sub-blocks and ignores it.
  virtual void checkSubBlock(const Dataset& dataset, int subBlock) const;

  /// Whether sort-last rendering can split datasets of this kind into parts. Default: no.
  virtual bool sortsLast() const { return false; }
  /// `dataset` split into `parts` parts (sortsLast() only; default throws RenderInputError).
  virtual std::shared_ptr<const SortLastParts> partition(const Dataset& dataset, int parts) const;
};

/// The driver of `dataset`'s kind; throws RenderInputError naming a kind no driver drives.
const DatasetDriver& driverFor(const Dataset& dataset);
/// The driver of the kind named `kind`; null when none drives it.
const DatasetDriver* findDriver(std::string_view kind);
/// The driver of the first kind that recognises `path`; null when none does.
const DatasetDriver* driverOfPath(const std::filesystem::path& path);
/// Adds a kind at run time (Drivers.cpp registers the built-in ones): datasets whose kind() is driver->kind() are
/// then driven by it, and paths it recognises are opened by it (after the built-in kinds). Throws
/// std::invalid_argument for a kind already registered.
void registerDriver(std::shared_ptr<const DatasetDriver> driver);

}  // namespace voxbrick::render
