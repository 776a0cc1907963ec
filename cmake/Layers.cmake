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

# voxbrick_layer_probe(NAME TARGET HEADER): a test that compiles one line, #include "HEADER", with TARGET's include
# path and passes only if the compiler cannot find the header: the rule "TARGET does not see HEADER", checked.
function(voxbrick_layer_probe name target header)
  set(source ${PROJECT_BINARY_DIR}/layer_probes/${name}.cpp)
  file(WRITE ${source} "#include \"${header}\"\n")
  add_library(layer_probe_${name} OBJECT EXCLUDE_FROM_ALL ${source})
  target_link_libraries(layer_probe_${name} PRIVATE ${target})
  add_test(NAME layers.${name}
           COMMAND ${CMAKE_COMMAND} --build ${PROJECT_BINARY_DIR} --target layer_probe_${name})
  string(REPLACE "." "\\." pattern "${header}")
  set_tests_properties(layers.${name} PROPERTIES PASS_REGULAR_EXPRESSION "${pattern}: No such file or directory")
endfunction()
