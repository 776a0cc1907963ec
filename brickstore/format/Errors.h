// The typed exceptions of the brick store. Each message names the function or file and the bad value.
#pragma once

#include <stdexcept>
#include <string>

namespace voxbrick::store {

/// Base of every error the brick store throws.
class StoreError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// An input file or option is malformed, inconsistent or unsupported.
class InputError : public StoreError {
 public:
  using StoreError::StoreError;
};

/// A store on disk is missing parts, truncated or corrupt.
class CorruptStoreError : public StoreError {
 public:
  using StoreError::StoreError;
};

/// The operating system refused a read or write (unwritable path, full disk, ...).
class IoError : public StoreError {
 public:
  using StoreError::StoreError;
};

/// Formats "<what>: <strerror(errno)>" for the current errno.
std::string errnoMessage(const std::string& what);

/// Throws IoError(message): how the store's output files (common::OutputFile) report a failed write.
[[noreturn]] void throwIoError(const std::string& message);

}  // namespace voxbrick::store
