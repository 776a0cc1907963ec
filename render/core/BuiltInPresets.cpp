// Looking up the embedded presets by name.
#include "render/core/BuiltInPresets.h"

namespace voxbrick::render {

const BuiltInPreset* findBuiltInPreset(std::string_view name) {
  for (const BuiltInPreset& p : builtInPresets())
    if (p.name == name) return &p;
  return nullptr;
}

}  // namespace voxbrick::render
