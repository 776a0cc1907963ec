// voxbrick's own shared modules: the code that needs a large library few commands use (OpenVDB, GDCM) is built as
// a module (libvoxbrick_<name>.so) that a process loads the first time it needs it, so that every other process
// starts without mapping and relocating those libraries (a tenth of a second each time: docs/design/modules.md).
#pragma once

#include <stdexcept>
#include <string>

namespace voxbrick::common {

/// A module that cannot be loaded: its message names the module's file, where it was looked for and why it failed.
class ModuleError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The table of entry points that module `name` (libvoxbrick_<name>.so) gives through its C function `entry`
/// (`const void* entry()`), loading the module the first time it is asked for. Where it is looked for: only in
/// $VOXBRICK_MODULE_DIR when that is set; otherwise beside the running program, in <program's folder>/../lib/voxbrick
/// (as installed), then in the build tree's `modules` folder. Throws ModuleError. Thread-safe; a module is never
/// unloaded.
const void* moduleTable(const char* name, const char* entry);

/// The table as its type, from `linked` when that is not null: the entry's weak declaration, which the program's own
/// copy of the module's code defines where it was linked with it (the sanitized programs, tests/sanitize), so that
/// such a program runs its own copy and loads nothing. VOXBRICK_MODULE_TABLE says it once.
template <class Table>
const Table& moduleTable(const void* (*linked)(), const char* name, const char* entry) {
  return *static_cast<const Table*>(linked ? linked() : moduleTable(name, entry));
}

}  // namespace voxbrick::common

/// The C entry ENTRY of a module (`extern "C" const void* ENTRY()`, returning its table), declared weakly: at global
/// scope, in the one file that asks for its table.
#define VOXBRICK_MODULE_ENTRY_DECLARE(ENTRY) extern "C" const void* ENTRY() __attribute__((weak))
/// The table of type TABLE that entry ENTRY of module NAME gives (declared by VOXBRICK_MODULE_ENTRY_DECLARE).
#define VOXBRICK_MODULE_TABLE(TABLE, NAME, ENTRY) VOXBRICK_MODULE_TABLE_(TABLE, NAME, ENTRY)
#define VOXBRICK_MODULE_TABLE_(TABLE, NAME, ENTRY) ::voxbrick::common::moduleTable<TABLE>(&ENTRY, NAME, #ENTRY)
/// A module's definition of its entry: exported from the module (whose other symbols its version script hides).
#define VOXBRICK_MODULE_ENTRY_DEFINE(ENTRY) extern "C" __attribute__((visibility("default"))) const void* ENTRY()
