// Synthetic fields as prep's input ("synthetic:NAME[,k=v...]").
#pragma once

#include <memory>
#include <string>

#include "brickstore/source/VolumeSource.h"

namespace voxbrick::store {

/// A synthetic field; `spec` is what follows "synthetic:", e.g. "marschner-lobb,n=64".
std::unique_ptr<VolumeSource> openSyntheticSource(const std::string& spec, const SourceOptions& options);

}  // namespace voxbrick::store
