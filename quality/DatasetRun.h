// One dataset's part of a sweep: its stores, variants and reference frames, and the GPU renderers that measure its
// settings.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "brickstore/read/BrickStore.h"
#include "quality/SweepResult.h"
#include "render/gl/GlContext.h"
#include "render/gl/volume/VolumeRenderer.h"

namespace voxbrick::quality {

/// Host cache and GPU atlas of every renderer in a sweep: every dataset here fits.
constexpr size_t kSweepBudget = size_t(2) << 30;

/// The scene of view `view` of the spec's orbit with `variant`, at the renderer's default settings.
render::Scene viewScene(const SweepSpec& spec, const Variant& variant, int view);

/// One dataset's stores (made once, kept in `work`), variants and reference frames (each view of each variant,
/// cached in `work`/reference), and, made when first needed and released between the sweep's phases, one GPU
/// renderer per store, so that bricks stay resident across settings as in a server.
class DatasetRun {
 public:
  /// Makes or opens the stores and the reference frames; adds a ReferenceReport per variant to `result` and logs it.
  DatasetRun(const SweepSpec& spec, const Dataset& d, const std::filesystem::path& work, render::GlContext& context,
             SweepResult& result, const std::function<void(const std::string&)>& log);

  const std::vector<Variant>& variants() const { return mVariants; }
  size_t variantIndex(const Variant& v) const;

  /// Frees the GPU renderers (and their atlases) until the next measure().
  void release() { mRenderers.clear(); }

  /// Every view of variant `variantIndex` with `setting`, after a warm-up frame: times, counts and error.
  Point measure(const Setting& setting, size_t variantIndex);

 private:
  void makeReferences(const std::filesystem::path& work, SweepResult& result,
                      const std::function<void(const std::string&)>& log);
  render::VolumeRenderer& renderer(int brick);
  render::Scene settingScene(const Setting& setting, const Variant& variant, int view) const;

  const SweepSpec& mSpec;
  const Dataset& mDataset;
  render::GlContext& mContext;
  std::map<int, std::shared_ptr<const store::BrickStore>> mStores;
  std::vector<Variant> mVariants;
  std::vector<std::vector<image::ImageF>> mTruth;
  std::map<int, std::unique_ptr<render::VolumeRenderer>> mRenderers;
};

}  // namespace voxbrick::quality
