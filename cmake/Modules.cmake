# voxbrick's modules (common/Modules.h): the code that needs a large library few commands use, built as a shared
# library that a process loads on first use instead of at its start.

# The folder the build puts the modules in; common/Modules.cpp looks there last (after $VOXBRICK_MODULE_DIR, beside
# the program and ../lib/voxbrick), so that every program of the build tree finds them.
set(VOXBRICK_MODULE_BUILD_DIR ${PROJECT_BINARY_DIR}/modules)
set_property(GLOBAL PROPERTY VOXBRICK_MODULES "")

# voxbrick_module(NAME LIBRARY): libvoxbrick_NAME.so in the build's module folder, made of the whole of static
# LIBRARY (its code, position-independent, with every library it links but the shared ones, which the module loads
# in its turn). Only its entries (C functions named voxbrick_module_*) are exported (cmake/module.map), so its copies
# of the project's code stay its own; every symbol must resolve at link time (--no-undefined). The command line
# depends on it and installs it in lib/voxbrick.
function(voxbrick_module name library)
  set(anchor ${PROJECT_BINARY_DIR}/modules-src/${name}.cpp)
  file(WRITE ${anchor} "// libvoxbrick_${name}.so: the whole of ${library} (cmake/Modules.cmake).\n")
  add_library(voxbrick_${name} MODULE ${anchor})
  target_link_libraries(voxbrick_${name} PRIVATE "$<LINK_LIBRARY:WHOLE_ARCHIVE,${library}>")
  target_link_options(voxbrick_${name} PRIVATE -Wl,--version-script=${PROJECT_SOURCE_DIR}/cmake/module.map
                      -Wl,--no-undefined)
  set_target_properties(voxbrick_${name} PROPERTIES OUTPUT_NAME voxbrick_${name} PREFIX lib
                        LIBRARY_OUTPUT_DIRECTORY ${VOXBRICK_MODULE_BUILD_DIR}
                        LINK_DEPENDS ${PROJECT_SOURCE_DIR}/cmake/module.map)
  set_property(GLOBAL APPEND PROPERTY VOXBRICK_MODULES voxbrick_${name})
endfunction()
