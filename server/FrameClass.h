// The classes of render work the scheduler tells apart, in the order it serves them: a moving camera's frame and the
// frame that ends a drag (interactive), any other plain Render (still), and work nobody watches as it
// happens (batch: a scene with "batch": true, as `voxbrick load --batch`, `orbit` and scripts send).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "common/EnumNames.h"

namespace voxbrick::server {

enum class FrameClass : uint8_t { Interactive, Still, Batch };
inline constexpr size_t kFrameClasses = 3;

inline constexpr common::EnumName<FrameClass> kFrameClassNames[] = {
    {FrameClass::Interactive, "interactive"}, {FrameClass::Still, "still"}, {FrameClass::Batch, "batch"}};
constexpr std::span<const common::EnumName<FrameClass>> enumNames(FrameClass) { return kFrameClassNames; }

/// Every class, in the order the scheduler serves them.
inline constexpr std::array<FrameClass, kFrameClasses> kAllFrameClasses = {FrameClass::Interactive, FrameClass::Still,
                                                                           FrameClass::Batch};

}  // namespace voxbrick::server
