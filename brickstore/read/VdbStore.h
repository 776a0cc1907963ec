// An OpenVDB file read live as a store: bricks and the LOD pyramid extracted from the grid's tree on demand, with
// nothing written to disk. The same bricks as the store `voxbrick prep` makes of the file.
#pragma once

#include <filesystem>
#include <memory>

#include "brickstore/read/BrickStore.h"

namespace voxbrick::store {

/// What opening a .vdb cost and found.
struct VdbOpenStats {
  double readSeconds = 0;     ///< reading and decompressing the file into memory (OpenVDB)
  double scanSeconds = 0;     ///< the pass over the tree: level-0 brick ranges and emptiness, statistics, histogram
  int64_t leafNodes = 0;      ///< leaf nodes (8^3 voxels) of the tree
  int64_t tiles = 0;          ///< tiles whose value differs from the background, inside the volume
  int64_t bricksScanned = 0;  ///< level-0 bricks the pass extracted: those near a leaf or such a tile
};

/// One float grid of a .vdb file, held in memory, read as a store of bricks of B^3 voxels.
///
/// The volume is the grid's active voxels' bounding box, its spacing the grid's voxel size, its background the
/// grid's, and voxel values are the tree's values, inactive ones included, with NaN and Inf read as the background:
/// exactly what `voxbrick prep` ingests from the file (with its default non-finite policy).
///
/// Opening reads the whole file (OpenVDB) and makes one parallel pass over the tree: every level-0 brick whose
/// voxels, border included, touch a leaf node or a non-background tile is extracted once, for its exact [min, max]
/// and whether it holds anything but the background; the other bricks are known to be background from the topology
/// alone and are never read. The same pass gives the value range, active voxels and the histogram. Level-0 records
/// are then exactly those of the prepped store, and so is the min/max octree built from them.
///
/// A level-0 brick is extracted from the tree (one leaf lookup per 8^3 block it covers) when read; a brick of level
/// m >= 1 is the pyramid's 2x2x2 average (downsampleVoxel, brickstore/format/BrickMath.h) of the level-(m-1) bricks it
/// covers, which it asks for through the `finer` fetch readBrick is given: through the host cache (BrickCache passes
/// its get), each finer brick is built once for all the coarser bricks that read it. Coarse records are known from the
/// topology too: a brick is stored if any finer brick it reads is, and its [min, max] is the union of theirs (a
/// bound, not the exact range, which would need every coarse brick built at open). A coarse brick the topology
/// marks stored may still come out all background (values cancelling); it is then extracted and read as such.
class VdbStore : public BrickStore {
 public:
  /// Opens the float grid options.gridName (default: the first float grid) of `file` with bricks of
  /// options.brickSize. Throws InputError naming the file and the problem (unreadable or malformed file, no such
  /// grid, a grid that is not float, a non-uniform transform, no active voxels, a bad brick size, an active bounding
  /// box of more than kMaxLiveBricks bricks) and IoError. The store is the OpenVDB module's (brickstore/modules/
  /// openvdb, loaded by this call the first time; common::ModuleError if it cannot be).
  static std::shared_ptr<const VdbStore> open(const std::filesystem::path& file, const StoreOpenOptions& options = {});

  StoreBacking backing() const override { return StoreBacking::VdbFile; }
  const VdbOpenStats& openStats() const { return mOpenStats; }
  /// Bricks of `level` extracted from the tree or built from finer bricks since open (the open pass not counted).
  virtual int64_t bricksBuilt(int level) const = 0;

 protected:
  VdbStore() = default;

  VdbOpenStats mOpenStats;
};

/// The OpenVDB module's read side: the table its entry VOXBRICK_VDB_READ_ENTRY gives (common/Modules.h). A change to
/// the table changes the entry's name, so that a module of another build is refused by name, not called wrongly.
struct VdbReadModule {
  std::shared_ptr<const VdbStore> (*open)(const std::filesystem::path& file, const StoreOpenOptions& options);
};
#define VOXBRICK_VDB_READ_ENTRY voxbrick_module_openvdb_read_v1

}  // namespace voxbrick::store
