// A store's metadata (store.json): what `voxbrick info` prints and what readers check the index against.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "brickstore/format/Orientation.h"
#include "brickstore/format/Quantise.h"
#include "brickstore/format/Types.h"

namespace voxbrick::store {

/// One LOD level: level k halves level k-1 along each axis (rounding up).
struct LevelMeta {
  Vec3i dims;                ///< voxels
  Vec3i bricks;              ///< bricks along each axis: ceil(dims / B)
  int64_t bricksStored = 0;  ///< bricks with at least one sample different from the background
  int64_t bytesStored = 0;   ///< compressed bytes of the stored bricks
  int64_t bricksTotal() const { return bricks.volume(); }
};

/// Counts of level-0 voxel values in `bins` equal bins over value_range.
struct Histogram {
  double lo = 0, hi = 0;
  std::vector<uint64_t> counts;
};

struct StoreMeta {
  static constexpr int kFormatVersion = 1;

  Vec3i dims;  ///< level 0 voxels
  Vec3d spacing;
  /// Index-to-world (RAS) of level 0; store.json key "orientation" (absent in older stores: the identity).
  Orientation orientation;
  ValueType type = ValueType::F32;
  double background = 0;              ///< value of empty (inactive, not stored) space
  double valueMin = 0, valueMax = 0;  ///< over every level-0 voxel, after the non-finite policy
  Histogram histogram;
  int brickSize = 32;
  std::vector<LevelMeta> levels;
  int64_t bytesRaw = 0;               ///< level-0 voxels times the type size
  int64_t bytesStored = 0;            ///< bricks.bin + index.bin over all levels
  int64_t bytesVdb = 0;               ///< the canonical OpenVDB grid files
  int64_t activeVoxels = 0;           ///< level-0 voxels different from the background
  int64_t nonFiniteReplaced = 0;      ///< NaN/Inf voxels set to the background at ingest
  std::vector<std::string> vdbFiles;  ///< relative to the store directory, in z order
  std::string source;                 ///< the input's description
  /// Set when prep quantised the input: the stored integers q stand for quantisation->dequantise(q). Every other
  /// value here (background, value range, histogram, brick and node ranges) is in stored units.
  std::optional<Quantisation> quantisation;
  int64_t quantisationClamped = 0;  ///< finite input values outside the quantisation range (stored as 0 or steps)

  /// A value of the input in stored units: itself, or quantisation->toSteps(v) (not rounded, not clamped).
  double storedValue(double v) const { return quantisation ? quantisation->toSteps(v) : v; }

  /// The JSON object stored as store.json (keys as in `voxbrick info --json`).
  std::string toJson() const;
  /// Parses store.json; throws CorruptStoreError naming `what` and the bad key.
  static StoreMeta fromJson(const std::string& text, const std::string& what);
};

/// The dims of every LOD level: level 0, then each level halving the one before (rounding up) until the level fits
/// in one brick of `brickSize` along every axis.
std::vector<Vec3i> pyramidDims(Vec3i dims, int brickSize);

/// The voxel spacing any input or store may have: far enough from 0 and from the largest double that spacing times
/// dims stays finite and the index-to-world transform (OpenVDB's included) stays invertible.
inline constexpr double kMinSpacing = 1e-12, kMaxSpacing = 1e12;

/// Whether `s` is in [kMinSpacing, kMaxSpacing] (false for NaN).
inline bool spacingInRange(double s) { return s >= kMinSpacing && s <= kMaxSpacing; }

/// Throws InputError "<what> is <s>, not a spacing in [1e-12, 1e12] ..." unless spacingInRange(s); `what` names the
/// file and the field the spacing came from.
void checkSpacingInRange(double s, const std::string& what);

/// Throws InputError unless `brickSize` is a power of two in [8, kMaxBrickSize] (the rule for --brick).
void checkBrickSize(int brickSize);

}  // namespace voxbrick::store
