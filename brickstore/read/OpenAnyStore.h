// Opening a dataset file by its form: a store directory, a .vdb read live or an OME-Zarr read live. Apart from the
// store's base class, so that BrickStore knows none of its backings.
#pragma once

#include <filesystem>
#include <memory>

#include "brickstore/read/BrickStore.h"

namespace voxbrick::store {

/// Opens `path` by its form: a file ending in .vdb is read live (VdbStore::open with `options`), an OME-Zarr
/// directory too (ZarrStore::open, isZarrDirectory), anything else is opened as a store directory (BrickStore::open;
/// then `options` must be the defaults). Throws what those throw, and InputError for options given to a directory.
std::shared_ptr<const BrickStore> openAnyStore(const std::filesystem::path& path, const StoreOpenOptions& options = {});

/// True if `path` ends in ".vdb" (case-insensitive) and is not a directory: what openAnyStore reads live (a missing
/// file then gets OpenVDB's reader's error, naming it).
bool isVdbFile(const std::filesystem::path& path);

}  // namespace voxbrick::store
