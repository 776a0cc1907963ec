// Reference frames of a sweep on disk, so that a rerun renders only the GPU frames.
#pragma once

#include <filesystem>
#include <memory>

#include "brickstore/read/BrickStore.h"
#include "image/Image.h"
#include "render/core/Scene.h"
#include "render/reference/ReferenceRenderer.h"

namespace voxbrick::quality {

/// Reference frames of one store in a directory: a file per frame, a text header naming everything the frame
/// depends on (the store's source, the scene as the reference renderer sees it, the step), then RGBA floats.
class ReferenceCache {
 public:
  /// `budget`: the host cache of the reference renderer, in bytes.
  ReferenceCache(std::filesystem::path dir, std::shared_ptr<const store::BrickStore> s, size_t budget);

  /// The frame of `scene` at `step`; `msRendered` gets the time if it had to be rendered, else stays.
  image::ImageF get(const render::Scene& scene, double step, double* msRendered);

 private:
  std::filesystem::path mDir;
  std::shared_ptr<const store::BrickStore> mStore;
  render::ReferenceRenderer mRenderer;
};

}  // namespace voxbrick::quality
