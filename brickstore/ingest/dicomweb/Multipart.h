// A strict, streaming parser of multipart/related bodies (RFC 2046, RFC 2387), as WADO-RS sends DICOM instances: the
// parts' bytes are handed on as they arrive, so a body of any size passes through a buffer of a few kilobytes.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "brickstore/format/Errors.h"

namespace voxbrick::store {

/// A body or media type that is not the multipart/related it must be; `truncated` when the body ended before its
/// closing delimiter (a transfer cut short, which a retry may mend), false for a malformed one.
class MultipartError : public InputError {
 public:
  MultipartError(const std::string& message, bool truncated) : InputError(message), mTruncated(truncated) {}
  bool truncated() const { return mTruncated; }

 private:
  bool mTruncated;
};

/// The parameters of a multipart/related Content-Type that matter here.
struct MultipartType {
  std::string boundary;  ///< the boundary parameter, unquoted
  std::string type;      ///< the type parameter (the parts' root media type), unquoted and lower case; "" if absent
};

/// Parses a Content-Type header value such as `multipart/related; type="application/dicom"; boundary=XYZ`: the
/// media type must be multipart/related (any case); parameters are token=token or token="quoted string" (with
/// backslash escapes), separated by ';' and optional white space; boundary is required, 1 to 200 characters of the
/// set RFC 2046 allows (longer than its 70: some servers send more), not ending in a space. Throws MultipartError
/// naming the problem.
MultipartType parseMultipartType(std::string_view contentType);

/// One part's header fields: names lower case, values with surrounding white space removed, in order.
using PartHeaders = std::vector<std::pair<std::string, std::string>>;

/// The value of header `name` (lower case) in `headers`, or "" when absent.
std::string headerValue(const PartHeaders& headers, std::string_view name);

/// Where a parser delivers its parts; a handler's exception passes out of MultipartParser::feed unchanged.
class PartHandler {
 public:
  virtual ~PartHandler() = default;
  /// A part starts; its header fields.
  virtual void partBegin(const PartHeaders& headers) = 0;
  /// The next bytes of the current part's body (in order; any number of calls, each with at least one byte).
  virtual void partData(const char* data, size_t size) = 0;
  /// The current part's body is complete.
  virtual void partEnd() = 0;
};

/// Splits a multipart body into parts, fed in pieces of any size. The body is: an optional preamble, then
/// "--BOUNDARY" (at the start or after CRLF), optional spaces or tabs, CRLF, header lines ("Name: value" CRLF, no
/// folding) and an empty line, the part's body, and "CRLF--BOUNDARY" again; after the last part "--" closes the body
/// (whatever follows, the epilogue, is ignored). A part's Content-Length, when given, must equal its body's size.
/// Every departure throws MultipartError naming it and the part.
class MultipartParser {
 public:
  /// The limits that bound what a malformed body can make the parser hold.
  struct Limits {
    size_t preambleBytes = size_t(64) << 10;  ///< before the first delimiter
    size_t headerBytes = size_t(16) << 10;    ///< one part's header section
    size_t parts = 1u << 20;                  ///< parts in the body
  };

  MultipartParser(std::string boundary, PartHandler& handler) : MultipartParser(std::move(boundary), handler, {}) {}
  MultipartParser(std::string boundary, PartHandler& handler, Limits limits);

  /// Parses the next `size` bytes of the body.
  void feed(const char* data, size_t size);
  /// The body has ended: throws MultipartError (truncated) unless the closing delimiter was read.
  void finish();

  /// Whether the closing delimiter has been read.
  bool complete() const { return mState == State::Epilogue; }
  /// The parts begun so far.
  size_t parts() const { return mParts; }
  /// The bytes fed so far.
  uint64_t bytesFed() const { return mFed; }

 private:
  enum class State { Preamble, AfterDelimiter, Headers, Body, Epilogue };

  bool step();  // one transition on mBuffer; false when it needs more bytes
  bool stepPreamble();
  bool stepAfterDelimiter();
  bool stepHeaders();
  bool stepBody();
  void endPart();
  std::string where() const;  // "part N" or "the body", for messages

  std::string mDelimiter;  // CRLF "--" BOUNDARY: what ends a part's body
  PartHandler& mHandler;
  Limits mLimits;
  State mState = State::Preamble;
  std::string mBuffer;  // bytes fed but not yet consumed: at most one piece fed plus a delimiter's length
  size_t mParts = 0;
  uint64_t mFed = 0, mPartBytes = 0;
  int64_t mPartLength = -1;  // the current part's Content-Length; -1 when it gave none
};

}  // namespace voxbrick::store
