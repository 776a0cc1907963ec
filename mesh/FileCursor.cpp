#include "mesh/FileCursor.h"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <fstream>
#include <system_error>

namespace voxbrick::mesh {

namespace {

bool isSpace(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f'; }

// Tokens quoted in messages are cut short: a binary file read as text can produce very long "tokens".
std::string quoted(std::string_view text) {
  constexpr size_t kMax = 40;
  std::string out = "'" + std::string(text.substr(0, kMax));
  for (char& c : out)
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) >= 0x7f) c = '?';
  return out + (text.size() > kMax ? "...'" : "'");
}

}  // namespace

std::string lowerCase(std::string_view text) {
  std::string out(text);
  for (char& c : out)
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  return out;
}

FileCursor::FileCursor(const std::filesystem::path& path) : mName(path.string()) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw MeshError(mName + ": not a readable file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw MeshError(mName + ": cannot open: " + std::generic_category().message(errno));
  const uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) throw MeshError(mName + ": cannot get its size: " + ec.message());
  mBytes.resize(static_cast<size_t>(size));
  if (size > 0 && !in.read(mBytes.data(), static_cast<std::streamsize>(size)))
    throw MeshError(mName + ": read failed after " + std::to_string(in.gcount()) + " of " + std::to_string(size) +
                    " bytes");
}

FileCursor::FileCursor(std::string name, std::vector<char> bytes) : mName(std::move(name)), mBytes(std::move(bytes)) {}

std::string_view FileCursor::view(size_t offset) const {
  if (offset >= mBytes.size()) return {};
  return std::string_view(mBytes.data() + offset, mBytes.size() - offset);
}

size_t FileCursor::lineAt(size_t offset) const {
  offset = std::min(offset, mBytes.size());
  return 1 + static_cast<size_t>(std::count(mBytes.begin(), mBytes.begin() + static_cast<ptrdiff_t>(offset), '\n'));
}

std::string FileCursor::where(size_t offset) const {
  return mName + ", line " + std::to_string(lineAt(offset)) + " (byte " + std::to_string(offset) + ")";
}

void FileCursor::failAt(size_t offset, const std::string& what) const { throw MeshError(where(offset) + ": " + what); }

void FileCursor::skipWhitespace() {
  while (mPos < mBytes.size() && isSpace(mBytes[mPos])) ++mPos;
}

std::string_view FileCursor::token() {
  skipWhitespace();
  const size_t start = mPos;
  while (mPos < mBytes.size() && !isSpace(mBytes[mPos])) ++mPos;
  return std::string_view(mBytes.data() + start, mPos - start);
}

std::string_view FileCursor::token(const char* what) {
  std::string_view t = token();
  if (t.empty()) fail(std::string("unexpected end of file, expected ") + what);
  return t;
}

std::string_view FileCursor::peekToken() {
  const size_t saved = mPos;
  std::string_view t = token();
  mPos = saved;
  return t;
}

std::string_view FileCursor::line() {
  const size_t start = mPos;
  while (mPos < mBytes.size() && mBytes[mPos] != '\n') ++mPos;
  size_t end = mPos;
  if (end > start && mBytes[end - 1] == '\r') --end;
  if (mPos < mBytes.size()) ++mPos;
  return std::string_view(mBytes.data() + start, end - start);
}

void FileCursor::skipLine() { line(); }

int64_t FileCursor::integer(const char* what, int64_t lo, int64_t hi) {
  const size_t at = (skipWhitespace(), mPos);
  std::string_view t = token(what);
  std::string_view digits = t.size() > 1 && t[0] == '+' ? t.substr(1) : t;
  int64_t value = 0;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (ec == std::errc::result_out_of_range) failAt(at, std::string(what) + " " + quoted(t) + " is out of range");
  if (ec != std::errc() || end != digits.data() + digits.size())
    failAt(at, std::string("expected an integer (") + what + "), got " + quoted(t));
  if (value < lo || value > hi)
    failAt(at, std::string(what) + " " + std::to_string(value) + " is out of range [" + std::to_string(lo) + ", " +
                   std::to_string(hi) + "]");
  return value;
}

namespace {

template <class T>
T parseReal(FileCursor& in, const char* what) {
  in.skipWhitespace();
  const size_t at = in.offset();
  std::string_view t = in.token(what);
  std::string_view digits = t.size() > 1 && t[0] == '+' ? t.substr(1) : t;
  T value = 0;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  // Subnormal values come back as out of range but with the value set; anything larger is a real overflow.
  if (ec == std::errc::result_out_of_range && std::abs(value) > T(1))
    in.failAt(at, std::string(what) + " " + quoted(t) + " is out of range");
  if ((ec != std::errc() && ec != std::errc::result_out_of_range) || end != digits.data() + digits.size())
    in.failAt(at, std::string("expected a number (") + what + "), got " + quoted(t));
  return value;
}

}  // namespace

double FileCursor::real(const char* what) { return parseReal<double>(*this, what); }

float FileCursor::realFloat(const char* what) { return parseReal<float>(*this, what); }

void FileCursor::expect(std::string_view keyword) {
  const size_t at = (skipWhitespace(), mPos);
  std::string_view t = token();
  if (lowerCase(t) != lowerCase(keyword))
    failAt(at, "expected " + std::string(keyword) + ", got " + (t.empty() ? std::string("end of file") : quoted(t)));
}

void FileCursor::requireFits(uint64_t count, uint64_t bytesEach, const std::string& what, uint64_t slack) const {
  if (bytesEach > 0 && count > (remaining() + slack) / bytesEach)
    fail(what + ": a count of " + std::to_string(count) + " needs at least " +
         (count > UINT64_MAX / bytesEach ? std::string("more") : std::to_string(count * bytesEach)) +
         " bytes, but only " + std::to_string(remaining()) + " remain in the file");
}

const char* FileCursor::take(size_t n, const char* what) {
  if (n > remaining())
    fail(std::string("unexpected end of file in ") + what + " (" + std::to_string(n) + " bytes needed, " +
         std::to_string(remaining()) + " remain)");
  const char* p = mBytes.data() + mPos;
  mPos += n;
  return p;
}

}  // namespace voxbrick::mesh
