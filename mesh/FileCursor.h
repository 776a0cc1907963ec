// A read position in a whole mesh file held in memory, for the VTK and gmsh readers: whitespace-separated tokens,
// lines and raw binary values (either byte order), every read bounds-checked, every error naming the file and place.
#pragma once

#include <bit>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "mesh/TetMesh.h"

namespace voxbrick::mesh {

class FileCursor {
 public:
  /// Reads the whole file. Throws MeshError if it cannot be opened or read.
  explicit FileCursor(const std::filesystem::path& path);
  /// Over bytes already in memory; `name` is what errors call the file.
  FileCursor(std::string name, std::vector<char> bytes);

  const std::string& name() const { return mName; }
  size_t offset() const { return mPos; }
  size_t size() const { return mBytes.size(); }
  size_t remaining() const { return mBytes.size() - mPos; }
  bool atEnd() const { return mPos >= mBytes.size(); }
  /// Moves to an absolute offset (clamped to the end), e.g. to parse again from the start.
  void seek(size_t offset) { mPos = offset < mBytes.size() ? offset : mBytes.size(); }
  /// The bytes from `offset` on, for sniffing a format.
  std::string_view view(size_t offset = 0) const;

  /// "FILE, line L (byte B)": the place `offset` for messages.
  std::string where(size_t offset) const;
  /// Throws MeshError "FILE, line L (byte B): what" at the current position, or at `offset`.
  [[noreturn]] void fail(const std::string& what) const { failAt(mPos, what); }
  [[noreturn]] void failAt(size_t offset, const std::string& what) const;

  /// Skips spaces, tabs and line ends.
  void skipWhitespace();
  /// The next whitespace-separated token; empty at the end of the file.
  std::string_view token();
  /// The next token, failing with "expected WHAT" at the end of the file.
  std::string_view token(const char* what);
  /// The next token without consuming it.
  std::string_view peekToken();
  /// The rest of the current line without its line end, and moves past the line end.
  std::string_view line();
  /// Moves past the end of the current line: after a header line, binary data starts there.
  void skipLine();

  /// A token parsed as an integer in [lo, hi]; `what` names it in errors.
  int64_t integer(const char* what, int64_t lo = INT64_MIN, int64_t hi = INT64_MAX);
  /// A token parsed as a real ("nan" and "inf" are accepted: validation, not parsing, refuses them).
  double real(const char* what);
  /// A token parsed straight to the nearest float (going through double could round twice).
  float realFloat(const char* what);
  /// Consumes `keyword` (compared without case) or fails naming both.
  void expect(std::string_view keyword);

  /// Fails unless `count` items of at least `bytesEach` bytes can still fit in the file: the guard before
  /// allocating anything sized by a count read from the file. `slack` extra bytes are allowed: the last of n
  /// text values needs no separator after it.
  void requireFits(uint64_t count, uint64_t bytesEach, const std::string& what, uint64_t slack = 0) const;

  /// Raw bytes; fails if fewer than `n` remain.
  const char* take(size_t n, const char* what);
  /// One binary value of type T; `swap` reverses its bytes (the file's byte order is not the machine's).
  template <class T>
  T binary(bool swap, const char* what) {
    const char* p = take(sizeof(T), what);
    T value;
    if (!swap) {
      std::memcpy(&value, p, sizeof(T));
    } else {
      char reversed[sizeof(T)];
      for (size_t i = 0; i < sizeof(T); ++i) reversed[i] = p[sizeof(T) - 1 - i];
      std::memcpy(&value, reversed, sizeof(T));
    }
    return value;
  }

 private:
  size_t lineAt(size_t offset) const;

  std::string mName;
  std::vector<char> mBytes;
  size_t mPos = 0;
};

/// Whether the bytes of a file with byte order `bigEndian` must be reversed on this machine.
inline bool needsSwap(bool bigEndian) { return bigEndian != (std::endian::native == std::endian::big); }

/// Lower-case ASCII copy, for keywords that the formats compare without case.
std::string lowerCase(std::string_view text);

}  // namespace voxbrick::mesh
