# Folder rules the compiler enforces. No target gets the repository root as an include path: each exposes only the
# headers it lists, through a directory of links in the build tree (build/layers/<target>/<folder>/<header>), so a
# source can include a header of another folder only if its target links the target that exposes it. A target
# that must not see GL never gets the directory that holds the GL headers.

# voxbrick_expose(TARGET SCOPE FOLDER HEADER...): links each HEADER (relative to the calling CMakeLists' folder)
# as <FOLDER>/<its path> in TARGET's header directory, and adds that directory to TARGET's include path with SCOPE
# (PUBLIC, PRIVATE or INTERFACE). Call it once per target and scope.
function(voxbrick_expose target scope folder)
  string(TOLOWER "${scope}" scopeName)
  set(root ${PROJECT_BINARY_DIR}/layers/${target}-${scopeName})
  file(REMOVE_RECURSE ${root})
  foreach(header IN LISTS ARGN)
    get_filename_component(dir ${root}/${folder}/${header} DIRECTORY)
    file(MAKE_DIRECTORY ${dir})
    file(CREATE_LINK ${CMAKE_CURRENT_SOURCE_DIR}/${header} ${root}/${folder}/${header} SYMBOLIC)
  endforeach()
  target_include_directories(${target} ${scope} ${root})
endfunction()

# voxbrick_layer_probe(NAME TARGET HEADER [IN DIR...]): a test that compiles one line, #include "HEADER", with
# TARGET's include path and passes only if the compiler cannot find the header: the rule "TARGET does not see HEADER",
# checked. HEADER must exist, as DIR/HEADER for one of the DIRs (default: the source tree, for the project's own
# headers; a library's include directories for its headers): configuring stops otherwise, since a probe of a header
# that was renamed or removed would pass without checking anything.
function(voxbrick_layer_probe name target header)
  cmake_parse_arguments(PARSE_ARGV 3 probe "" "" "IN")
  if(NOT probe_IN)
    set(probe_IN ${PROJECT_SOURCE_DIR})
  endif()
  set(found FALSE)
  foreach(dir IN LISTS probe_IN)
    if(EXISTS ${dir}/${header} AND NOT IS_DIRECTORY ${dir}/${header})
      set(found TRUE)
    endif()
  endforeach()
  if(NOT found)
    message(FATAL_ERROR "layer probe ${name}: ${header} is not in ${probe_IN}; the probe would check nothing. "
                        "Name a header that exists (was it renamed or moved?)")
  endif()
  set(source ${PROJECT_BINARY_DIR}/layer_probes/${name}.cpp)
  file(WRITE ${source} "#include \"${header}\"\n")
  add_library(layer_probe_${name} OBJECT EXCLUDE_FROM_ALL ${source})
  set_target_properties(layer_probe_${name} PROPERTIES UNITY_BUILD OFF)
  get_target_property(type ${target} TYPE)
  if(type STREQUAL "EXECUTABLE")
    # A program cannot be linked: the probe gets what it compiles with, its own include path and its libraries'.
    get_target_property(dirs ${target} INCLUDE_DIRECTORIES)
    get_target_property(libraries ${target} LINK_LIBRARIES)
    if(dirs)
      target_include_directories(layer_probe_${name} PRIVATE ${dirs})
    endif()
    if(libraries)
      target_link_libraries(layer_probe_${name} PRIVATE ${libraries})
    endif()
  else()
    target_link_libraries(layer_probe_${name} PRIVATE ${target})
  endif()
  add_test(NAME layers.${name}
           COMMAND ${CMAKE_COMMAND} --build ${PROJECT_BINARY_DIR} --target layer_probe_${name})
  string(REPLACE "." "\\." pattern "${header}")
  set_tests_properties(layers.${name} PROPERTIES PASS_REGULAR_EXPRESSION "${pattern}: No such file or directory")
endfunction()

# voxbrick_expose_folder(TARGET SCOPE): links every header directly in the calling CMakeLists' folder as
# <folder>/<header> (the folder's path from the repository root) in TARGET's header directory, and adds that
# directory to TARGET's include path with SCOPE. The folder decides what is exposed: a new header needs no list, and a
# subfolder (its own library) is not exposed with its parent. Call it once per target and scope.
function(voxbrick_expose_folder target scope)
  file(RELATIVE_PATH folder ${PROJECT_SOURCE_DIR} ${CMAKE_CURRENT_SOURCE_DIR})
  file(GLOB headers CONFIGURE_DEPENDS RELATIVE ${CMAKE_CURRENT_SOURCE_DIR} ${CMAKE_CURRENT_SOURCE_DIR}/*.h)
  voxbrick_expose(${target} ${scope} ${folder} ${headers})
endfunction()

# voxbrick_folder_library(TARGET [EXTRA_SOURCE...]): the calling CMakeLists' folder as one static library: every
# .cpp directly in it (and EXTRA_SOURCEs, e.g. generated ones), its headers exposed PUBLIC (voxbrick_expose_folder),
# warnings on. What it may include is what it links: give it its dependencies with target_link_libraries.
function(voxbrick_folder_library target)
  file(GLOB sources CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*.cpp)
  add_library(${target} STATIC ${sources} ${ARGN})
  voxbrick_expose_folder(${target} PUBLIC)
  target_link_libraries(${target} PRIVATE voxbrick_warnings)
endfunction()
