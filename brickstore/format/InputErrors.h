// Errors of reading an input or opening a store, each naming the file whatever library raised it: the one place that
// puts the file's name on an ingest or open error (prep, info and render use it; so may any other opener).
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace voxbrick::store {

/// Rethrows the exception in flight (call it from a catch block) so that it names a file: a message that names one of
/// `named` already passes unchanged, and so do IoError and a plain StoreError (an interruption), which
/// are about no input; any other, a library's own included (JSON, OpenVDB, std::bad_alloc, a mesh check), becomes
/// "NAMED[0]: MESSAGE", a CorruptStoreError if it was one and a InputError otherwise.
[[noreturn]] void rethrowNamingInput(const std::vector<std::string>& named);

/// Throws InputError "PATH: no such file or directory" when nothing is at `path`: the one way every command (prep,
/// info, render, a server opening a dataset) says that an input is missing.
void requirePath(const std::filesystem::path& path);

/// Runs `fn`, whose errors come from reading the file `named[0]`, through rethrowNamingInput.
template <typename F>
decltype(auto) namingInput(const std::vector<std::string>& named, F&& fn) {
  try {
    return std::forward<F>(fn)();
  } catch (...) {
    rethrowNamingInput(named);
  }
}

}  // namespace voxbrick::store
