// multipart/related: the media type's parameters and the streaming split of a body into parts.
#include "brickstore/ingest/dicomweb/Multipart.h"

#include <algorithm>
#include <cctype>
#include <cstring>

namespace voxbrick::store {
namespace {

constexpr std::string_view kCrlf = "\r\n";
constexpr size_t kMaxBoundary = 200;
constexpr size_t kMaxPadding = 256;  // spaces or tabs after a delimiter

bool isTokenChar(unsigned char c) { return std::isalnum(c) || std::strchr("!#$%&'*+-.^_`|~", c) != nullptr; }

/// RFC 2046's bcharsnospace.
bool isBoundaryChar(unsigned char c) { return std::isalnum(c) || std::strchr("'()+_,-./:=?", c) != nullptr; }

std::string lower(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return out;
}

/// The text for a message: printable ASCII kept, other bytes as \xNN, at most `max` characters of `s`.
std::string shown(std::string_view s, size_t max = 40) {
  static const char* hex = "0123456789abcdef";
  std::string out;
  for (size_t i = 0; i < s.size() && i < max; ++i) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    if (c >= 0x20 && c < 0x7f) {
      out += char(c);
    } else {
      out += "\\x";
      out += hex[c >> 4];
      out += hex[c & 15];
    }
  }
  if (s.size() > max) out += "...";
  return out;
}

[[noreturn]] void malformed(const std::string& message) { throw MultipartError(message, false); }

/// Reads the media type's parameters one at a time.
class ParameterReader {
 public:
  explicit ParameterReader(std::string_view text) : mText(text) {}

  void skipSpace() {
    while (mAt < mText.size() && (mText[mAt] == ' ' || mText[mAt] == '\t')) ++mAt;
  }
  bool atEnd() const { return mAt >= mText.size(); }
  char peek() const { return mText[mAt]; }
  void expect(char c, const std::string& what) {
    if (atEnd() || mText[mAt] != c)
      malformed("Content-Type '" + shown(mText, 120) + "': expected '" + std::string(1, c) + "' " + what +
                (atEnd() ? " at its end" : " at '" + shown(mText.substr(mAt), 20) + "'"));
    ++mAt;
  }
  /// A token; with `slash`, '/' too: an unquoted media type as a parameter value (type=application/dicom), which
  /// RFC 2045 wants quoted but servers send.
  std::string token(const std::string& what, bool slash = false) {
    const size_t start = mAt;
    while (mAt < mText.size() && (isTokenChar(static_cast<unsigned char>(mText[mAt])) || (slash && mText[mAt] == '/')))
      ++mAt;
    if (mAt == start)
      malformed("Content-Type '" + shown(mText, 120) + "': expected " + what +
                (atEnd() ? " at its end" : " at '" + shown(mText.substr(mAt), 20) + "'"));
    return std::string(mText.substr(start, mAt - start));
  }
  /// A quoted string after its opening quote: backslash escapes any character; the closing quote ends it.
  std::string quoted() {
    std::string out;
    while (mAt < mText.size()) {
      const char c = mText[mAt++];
      if (c == '"') return out;
      if (c == '\\') {
        if (mAt >= mText.size()) break;
        out += mText[mAt++];
      } else if (static_cast<unsigned char>(c) < 0x20 && c != '\t') {
        malformed("Content-Type '" + shown(mText, 120) + "': a control character in a quoted parameter value");
      } else {
        out += c;
      }
    }
    malformed("Content-Type '" + shown(mText, 120) + "': a quoted parameter value is not closed");
  }

 private:
  std::string_view mText;
  size_t mAt = 0;
};

}  // namespace

MultipartType parseMultipartType(std::string_view contentType) {
  ParameterReader r(contentType);
  r.skipSpace();
  const std::string type = lower(r.token("a media type"));
  r.expect('/', "after the media type");
  const std::string subtype = lower(r.token("a media subtype"));
  if (type != "multipart" || subtype != "related")
    malformed("Content-Type '" + shown(contentType, 120) + "' is not multipart/related");
  MultipartType result;
  bool haveBoundary = false, haveType = false;
  r.skipSpace();
  while (!r.atEnd()) {
    r.expect(';', "between parameters");
    r.skipSpace();
    if (r.atEnd()) break;  // a trailing ';'
    const std::string name = lower(r.token("a parameter name"));
    r.skipSpace();
    r.expect('=', "after parameter '" + name + "'");
    r.skipSpace();
    std::string value;
    if (!r.atEnd() && r.peek() == '"') {
      r.expect('"', "");
      value = r.quoted();
    } else {
      value = r.token("the value of parameter '" + name + "'", true);
    }
    r.skipSpace();
    if (name == "boundary") {
      if (haveBoundary) malformed("Content-Type '" + shown(contentType, 120) + "': boundary given twice");
      haveBoundary = true;
      result.boundary = value;
    } else if (name == "type") {
      if (haveType) malformed("Content-Type '" + shown(contentType, 120) + "': type given twice");
      haveType = true;
      result.type = lower(value);
    }
  }
  if (!haveBoundary) malformed("Content-Type '" + shown(contentType, 120) + "' has no boundary parameter");
  const std::string& b = result.boundary;
  if (b.empty() || b.size() > kMaxBoundary)
    malformed("Content-Type: boundary '" + shown(b) + "' is " + std::to_string(b.size()) + " characters (1 to " +
              std::to_string(kMaxBoundary) + ")");
  for (size_t i = 0; i < b.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(b[i]);
    if (!isBoundaryChar(c) && !(c == ' ' && i + 1 < b.size()))
      malformed("Content-Type: boundary '" + shown(b) + "' holds '" + shown(b.substr(i, 1)) +
                "', which a boundary may not (RFC 2046)");
  }
  return result;
}

std::string headerValue(const PartHeaders& headers, std::string_view name) {
  for (const auto& [n, v] : headers)
    if (n == name) return v;
  return "";
}

MultipartParser::MultipartParser(std::string boundary, PartHandler& handler, Limits limits)
    : mDelimiter("\r\n--" + boundary), mHandler(handler), mLimits(limits) {
  if (boundary.empty()) malformed("multipart body: empty boundary");
}

void MultipartParser::feed(const char* data, size_t size) {
  mFed += size;
  if (mState == State::Epilogue || size == 0) return;
  mBuffer.append(data, size);
  while (step()) {
  }
}

void MultipartParser::finish() {
  switch (mState) {
    case State::Epilogue: return;
    case State::Preamble:
      throw MultipartError("multipart body ends after " + std::to_string(mFed) + " bytes without a boundary", true);
    case State::AfterDelimiter:
    case State::Headers:
      throw MultipartError(
          "multipart body ends in the headers of " + where() + " (after " + std::to_string(mFed) + " bytes)", true);
    case State::Body:
      throw MultipartError("multipart body ends in " + where() + " after " +
                               std::to_string(mPartBytes + mBuffer.size()) +
                               " bytes of it, before its closing boundary (" + std::to_string(mFed) + " bytes in all)",
                           true);
  }
}

std::string MultipartParser::where() const { return "part " + std::to_string(mParts); }

bool MultipartParser::step() {
  switch (mState) {
    case State::Preamble: return stepPreamble();
    case State::AfterDelimiter: return stepAfterDelimiter();
    case State::Headers: return stepHeaders();
    case State::Body: return stepBody();
    case State::Epilogue: mBuffer.clear(); return false;
  }
  return false;
}

bool MultipartParser::stepPreamble() {
  // The first delimiter may open the body without the CRLF before it.
  const std::string_view dashBoundary = std::string_view(mDelimiter).substr(2);
  const std::string_view buffer = mBuffer;
  const uint64_t before = mFed - mBuffer.size();  // bytes of the body before mBuffer
  if (before == 0) {
    if (buffer.size() < dashBoundary.size() && dashBoundary.substr(0, buffer.size()) == buffer) return false;
    if (buffer.substr(0, dashBoundary.size()) == dashBoundary) {
      mBuffer.erase(0, dashBoundary.size());
      mState = State::AfterDelimiter;
      return true;
    }
  }
  const size_t at = buffer.find(mDelimiter);
  if (at != std::string_view::npos && before + at > mLimits.preambleBytes)
    malformed("multipart body: no boundary in its first " + std::to_string(mLimits.preambleBytes) + " bytes");
  if (at != std::string_view::npos) {
    mBuffer.erase(0, at + mDelimiter.size());
    mState = State::AfterDelimiter;
    return true;
  }
  if (mFed > mLimits.preambleBytes)
    malformed("multipart body: no boundary in its first " + std::to_string(mLimits.preambleBytes) +
              " bytes (it starts '" + shown(buffer, 24) + "')");
  // Keep what may be the start of a delimiter. The buffer keeps its first byte's offset only through `before`, so
  // the preamble's first bytes are dropped only once the case of a delimiter at offset 0 is decided above.
  if (buffer.size() >= mDelimiter.size()) mBuffer.erase(0, buffer.size() - (mDelimiter.size() - 1));
  return false;
}

bool MultipartParser::stepAfterDelimiter() {
  if (mBuffer.size() < 2) return false;
  if (mBuffer.compare(0, 2, "--") == 0) {
    if (mParts == 0) malformed("multipart body: closed before its first part");
    mBuffer.clear();
    mState = State::Epilogue;
    return false;
  }
  size_t padding = 0;
  while (padding < mBuffer.size() && (mBuffer[padding] == ' ' || mBuffer[padding] == '\t')) ++padding;
  if (padding > kMaxPadding)
    malformed("multipart body: more than " + std::to_string(kMaxPadding) + " spaces after the delimiter before part " +
              std::to_string(mParts + 1));
  if (padding + 2 > mBuffer.size()) return false;
  if (mBuffer.compare(padding, 2, kCrlf) != 0)
    malformed("multipart body: the delimiter before part " + std::to_string(mParts + 1) + " is followed by '" +
              shown(std::string_view(mBuffer).substr(padding, 16)) + "', not CRLF or '--'");
  mBuffer.erase(0, padding + 2);
  if (mParts >= mLimits.parts) malformed("multipart body: more than " + std::to_string(mLimits.parts) + " parts");
  ++mParts;
  mState = State::Headers;
  return true;
}

bool MultipartParser::stepHeaders() {
  size_t end;  // the header section's length, its final CRLF CRLF (or lone CRLF when empty) included
  if (mBuffer.size() >= 2 && mBuffer.compare(0, 2, kCrlf) == 0) {
    end = 2;
  } else {
    const size_t at = mBuffer.find("\r\n\r\n");
    if (at == std::string::npos) {
      if (mBuffer.size() > mLimits.headerBytes)
        malformed("multipart body: the headers of " + where() + " exceed " + std::to_string(mLimits.headerBytes) +
                  " bytes");
      return false;
    }
    end = at + 4;
  }
  if (end > mLimits.headerBytes + 4)
    malformed("multipart body: the headers of " + where() + " exceed " + std::to_string(mLimits.headerBytes) +
              " bytes");
  PartHeaders headers;
  const std::string_view section = std::string_view(mBuffer).substr(0, end - 2);  // each line with its CRLF
  size_t lineStart = 0;
  while (lineStart < section.size()) {
    const size_t lineEnd = section.find(kCrlf, lineStart);
    const std::string_view line = section.substr(lineStart, lineEnd - lineStart);
    lineStart = lineEnd + 2;
    if (line.find_first_of("\r\n") != std::string_view::npos)
      malformed("multipart body: a bare CR or LF in the headers of " + where() + ": '" + shown(line) + "'");
    if (!line.empty() && (line[0] == ' ' || line[0] == '\t'))
      malformed("multipart body: a folded header line in " + where() + ": '" + shown(line) + "'");
    const size_t colon = line.find(':');
    if (colon == std::string_view::npos || colon == 0 ||
        !std::all_of(line.begin(), line.begin() + long(colon), [](char c) { return isTokenChar((unsigned char)c); }))
      malformed("multipart body: '" + shown(line) + "' in the headers of " + where() + " is not 'Name: value'");
    std::string_view value = line.substr(colon + 1);
    while (!value.empty() && (value.front() == ' ' || value.front() == '\t')) value.remove_prefix(1);
    while (!value.empty() && (value.back() == ' ' || value.back() == '\t')) value.remove_suffix(1);
    headers.emplace_back(lower(line.substr(0, colon)), std::string(value));
  }
  mPartLength = -1;
  for (const auto& [name, value] : headers) {
    if (name != "content-length") continue;
    if (mPartLength >= 0) malformed("multipart body: Content-Length given twice in " + where());
    if (value.empty() || value.size() > 18 ||
        !std::all_of(value.begin(), value.end(), [](char c) { return c >= '0' && c <= '9'; }))
      malformed("multipart body: Content-Length '" + shown(value) + "' of " + where() + " is not a byte count");
    mPartLength = std::stoll(value);
  }
  mBuffer.erase(0, end);
  mPartBytes = 0;
  mState = State::Body;
  mHandler.partBegin(headers);
  return true;
}

bool MultipartParser::stepBody() {
  const size_t at = mBuffer.find(mDelimiter);
  if (at != std::string::npos) {
    if (at > 0) {
      mPartBytes += at;
      mHandler.partData(mBuffer.data(), at);
    }
    mBuffer.erase(0, at + mDelimiter.size());
    endPart();
    mState = State::AfterDelimiter;
    return true;
  }
  // All but the bytes that may begin a delimiter are the part's.
  if (mBuffer.size() >= mDelimiter.size()) {
    const size_t ready = mBuffer.size() - (mDelimiter.size() - 1);
    mPartBytes += ready;
    mHandler.partData(mBuffer.data(), ready);
    mBuffer.erase(0, ready);
  }
  return false;
}

void MultipartParser::endPart() {
  if (mPartLength >= 0 && uint64_t(mPartLength) != mPartBytes)
    malformed("multipart body: " + where() + " holds " + std::to_string(mPartBytes) +
              " bytes, its Content-Length says " + std::to_string(mPartLength));
  mHandler.partEnd();
}

}  // namespace voxbrick::store
