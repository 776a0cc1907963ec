// Which library makes a render thread's GL context. GL-free, so that configuration and the server can name a
// backend without seeing GL.
#pragma once

#include <span>
#include <string>

#include "common/EnumNames.h"

namespace voxbrick::render {

/// Which library creates the context. Auto tries EGL first (a GPU when there is one), then OSMesa.
enum class Backend { Auto, Egl, OsMesa };

inline constexpr common::EnumName<Backend> kBackendNames[] = {
    {Backend::Auto, "auto"}, {Backend::Egl, "egl"}, {Backend::OsMesa, "osmesa"}};
constexpr std::span<const common::EnumName<Backend>> enumNames(Backend) { return kBackendNames; }

/// "auto", "egl" or "osmesa".
inline const char* backendName(Backend backend) { return common::nameOf(backend); }

/// Parses "auto", "egl" or "osmesa"; throws RenderInputError naming the closest otherwise.
Backend parseBackend(const std::string& text);

}  // namespace voxbrick::render
