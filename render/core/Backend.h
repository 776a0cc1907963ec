// Which library makes a render thread's GL context. GL-free, so that configuration and the server can name a
// backend without seeing GL.
#pragma once

#include <string>

namespace voxbrick::render {

/// Which library creates the context. Auto tries EGL first (a GPU when there is one), then OSMesa.
enum class Backend { Auto, Egl, OsMesa };

/// "auto", "egl" or "osmesa".
const char* backendName(Backend backend);

/// Parses "auto", "egl" or "osmesa"; throws RenderInputError on anything else.
Backend parseBackend(const std::string& text);

}  // namespace voxbrick::render
