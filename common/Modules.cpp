// Loading voxbrick's modules: dlopen on first use, the entry's table kept for the process's life.
#include "common/Modules.h"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <map>
#include <mutex>
#include <vector>

namespace voxbrick::common {
namespace {

namespace fs = std::filesystem;

std::string fileName(const char* name) { return std::string("libvoxbrick_") + name + ".so"; }

/// The folders a module is looked for in, in order.
std::vector<fs::path> moduleFolders() {
  if (const char* dir = std::getenv("VOXBRICK_MODULE_DIR"); dir && *dir) return {fs::path(dir)};
  std::vector<fs::path> folders;
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    folders.push_back(self.parent_path());
    folders.push_back(self.parent_path().parent_path() / "lib" / "voxbrick");
  }
#ifdef VOXBRICK_MODULE_BUILD_DIR
  folders.push_back(fs::path(VOXBRICK_MODULE_BUILD_DIR));
#endif
  return folders;
}

/// Where module `name` is looked for, in order (what ModuleError lists).
std::string moduleSearchPath(const char* name) {
  std::string path;
  for (const fs::path& folder : moduleFolders())
    path += (path.empty() ? "" : ", ") + (folder / fileName(name)).string();
  return path;
}

struct Loaded {
  std::mutex mutex;
  std::map<std::string, void*> handles;  // by module name
};

Loaded& loaded() {
  static Loaded l;
  return l;
}

void* openModule(const char* name) {
  const std::string file = fileName(name);
  std::string failures;
  for (const fs::path& folder : moduleFolders()) {
    const fs::path path = folder / file;
    std::error_code ec;
    if (!fs::exists(path, ec)) continue;
    ::dlerror();
    if (void* handle = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL)) return handle;
    const char* why = ::dlerror();
    failures += "; " + path.string() + ": " + (why ? why : "dlopen failed");
  }
  throw ModuleError(
      "cannot load voxbrick's " + std::string(name) + " module " + file +
      (failures.empty() ? ": not found (looked in " + moduleSearchPath(name) + ")" : ":" + failures.substr(1)) +
      "; set VOXBRICK_MODULE_DIR to the folder that holds it");
}

}  // namespace

const void* moduleTable(const char* name, const char* entry) {
  Loaded& l = loaded();
  void* handle = nullptr;
  {
    const std::lock_guard lock(l.mutex);
    auto it = l.handles.find(name);
    if (it == l.handles.end()) it = l.handles.emplace(name, openModule(name)).first;
    handle = it->second;
  }
  ::dlerror();
  void* symbol = ::dlsym(handle, entry);
  if (!symbol) {
    const char* why = ::dlerror();
    throw ModuleError("voxbrick's " + std::string(name) + " module " + fileName(name) + " has no entry " + entry +
                      " (" + (why ? why : "not found") + "): it is from another build of voxbrick");
  }
  using Entry = const void* (*)();
  return reinterpret_cast<Entry>(symbol)();
}

}  // namespace voxbrick::common
