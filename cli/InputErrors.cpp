#include "cli/InputErrors.h"

#include <exception>
#include <new>
#include <typeinfo>

#include "brickstore/Errors.h"

namespace voxbrick::cli {
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
  } catch (const store::IoError&) {
    throw;
  } catch (const store::CorruptStoreError& e) {
    if (namesOne(e.what(), named)) throw;
    throw store::CorruptStoreError(file + ": " + e.what());
  } catch (const std::bad_alloc&) {
    throw store::InputError(file + ": out of memory while reading it (std::bad_alloc)");
  } catch (const std::exception& e) {
    if (typeid(e) == typeid(store::StoreError) || namesOne(e.what(), named)) throw;
    throw store::InputError(file + ": " + e.what());
  }
}

}  // namespace voxbrick::cli
