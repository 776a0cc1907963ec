#include "brickstore/format/InputErrors.h"

#include <exception>
#include <new>
#include <typeinfo>

#include "brickstore/format/Errors.h"

namespace voxbrick::store {
namespace {

bool namesOne(const std::string& message, const std::vector<std::string>& named) {
  for (const std::string& name : named)
    if (!name.empty() && message.find(name) != std::string::npos) return true;
  return false;
}

}  // namespace

void rethrowNamingInput(const std::vector<std::string>& named) {
  const std::string file = named.empty() ? std::string("input") : named.front();
  try {
    throw;
  } catch (const IoError&) {
    throw;
  } catch (const CorruptStoreError& e) {
    if (namesOne(e.what(), named)) throw;
    throw CorruptStoreError(file + ": " + e.what());
  } catch (const std::bad_alloc&) {
    throw InputError(file + ": out of memory while reading it (std::bad_alloc)");
  } catch (const std::exception& e) {
    if (typeid(e) == typeid(StoreError) || namesOne(e.what(), named)) throw;
    throw InputError(file + ": " + e.what());
  }
}

void requirePath(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw InputError(path.string() + ": no such file or directory");
}

}  // namespace voxbrick::store
