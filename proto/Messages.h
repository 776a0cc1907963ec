// The voxbrick wire protocol: message types, their fields, limits and error codes (the spec is PROTOCOL.md).
// This folder knows nothing of rendering or sockets: it turns messages into bytes and bytes into messages, checking
// every length and count against the limits before anything is allocated.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace voxbrick::proto {

/// First four bytes of every message: 'V' 'X' 'B' 'K'.
constexpr uint32_t kMagic = 0x4B425856;  // read as a little-endian uint32
/// The versions this code speaks (PROTOCOL.md section 9): version 2 is version 1 plus the jpeg encoding; version 3
/// is version 2 plus the error code Busy; version 4 is version 3 plus the video encodings (vp8, vp9) and the message
/// FrameReceived; version 5 is version 4 plus the messages Authenticate and Authenticated and the error code
/// Forbidden (an access token presented on any transport); version 6 is version 5 plus the messages Upload,
/// UploadReady and UploadChunk and the error code AlreadyExists (a volume sent to become a dataset); version 7 is
/// version 6 plus the webp encoding (lossless WebP) and the scene key `accepts_webp`; version 8 is version 7 with
/// provisional frames sent at the size they were drawn (kProvisionalAsDrawnVersion); version 9 is version 8 plus the
/// scene key `accepts_vp9_444` (kVp9FullChromaVersion).
constexpr uint16_t kMinVersion = 1;
constexpr uint16_t kMaxVersion = 9;
/// From this version a provisional Frame in a still encoding (not vp8 or vp9) is sent at the size the interactive
/// ladder drew it, which may be smaller than its scene; the client shows it at the scene's size (PROTOCOL.md,
/// Session 8). Before it, the server scales such a frame up to the scene's size itself.
constexpr uint16_t kProvisionalAsDrawnVersion = 8;
/// From this version a Render's scene may say `accepts_vp9_444`: its session's vp9 stream may then be VP9 profile 1,
/// 4:4:4 (PROTOCOL.md, Session 11).
constexpr uint16_t kVp9FullChromaVersion = 9;
/// Version 1, which every peer speaks: what encode() and Header write unless told otherwise, and the version a
/// Hello is written in by a client whose lowest version is 1.
constexpr uint16_t kVersion = kMinVersion;
/// Every message starts with a fixed header: magic u32, version u16, type u16, request id u32, body length u32.
/// All integers on the wire are little-endian.
constexpr size_t kHeaderBytes = 16;

enum class MessageType : uint16_t {
  Hello = 1,         ///< client -> server: first message of a session
  Capabilities = 2,  ///< server -> client: answer to Hello
  ListDatasets = 3,  ///< client -> server
  DatasetList = 4,   ///< server -> client
  OpenDataset = 5,   ///< client -> server: selects the session's dataset
  DatasetInfo = 6,   ///< server -> client: its metadata
  Render = 7,        ///< client -> server: one frame of the open dataset
  Frame = 8,         ///< server -> client: the rendered frame
  Error = 9,         ///< server -> client: a request failed (the session goes on unless the code says otherwise)
  GetStats = 10,     ///< client -> server
  Stats = 11,        ///< server -> client
  Goodbye = 12,      ///< either way: the sender closes the session
  /// Version 4 on, client -> server: a Frame has arrived (one per Frame, in order; nothing answers it). The server
  /// paces a session's frames and sets its video bitrate by them.
  FrameReceived = 13,
  /// Version 5 on, client -> server: the session's access token, after Hello and before OpenDataset; answered by
  /// Authenticated, or by Error Forbidden (and the server closes).
  Authenticate = 14,
  /// Version 5 on, server -> client: the token was taken; the session may now list and open its datasets.
  Authenticated = 15,
  /// Version 6 on, client -> server: a volume to become a new dataset (its name, voxel description and size);
  /// answered by UploadReady, or an Error.
  Upload = 16,
  /// Version 6 on, server -> client: the upload is taken; the client sends its voxels in UploadChunks.
  UploadReady = 17,
  /// Version 6 on, client -> server: the upload's next voxels; the last is answered by the new dataset's DatasetInfo
  /// once it is prepped (or an Error), the others by nothing.
  UploadChunk = 18,
};
/// Whether message `type` exists in protocol `version` (FrameReceived from version 4 on, Authenticate and
/// Authenticated from version 5 on, Upload, UploadReady and UploadChunk from version 6 on).
bool messageTypeInVersion(MessageType type, uint16_t version);

/// Error codes carried by an Error message. Values are stable across versions.
enum class ErrorCode : uint16_t {
  BadMagic = 1,            ///< header does not start with the magic (the server closes the connection)
  UnsupportedVersion = 2,  ///< header version not supported (closes)
  UnknownType = 3,         ///< message type not known (session goes on)
  TooLarge = 4,            ///< body length above the limit (closes: the stream cannot be resynchronised)
  Malformed = 5,           ///< body does not decode: short, trailing bytes, bad enum, string or count over limit
  UnexpectedMessage = 6,   ///< valid message in the wrong state (e.g. Render before Hello or before OpenDataset)
  UnknownDataset = 7,      ///< OpenDataset names no configured dataset
  InvalidScene = 8,        ///< the scene JSON is invalid or out of range (message names the key)
  LimitExceeded = 9,       ///< image size, queued requests or sessions above the configured limit
  Superseded = 10,         ///< a queued Render was replaced by a newer one of the same session (latest wins)
  Internal = 11,           ///< the server failed (render or store error); other sessions are unaffected
  ShuttingDown = 12,       ///< the server is stopping
  Timeout = 13,            ///< idle or read timeout (the server closes)
  /// Version 3 on: the server is over capacity for this request or session; the message ends with "; retry after N
  /// ms" (busyMessage, retryAfterMs). An older session gets LimitExceeded with the same message.
  Busy = 14,
  /// Version 5 on: an access token that opens nothing (Authenticate); the server closes.
  Forbidden = 15,
  /// Version 6 on: an Upload names a dataset that exists or is being uploaded (the session goes on).
  AlreadyExists = 16,
};
/// Whether `code` exists in protocol `version` (Busy from version 3 on, Forbidden from version 5 on, AlreadyExists
/// from version 6 on).
bool errorCodeInVersion(ErrorCode code, uint16_t version);
/// The message of a Busy reply: `what`, then "; retry after N ms" (N = `retryAfterMs`, at least 1).
std::string busyMessage(std::string_view what, uint32_t retryAfterMs);
/// The retry hint of a Busy (or LimitExceeded) message: N of its "; retry after N ms" ending; none without one.
std::optional<uint32_t> retryAfterMs(std::string_view message);
/// Offset of the first byte of `p` that does not start a well-formed UTF-8 sequence (Unicode Table 3-7: no overlong
/// forms, no surrogates, nothing above U+10FFFF), or `size` if all are well formed.
size_t invalidUtf8At(const uint8_t* p, size_t size);

/// The code's name as PROTOCOL.md spells it ("BadMagic", ...), or "unknown" for a value outside the enum.
const char* errorCodeName(ErrorCode code);

/// Frame payload encodings.
enum class Encoding : uint8_t {
  RawRgba8 = 0,   ///< width*height*4 bytes, rows top to bottom
  Png = 1,        ///< an RGBA8 PNG file
  ZstdRgba8 = 2,  ///< one zstd frame that decompresses to RawRgba8
  Jpeg = 3,       ///< a baseline JPEG file, 8-bit RGB (alpha dropped); protocol version 2 on
  Vp8 = 4,        ///< one VP8 frame of the session's video stream (image/Video.h); protocol version 4 on
  Vp9 = 5,        ///< one VP9 frame of the session's video stream; protocol version 4 on
  Webp = 6,       ///< a lossless WebP file: the pixels of the png frame, in fewer bytes; protocol version 7 on
};
/// Whether `encoding` exists in protocol `version` (jpeg from version 2 on, vp8 and vp9 from 4, webp from 7; nothing
/// outside the enum).
bool encodingInVersion(Encoding encoding, uint16_t version);
/// The first protocol version that has `encoding` (kMaxVersion + 1 for a value outside the enum).
uint16_t firstVersionOf(Encoding encoding);
/// The encodings of protocol `version`, in value order: what a server of that session offers.
std::vector<Encoding> encodingsOf(uint16_t version);
/// The encoding's name as PROTOCOL.md spells it ("raw_rgba8", "png", "zstd_rgba8", "jpeg", "vp8", "vp9", "webp"),
/// or "unknown".
const char* encodingName(Encoding encoding);
/// The encoding a short name gives, as scenes (`provisional_encoding`) and the command line spell them: "raw",
/// "png", "zstd", "jpeg", "vp8", "vp9", "webp"; nothing for another text.
std::optional<Encoding> encodingFromShortName(std::string_view name);
/// Those short names, in the order of the encodings' values (for a command line's list of choices).
std::vector<std::string> encodingShortNames();

struct Hello {
  uint16_t minVersion = kVersion, maxVersion = kVersion;
  std::string client;  ///< free text, e.g. "voxbrick-request 0.1"

  bool operator==(const Hello&) const = default;
};
struct Capabilities {
  uint16_t version = kVersion;  ///< the version the session will speak
  std::string server;           ///< free text
  uint32_t maxMessageBytes = 0;
  uint32_t maxImageSide = 0;
  uint32_t maxQueuedPerSession = 0;
  std::vector<Encoding> encodings;

  bool operator==(const Capabilities&) const = default;
};
struct ListDatasets {
  bool operator==(const ListDatasets&) const = default;
};
struct DatasetList {
  std::vector<std::string> names;

  bool operator==(const DatasetList&) const = default;
};
struct OpenDataset {
  std::string name;

  bool operator==(const OpenDataset&) const = default;
};
struct DatasetInfo {
  std::string name;
  std::string metaJson;  ///< the store's metadata as `voxbrick info --json` prints it

  bool operator==(const DatasetInfo&) const = default;
};
struct RenderRequest {
  Encoding encoding = Encoding::Png;
  std::string sceneJson;  ///< the scene schema of `voxbrick render --scene`

  bool operator==(const RenderRequest&) const = default;
};
struct Frame {
  uint32_t width = 0, height = 0;
  Encoding encoding = Encoding::Png;
  std::string statsJson;         ///< per-frame statistics (render FrameStats plus queue and encode times)
  std::vector<uint8_t> payload;  ///< the image in `encoding`

  bool operator==(const Frame&) const = default;
};
struct Error {
  ErrorCode code = ErrorCode::Internal;
  std::string message;  ///< names the problem

  bool operator==(const Error&) const = default;
};
struct GetStats {
  bool operator==(const GetStats&) const = default;
};
struct Stats {
  std::string json;  ///< server statistics

  bool operator==(const Stats&) const = default;
};
struct Goodbye {
  bool operator==(const Goodbye&) const = default;
};
struct FrameReceived {
  uint32_t frameBytes = 0;  ///< the bytes of the Frame message that arrived, header included

  bool operator==(const FrameReceived&) const = default;
};

struct Authenticate {
  std::string token;  ///< the secret, as the server's operator handed it out

  bool operator==(const Authenticate&) const = default;
};
struct Authenticated {
  std::string tokenId;  ///< the token's name in the server's configuration (never its secret)

  bool operator==(const Authenticated&) const = default;
};

struct Upload {
  std::string name;      ///< the new dataset's name (DatasetRegistry::validName, not starting with '.')
  std::string metaJson;  ///< the voxels: dims, type, endian, spacing, origin, patient (PROTOCOL.md, Upload)
  uint64_t bytes = 0;    ///< the voxels' size: x * y * z * the type's size

  bool operator==(const Upload&) const = default;
};
struct UploadReady {
  uint32_t chunkBytes = 0;  ///< the most voxel bytes one UploadChunk may carry

  bool operator==(const UploadReady&) const = default;
};
struct UploadChunk {
  std::vector<uint8_t> data;  ///< the next voxels, x fastest, then y, then z

  bool operator==(const UploadChunk&) const = default;
};

using Message = std::variant<Hello, Capabilities, ListDatasets, DatasetList, OpenDataset, DatasetInfo, RenderRequest,
                             Frame, Error, GetStats, Stats, Goodbye, FrameReceived, Authenticate, Authenticated, Upload,
                             UploadReady, UploadChunk>;
MessageType messageType(const Message& message);
/// The type's name as PROTOCOL.md spells it ("Hello", "Render", ...), or "unknown" for a value outside the enum.
const char* messageTypeName(MessageType type);

/// The fixed header, little-endian:
///
///   offset  0       4        6     8           12          16
///           | magic | version | type | requestId | bodyBytes | body (bodyBytes bytes) ...
///             u32     u16       u16    u32         u32
struct Header {
  uint16_t version = kVersion;
  MessageType type = MessageType::Hello;
  uint32_t requestId = 0;  ///< chosen by the client; replies carry the id of the request they answer
  uint32_t bodyBytes = 0;

  bool operator==(const Header&) const = default;
};

/// Limits checked while decoding, before any allocation.
struct Limits {
  uint32_t maxBodyBytes = 64u << 20;  ///< a header announcing more is TooLarge
  uint32_t maxStringBytes = 1u << 20;
  uint32_t maxListCount = 4096;
};

/// A decoding failure: the code to send back and a message naming the problem.
class ProtocolError : public std::runtime_error {
 public:
  ProtocolError(ErrorCode code, const std::string& message) : std::runtime_error(message), mCode(code) {}
  ErrorCode code() const { return mCode; }

 private:
  ErrorCode mCode;
};

/// The whole message (header and body) as bytes, in `version` (kMinVersion..kMaxVersion). Strings are expected to be
/// UTF-8 and are not checked here (the peer's decoder rejects them otherwise). Throws std::length_error for a body
/// above 4 GiB - 1, std::invalid_argument for a version not spoken or a value or message the version lacks (jpeg in
/// version 1, FrameReceived before version 4).
std::vector<uint8_t> encode(const Message& message, uint32_t requestId, uint16_t version = kVersion);
/// The 16 header bytes: kMagic followed by the fields of `header`.
std::array<uint8_t, kHeaderBytes> encodeHeader(const Header& header);
/// Parses the fixed header. Throws ProtocolError: BadMagic, UnsupportedVersion (a version outside
/// kMinVersion..kMaxVersion), TooLarge (bodyBytes above limits.maxBodyBytes). An unknown type is not an error here
/// (decodeBody reports it), so the body can be skipped.
Header decodeHeader(std::span<const uint8_t, kHeaderBytes> bytes, const Limits& limits);
/// Parses a body of `header.type` in `header.version`. Throws ProtocolError: UnknownType, Malformed (naming the
/// field; an encoding the version lacks is an unknown value). `body` must be
/// exactly header.bodyBytes long (std::invalid_argument otherwise: a caller's mistake, not the peer's).
Message decodeBody(const Header& header, std::span<const uint8_t> body, const Limits& limits);

}  // namespace voxbrick::proto
