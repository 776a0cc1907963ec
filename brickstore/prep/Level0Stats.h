// Statistics of level-0 values as they stream into prep: the non-finite policy, the value range, active voxels.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <span>

#include "brickstore/source/VolumeSource.h"
#include "common/EnumNames.h"

namespace voxbrick::store {

/// What to do with NaN and Inf voxels of float inputs.
enum class NonFinitePolicy {
  Background,  ///< replace with the background value (so they are empty space), count and report them
  Error,       ///< refuse the input, naming the first bad voxel
};

/// --nonfinite's names.
inline constexpr common::EnumName<NonFinitePolicy> kNonFinitePolicyNames[] = {
    {NonFinitePolicy::Background, "background"}, {NonFinitePolicy::Error, "error"}};
constexpr std::span<const common::EnumName<NonFinitePolicy>> enumNames(NonFinitePolicy) {
  return kNonFinitePolicyNames;
}

/// Level-0 statistics gathered while slices stream past, with the non-finite policy applied first. Each batch is
/// reduced in parallel over its rows, left to right, so ties (0 and -0) resolve as a pass in z order would.
class Level0Stats {
 public:
  /// Slices of `info`'s type and dims; `background` replaces non-finite values under NonFinitePolicy::Background.
  Level0Stats(const VolumeInfo& info, double background, NonFinitePolicy policy)
      : mInfo(info), mBackground(background), mPolicy(policy) {}

  /// Applies the policy to `count` slices starting at z0 (in place) and adds them to the statistics. Throws
  /// InputError naming the first non-finite voxel under NonFinitePolicy::Error.
  void observe(int64_t z0, int64_t count, void* values);

  double min = std::numeric_limits<double>::max(), max = std::numeric_limits<double>::lowest();
  int64_t active = 0, nonFinite = 0;

 private:
  template <typename T>
  void observeTyped(int64_t z0, int64_t count, T* v);

  VolumeInfo mInfo;
  double mBackground;
  NonFinitePolicy mPolicy;
};

/// Reads all of `source` once, in batches of about `batchBytes` (at least one slice), and returns the statistics
/// prep would record for it: the same value range, active count and non-finite count. `progress` (if set) gets
/// (slices done, slices in all) after each batch. Throws what the source and the policy throw.
Level0Stats scanLevel0(VolumeSource& source, double background, NonFinitePolicy policy,
                       const std::function<void(int64_t, int64_t)>& progress = {},
                       int64_t batchBytes = int64_t{64} << 20);

}  // namespace voxbrick::store
