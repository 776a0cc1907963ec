// Access to the GLSL sources under shaders/, embedded into the binary at build time by cmake/EmbedShaders.cmake.
#pragma once

#include <string_view>

namespace voxbrick::render {

/// The text of shaders/<fileName> (e.g. "slice.vert.glsl") as it was at build time; throws std::out_of_range if no
/// such file was embedded. Defined in the generated EmbeddedShaders.cpp.
std::string_view shaderSource(std::string_view fileName);

}  // namespace voxbrick::render
