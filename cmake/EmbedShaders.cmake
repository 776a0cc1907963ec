# Writes OUTPUT: a C++ source defining voxbrick::render::shaderSource(name) over every SHADER_DIR/*.glsl and the
# EXTRA_FILES (a ;-separated list: headers that C++ and GLSL share, such as render/gl/Bindings.h), each by file name.
file(GLOB shaders "${SHADER_DIR}/*.glsl")
list(SORT shaders)
list(APPEND shaders ${EXTRA_FILES})
set(body "// Generated from shaders/*.glsl at build time. Do not edit.\n#include <string_view>\n#include <stdexcept>\n#include <string>\n\nnamespace voxbrick::render {\n\nstd::string_view shaderSource(std::string_view name) {\n")
foreach(path IN LISTS shaders)
  get_filename_component(name "${path}" NAME)
  file(READ "${path}" text)
  string(APPEND body "  if (name == \"${name}\") return R\"voxbrick_glsl(${text})voxbrick_glsl\";\n")
endforeach()
string(APPEND body "  throw std::out_of_range(\"shaderSource: no shader named \" + std::string(name));\n}\n\n}  // namespace voxbrick::render\n")
file(WRITE "${OUTPUT}.tmp" "${body}")
execute_process(COMMAND ${CMAKE_COMMAND} -E copy_if_different "${OUTPUT}.tmp" "${OUTPUT}")
