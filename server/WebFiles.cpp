// Lookup of the embedded viewer files, with their content types and entity tags.
#include "server/WebFiles.h"

#include <map>
#include <string>

namespace voxbrick::server {
namespace {

/// FNV-1a of `bytes`, as 16 hex digits in quotes (an HTTP entity tag).
std::string etagOf(std::span<const uint8_t> bytes) {
  uint64_t hash = 1469598103934665603ull;
  for (const uint8_t b : bytes) hash = (hash ^ b) * 1099511628211ull;
  static const char* digits = "0123456789abcdef";
  std::string tag = "\"";
  for (int shift = 60; shift >= 0; shift -= 4) tag += digits[(hash >> shift) & 15];
  return tag + "\"";
}

const std::map<std::string, WebFile, std::less<>>& table() {
  static const std::map<std::string, WebFile, std::less<>> files = [] {
    std::map<std::string, WebFile, std::less<>> m;
    for (const EmbeddedWebFile& f : embeddedWebFiles()) {
      const std::span<const uint8_t> bytes(f.data, f.size);
      m.emplace(f.path, WebFile{f.path, bytes, contentTypeOf(f.path), etagOf(bytes)});
    }
    return m;
  }();
  return files;
}

}  // namespace

const WebFile* findWebFile(std::string_view path) {
  const auto& files = table();
  const auto it = files.find(path);
  return it == files.end() ? nullptr : &it->second;
}

std::string_view contentTypeOf(std::string_view path) {
  static const std::map<std::string, std::string, std::less<>> types = {
      {"html", "text/html; charset=utf-8"},
      {"htm", "text/html; charset=utf-8"},
      {"js", "text/javascript; charset=utf-8"},
      {"mjs", "text/javascript; charset=utf-8"},
      {"css", "text/css; charset=utf-8"},
      {"json", "application/json"},
      {"txt", "text/plain; charset=utf-8"},
      {"md", "text/plain; charset=utf-8"},
      {"svg", "image/svg+xml"},
      {"png", "image/png"},
      {"jpg", "image/jpeg"},
      {"jpeg", "image/jpeg"},
      {"gif", "image/gif"},
      {"ico", "image/x-icon"},
      {"webp", "image/webp"},
      {"wasm", "application/wasm"},
      {"map", "application/json"},
      {"woff2", "font/woff2"},
  };
  const size_t slash = path.rfind('/');
  const size_t dot = path.rfind('.');
  if (dot == std::string_view::npos || (slash != std::string_view::npos && dot < slash))
    return "application/octet-stream";
  const auto it = types.find(path.substr(dot + 1));
  return it == types.end() ? std::string_view("application/octet-stream") : std::string_view(it->second);
}

}  // namespace voxbrick::server
