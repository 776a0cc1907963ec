// The typed exceptions of the renderer. Each message names the function or input and the bad value.
#pragma once

#include <charconv>
#include <stdexcept>
#include <string>

namespace voxbrick::render {

/// Base of every error the renderer throws.
class RenderError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A scene, camera or transfer-function parameter is malformed or out of range (the caller's fault, not the GPU's).
class RenderInputError : public RenderError {
 public:
  using RenderError::RenderError;
};

/// A frame whose estimated cost is above the limit its caller set (FrameOptions::maxSamples).
class RenderLimitError : public RenderError {
 public:
  using RenderError::RenderError;
};

/// A frame given up part way because its caller no longer wants it (FrameOptions::cancelled).
class FrameCancelled : public RenderError {
 public:
  using RenderError::RenderError;
};

/// Formats a number for an error message: the shortest text that reads back as the same double ("0.1", "1e-09").
inline std::string numberText(double value) {
  char buffer[32];
  auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

}  // namespace voxbrick::render
