# Writes OUTPUT: a C++ source defining voxbrick::render::builtInPresets() over every PRESET_DIR/*.json (name: the
# file's stem), sorted by name.
file(GLOB presets "${PRESET_DIR}/*.json")
list(SORT presets)
set(body "// Generated from config/tf/*.json at build time. Do not edit.\n#include \"render/core/BuiltInPresets.h\"\n\nnamespace voxbrick::render {\n\nconst std::vector<BuiltInPreset>& builtInPresets() {\n  static const std::vector<BuiltInPreset> presets = {\n")
foreach(path IN LISTS presets)
  get_filename_component(name "${path}" NAME_WE)
  file(READ "${path}" text)
  string(APPEND body "      {\"${name}\", R\"voxbrick_json(${text})voxbrick_json\"},\n")
endforeach()
string(APPEND body "  };\n  return presets;\n}\n\n}  // namespace voxbrick::render\n")
file(WRITE "${OUTPUT}.tmp" "${body}")
execute_process(COMMAND ${CMAKE_COMMAND} -E copy_if_different "${OUTPUT}.tmp" "${OUTPUT}")
