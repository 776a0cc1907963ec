// The viewer's files (every file under web/ in the source tree), embedded in the binary at build time by
// cmake/EmbedWebFiles.cmake, so an installed or moved binary serves them. Looked up by name only: no request ever
// reaches the file system.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

namespace voxbrick::server {

/// One embedded file as the generated source lists it.
struct EmbeddedWebFile {
  const char* path;  ///< relative to web/, with '/' separators (e.g. "index.html", "js/view.js")
  const unsigned char* data;
  size_t size;
};

/// Every embedded file, sorted by path (defined by the generated source).
std::span<const EmbeddedWebFile> embeddedWebFiles();

/// An embedded file ready to be served.
struct WebFile {
  std::string_view path;
  std::span<const uint8_t> bytes;
  std::string_view contentType;  ///< from the file name's extension
  std::string etag;              ///< a quoted hash of the bytes
};

/// The embedded file at `path` (relative to web/, no leading '/'); nullptr if there is none.
const WebFile* findWebFile(std::string_view path);

/// The Content-Type of a file named `path` (by its extension; application/octet-stream when unknown).
std::string_view contentTypeOf(std::string_view path);

}  // namespace voxbrick::server
