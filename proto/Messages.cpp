// Encoding and decoding of protocol messages. One field list per message (fields() below) drives both directions,
// so the encoder and the decoder cannot disagree on the order or the width of a field.
#include "proto/Messages.h"

#include <algorithm>
#include <concepts>
#include <cstdio>
#include <limits>
#include <type_traits>
#include <utility>

namespace voxbrick::proto {
namespace {

// messageType() and decodeBody() rely on the variant listing its alternatives in MessageType order (index + 1).
template <MessageType type, class T>
constexpr bool kAt = std::is_same_v<std::variant_alternative_t<size_t(type) - 1, Message>, T>;
static_assert(kAt<MessageType::Hello, Hello> && kAt<MessageType::Capabilities, Capabilities> &&
              kAt<MessageType::ListDatasets, ListDatasets> && kAt<MessageType::DatasetList, DatasetList> &&
              kAt<MessageType::OpenDataset, OpenDataset> && kAt<MessageType::DatasetInfo, DatasetInfo> &&
              kAt<MessageType::Render, RenderRequest> && kAt<MessageType::Frame, Frame> &&
              kAt<MessageType::Error, Error> && kAt<MessageType::GetStats, GetStats> &&
              kAt<MessageType::Stats, Stats> && kAt<MessageType::Goodbye, Goodbye> &&
              kAt<MessageType::FrameReceived, FrameReceived> && kAt<MessageType::Authenticate, Authenticate> &&
              kAt<MessageType::Authenticated, Authenticated> && kAt<MessageType::Upload, Upload> &&
              kAt<MessageType::UploadReady, UploadReady> && kAt<MessageType::UploadChunk, UploadChunk> &&
              std::variant_size_v<Message> == size_t(MessageType::UploadChunk));

bool known(Encoding e, uint16_t version) { return encodingInVersion(e, version); }
bool known(ErrorCode e, uint16_t version) { return errorCodeInVersion(e, version); }

/// Where a field is, for error messages: "names", or "names[3]" for a list item.
struct Field {
  static constexpr size_t kNone = std::numeric_limits<size_t>::max();
  const char* name;
  size_t index = kNone;
};

template <std::unsigned_integral T>
void putLittleEndian(uint8_t* out, T value) {
  for (size_t i = 0; i < sizeof(T); ++i) out[i] = static_cast<uint8_t>(value >> (8 * i));
}

template <std::unsigned_integral T>
T getLittleEndian(const uint8_t* in) {
  uint64_t value = 0;
  for (size_t i = 0; i < sizeof(T); ++i) value |= uint64_t(in[i]) << (8 * i);
  return static_cast<T>(value);
}

/// Counts the bytes a body will take, so that encode() can refuse an oversized body and allocate once.
class Sizer {
 public:
  explicit Sizer(MessageType type, uint16_t version) : mType(type), mVersion(version) {}
  size_t total() const { return mTotal; }

  template <class T>
  void number([[maybe_unused]] Field field, T value) {
    // The one pass before anything is written: a value the version lacks is the caller's mistake.
    if constexpr (std::is_enum_v<T>)
      if (!known(value, mVersion))
        throw std::invalid_argument(std::string("proto::encode: ") + messageTypeName(mType) + "." + field.name +
                                    ": value " + std::to_string(int(value)) + " does not exist in version " +
                                    std::to_string(mVersion));
    mTotal += sizeof(T);
  }
  void string(Field, const std::string& text) { mTotal += sizeof(uint32_t) + text.size(); }
  void bytes(Field, const std::vector<uint8_t>& data) { mTotal += sizeof(uint32_t) + data.size(); }
  template <class T>
  void list(Field field, const std::vector<T>& items) {
    mTotal += sizeof(uint32_t);
    for (const T& item : items) {
      if constexpr (std::is_enum_v<T>)
        number(field, item);
      else
        string(field, item);
    }
  }

 private:
  MessageType mType;
  uint16_t mVersion;
  size_t mTotal = 0;
};

class Writer {
 public:
  explicit Writer(std::vector<uint8_t>& out) : mOut(out) {}

  template <std::unsigned_integral T>
  void number(Field, T value) {
    mOut.resize(mOut.size() + sizeof(T));
    putLittleEndian(mOut.data() + mOut.size() - sizeof(T), value);
  }
  template <class E>
  requires std::is_enum_v<E>
  void number(Field field, E value) { number(field, static_cast<std::underlying_type_t<E>>(value)); }
  // Every length and count fits its u32: each is at most the body size, which encode() has checked.
  void string(Field field, const std::string& text) {
    number(field, static_cast<uint32_t>(text.size()));
    mOut.insert(mOut.end(), text.begin(), text.end());
  }
  void bytes(Field field, const std::vector<uint8_t>& data) {
    number(field, static_cast<uint32_t>(data.size()));
    mOut.insert(mOut.end(), data.begin(), data.end());
  }
  template <class T>
  void list(Field field, const std::vector<T>& items) {
    number(field, static_cast<uint32_t>(items.size()));
    for (size_t i = 0; i < items.size(); ++i) {
      if constexpr (std::is_enum_v<T>)
        number(Field{field.name, i}, items[i]);
      else
        string(Field{field.name, i}, items[i]);
    }
  }

 private:
  std::vector<uint8_t>& mOut;
};

class Reader {
 public:
  Reader(const Header& header, std::span<const uint8_t> body, const Limits& limits)
      : mType(header.type), mVersion(header.version), mBody(body), mLimits(limits) {}

  template <std::unsigned_integral T>
  void number(Field field, T& value) {
    value = getLittleEndian<T>(take(field, sizeof(T)));
  }
  template <class E>
  requires std::is_enum_v<E>
  void number(Field field, E& value) {
    std::underlying_type_t<E> raw;
    number(field, raw);
    if (!known(E(raw), mVersion))
      fail(field, "unknown value " + std::to_string(raw) + " in protocol version " + std::to_string(mVersion));
    value = E(raw);
  }
  void string(Field field, std::string& text) {
    const uint32_t size = length(field, mLimits.maxStringBytes);
    const uint8_t* p = take(field, size);
    if (size_t bad = invalidUtf8At(p, size); bad != size) fail(field, "not valid UTF-8 at byte " + std::to_string(bad));
    text.assign(reinterpret_cast<const char*>(p), size);
  }
  void bytes(Field field, std::vector<uint8_t>& data) {
    const uint32_t size = length(field, std::numeric_limits<uint32_t>::max());
    const uint8_t* p = take(field, size);
    data.assign(p, p + size);
  }
  template <class T>
  void list(Field field, std::vector<T>& items) {
    uint32_t count;
    number(field, count);
    if (count > mLimits.maxListCount)
      fail(field, "count " + std::to_string(count) + " exceeds limit " + std::to_string(mLimits.maxListCount));
    // Each item takes at least this much, so a count the body cannot hold is refused before the resize.
    constexpr size_t kMinItemBytes = std::is_enum_v<T> ? sizeof(T) : sizeof(uint32_t);
    if (uint64_t(count) * kMinItemBytes > left())
      fail(field, "count " + std::to_string(count) + " needs at least " + std::to_string(count * kMinItemBytes) +
                      " bytes, " + std::to_string(left()) + " left in the body");
    items.resize(count);
    for (size_t i = 0; i < count; ++i) {
      if constexpr (std::is_enum_v<T>)
        number(Field{field.name, i}, items[i]);
      else
        string(Field{field.name, i}, items[i]);
    }
  }

  /// Throws Malformed if bytes follow the last field.
  void finish() const {
    if (left() > 0)
      throw ProtocolError(ErrorCode::Malformed, std::string(messageTypeName(mType)) + ": " + std::to_string(left()) +
                                                    " trailing byte(s) after the last field");
  }

 private:
  size_t left() const { return mBody.size() - mOffset; }

  uint32_t length(Field field, uint32_t limit) {
    uint32_t size;
    number(field, size);
    if (size > limit) fail(field, "length " + std::to_string(size) + " exceeds limit " + std::to_string(limit));
    if (size > left())
      fail(field,
           "length " + std::to_string(size) + " exceeds the " + std::to_string(left()) + " bytes left in the body");
    return size;
  }

  const uint8_t* take(Field field, size_t size) {
    if (size > left())
      fail(field,
           "truncated: needs " + std::to_string(size) + " bytes, " + std::to_string(left()) + " left in the body");
    const uint8_t* p = mBody.data() + mOffset;
    mOffset += size;
    return p;
  }

  [[noreturn]] void fail(Field field, const std::string& problem) const {
    std::string where = std::string(messageTypeName(mType)) + "." + field.name;
    if (field.index != Field::kNone) where += "[" + std::to_string(field.index) + "]";
    throw ProtocolError(ErrorCode::Malformed, where + ": " + problem);
  }

  MessageType mType;
  uint16_t mVersion;
  std::span<const uint8_t> mBody;
  const Limits& mLimits;
  size_t mOffset = 0;
};

// The field lists, in wire order, with the names PROTOCOL.md uses. M is the message, const when encoding.
template <class M, class T>
concept Is = std::same_as<std::remove_const_t<M>, T>;

template <class Io, class M>
requires Is<M, ListDatasets> || Is<M, GetStats> || Is<M, Goodbye>
void fields(Io&, M&) {}

template <class Io, Is<Hello> M>
void fields(Io& io, M& m) {
  io.number({"min_version"}, m.minVersion);
  io.number({"max_version"}, m.maxVersion);
  io.string({"client"}, m.client);
}

template <class Io, Is<Capabilities> M>
void fields(Io& io, M& m) {
  io.number({"version"}, m.version);
  io.string({"server"}, m.server);
  io.number({"max_message_bytes"}, m.maxMessageBytes);
  io.number({"max_image_side"}, m.maxImageSide);
  io.number({"max_queued_per_session"}, m.maxQueuedPerSession);
  io.list({"encodings"}, m.encodings);
}

template <class Io, Is<DatasetList> M>
void fields(Io& io, M& m) {
  io.list({"names"}, m.names);
}

template <class Io, Is<OpenDataset> M>
void fields(Io& io, M& m) {
  io.string({"name"}, m.name);
}

template <class Io, Is<DatasetInfo> M>
void fields(Io& io, M& m) {
  io.string({"name"}, m.name);
  io.string({"meta_json"}, m.metaJson);
}

template <class Io, Is<RenderRequest> M>
void fields(Io& io, M& m) {
  io.number({"encoding"}, m.encoding);
  io.string({"scene_json"}, m.sceneJson);
}

template <class Io, Is<Frame> M>
void fields(Io& io, M& m) {
  io.number({"width"}, m.width);
  io.number({"height"}, m.height);
  io.number({"encoding"}, m.encoding);
  io.string({"stats_json"}, m.statsJson);
  io.bytes({"payload"}, m.payload);
}

template <class Io, Is<Error> M>
void fields(Io& io, M& m) {
  io.number({"code"}, m.code);
  io.string({"message"}, m.message);
}

template <class Io, Is<Stats> M>
void fields(Io& io, M& m) {
  io.string({"json"}, m.json);
}

template <class Io, Is<FrameReceived> M>
void fields(Io& io, M& m) {
  io.number({"frame_bytes"}, m.frameBytes);
}

template <class Io, Is<Authenticate> M>
void fields(Io& io, M& m) {
  io.string({"token"}, m.token);
}

template <class Io, Is<Authenticated> M>
void fields(Io& io, M& m) {
  io.string({"token_id"}, m.tokenId);
}

template <class Io, Is<Upload> M>
void fields(Io& io, M& m) {
  io.string({"name"}, m.name);
  io.string({"meta_json"}, m.metaJson);
  io.number({"bytes"}, m.bytes);
}

template <class Io, Is<UploadReady> M>
void fields(Io& io, M& m) {
  io.number({"chunk_bytes"}, m.chunkBytes);
}

template <class Io, Is<UploadChunk> M>
void fields(Io& io, M& m) {
  io.bytes({"data"}, m.data);
}

template <size_t I = 0>
Message decodeAs(const Header& header, std::span<const uint8_t> body, const Limits& limits) {
  if constexpr (I == std::variant_size_v<Message>) {
    throw ProtocolError(ErrorCode::UnknownType, "message type " + std::to_string(uint16_t(header.type)) +
                                                    " is not known in protocol version " +
                                                    std::to_string(header.version));
  } else if (size_t(header.type) != I + 1) {
    return decodeAs<I + 1>(header, body, limits);
  } else {
    std::variant_alternative_t<I, Message> message;
    Reader reader(header, body, limits);
    fields(reader, message);
    reader.finish();
    return message;
  }
}

}  // namespace

size_t invalidUtf8At(const uint8_t* p, size_t size) {
  size_t i = 0;
  while (i < size) {
    const uint8_t c = p[i];
    if (c < 0x80) {
      ++i;
      continue;
    }
    size_t length;
    uint8_t lo = 0x80, hi = 0xBF;  // the range of the second byte; later ones are always 80..BF
    if (c >= 0xC2 && c <= 0xDF) {
      length = 2;
    } else if (c >= 0xE0 && c <= 0xEF) {
      length = 3;
      if (c == 0xE0) lo = 0xA0;
      if (c == 0xED) hi = 0x9F;
    } else if (c >= 0xF0 && c <= 0xF4) {
      length = 4;
      if (c == 0xF0) lo = 0x90;
      if (c == 0xF4) hi = 0x8F;
    } else {
      return i;
    }
    if (size - i < length || p[i + 1] < lo || p[i + 1] > hi) return i;
    for (size_t k = 2; k < length; ++k)
      if (p[i + k] < 0x80 || p[i + k] > 0xBF) return i;
    i += length;
  }
  return size;
}

bool messageTypeInVersion(MessageType type, uint16_t version) {
  if (type == MessageType::FrameReceived) return version >= 4;
  if (type == MessageType::Authenticate || type == MessageType::Authenticated) return version >= 5;
  if (type == MessageType::Upload || type == MessageType::UploadReady || type == MessageType::UploadChunk)
    return version >= 6;
  return type >= MessageType::Hello && type <= MessageType::Goodbye;
}

bool errorCodeInVersion(ErrorCode code, uint16_t version) {
  if (code == ErrorCode::Busy) return version >= 3;
  if (code == ErrorCode::Forbidden) return version >= 5;
  if (code == ErrorCode::AlreadyExists) return version >= 6;
  return code >= ErrorCode::BadMagic && code <= ErrorCode::Timeout;
}

namespace {
constexpr std::string_view kRetryPrefix = "; retry after ", kRetrySuffix = " ms";
}  // namespace

std::string busyMessage(std::string_view what, uint32_t retryAfterMs) {
  return std::string(what) + std::string(kRetryPrefix) + std::to_string(std::max<uint32_t>(retryAfterMs, 1)) +
         std::string(kRetrySuffix);
}

std::optional<uint32_t> retryAfterMs(std::string_view message) {
  if (!message.ends_with(kRetrySuffix)) return std::nullopt;
  message.remove_suffix(kRetrySuffix.size());
  const size_t at = message.rfind(kRetryPrefix);
  if (at == std::string_view::npos) return std::nullopt;
  const std::string_view digits = message.substr(at + kRetryPrefix.size());
  if (digits.empty() || digits.size() > 9) return std::nullopt;
  uint32_t value = 0;
  for (char c : digits) {
    if (c < '0' || c > '9') return std::nullopt;
    value = value * 10 + uint32_t(c - '0');
  }
  return value;
}

const char* errorCodeName(ErrorCode code) {
  switch (code) {
    case ErrorCode::BadMagic: return "BadMagic";
    case ErrorCode::UnsupportedVersion: return "UnsupportedVersion";
    case ErrorCode::UnknownType: return "UnknownType";
    case ErrorCode::TooLarge: return "TooLarge";
    case ErrorCode::Malformed: return "Malformed";
    case ErrorCode::UnexpectedMessage: return "UnexpectedMessage";
    case ErrorCode::UnknownDataset: return "UnknownDataset";
    case ErrorCode::InvalidScene: return "InvalidScene";
    case ErrorCode::LimitExceeded: return "LimitExceeded";
    case ErrorCode::Superseded: return "Superseded";
    case ErrorCode::Internal: return "Internal";
    case ErrorCode::ShuttingDown: return "ShuttingDown";
    case ErrorCode::Timeout: return "Timeout";
    case ErrorCode::Busy: return "Busy";
    case ErrorCode::Forbidden: return "Forbidden";
    case ErrorCode::AlreadyExists: return "AlreadyExists";
  }
  return "unknown";
}

const char* messageTypeName(MessageType type) {
  switch (type) {
    case MessageType::Hello: return "Hello";
    case MessageType::Capabilities: return "Capabilities";
    case MessageType::ListDatasets: return "ListDatasets";
    case MessageType::DatasetList: return "DatasetList";
    case MessageType::OpenDataset: return "OpenDataset";
    case MessageType::DatasetInfo: return "DatasetInfo";
    case MessageType::Render: return "Render";
    case MessageType::Frame: return "Frame";
    case MessageType::Error: return "Error";
    case MessageType::GetStats: return "GetStats";
    case MessageType::Stats: return "Stats";
    case MessageType::Goodbye: return "Goodbye";
    case MessageType::FrameReceived: return "FrameReceived";
    case MessageType::Authenticate: return "Authenticate";
    case MessageType::Authenticated: return "Authenticated";
    case MessageType::Upload: return "Upload";
    case MessageType::UploadReady: return "UploadReady";
    case MessageType::UploadChunk: return "UploadChunk";
  }
  return "unknown";
}

MessageType messageType(const Message& message) { return MessageType(message.index() + 1); }

bool encodingInVersion(Encoding encoding, uint16_t version) {
  switch (encoding) {
    case Encoding::RawRgba8:
    case Encoding::Png:
    case Encoding::ZstdRgba8: return version >= 1;
    case Encoding::Jpeg: return version >= 2;
    case Encoding::Vp8:
    case Encoding::Vp9: return version >= 4;
    case Encoding::Webp: return version >= 7;
  }
  return false;
}

uint16_t firstVersionOf(Encoding encoding) {
  uint16_t version = kMinVersion;
  while (version <= kMaxVersion && !encodingInVersion(encoding, version)) ++version;
  return version;
}

namespace {

/// Every encoding by its short name, in the order of their values.
constexpr std::pair<std::string_view, Encoding> kShortNames[] = {
    {"raw", Encoding::RawRgba8}, {"png", Encoding::Png}, {"zstd", Encoding::ZstdRgba8}, {"jpeg", Encoding::Jpeg},
    {"vp8", Encoding::Vp8},      {"vp9", Encoding::Vp9}, {"webp", Encoding::Webp}};

}  // namespace

std::optional<Encoding> encodingFromShortName(std::string_view name) {
  for (const auto& [shortName, encoding] : kShortNames)
    if (name == shortName) return encoding;
  return std::nullopt;
}

std::vector<std::string> encodingShortNames() {
  std::vector<std::string> names;
  for (const auto& entry : kShortNames) names.emplace_back(entry.first);
  return names;
}

std::vector<Encoding> encodingsOf(uint16_t version) {
  std::vector<Encoding> encodings;
  for (const Encoding e :
       {Encoding::RawRgba8, Encoding::Png, Encoding::ZstdRgba8, Encoding::Jpeg, Encoding::Vp8, Encoding::Vp9,
        Encoding::Webp})
    if (encodingInVersion(e, version)) encodings.push_back(e);
  return encodings;
}

const char* encodingName(Encoding encoding) {
  switch (encoding) {
    case Encoding::RawRgba8: return "raw_rgba8";
    case Encoding::Png: return "png";
    case Encoding::ZstdRgba8: return "zstd_rgba8";
    case Encoding::Jpeg: return "jpeg";
    case Encoding::Vp8: return "vp8";
    case Encoding::Vp9: return "vp9";
    case Encoding::Webp: return "webp";
  }
  return "unknown";
}

std::array<uint8_t, kHeaderBytes> encodeHeader(const Header& header) {
  std::array<uint8_t, kHeaderBytes> bytes;
  putLittleEndian(bytes.data() + 0, kMagic);
  putLittleEndian(bytes.data() + 4, header.version);
  putLittleEndian(bytes.data() + 6, uint16_t(header.type));
  putLittleEndian(bytes.data() + 8, header.requestId);
  putLittleEndian(bytes.data() + 12, header.bodyBytes);
  return bytes;
}

std::vector<uint8_t> encode(const Message& message, uint32_t requestId, uint16_t version) {
  if (version < kMinVersion || version > kMaxVersion)
    throw std::invalid_argument("proto::encode: version " + std::to_string(version) + " is not spoken (" +
                                std::to_string(kMinVersion) + ".." + std::to_string(kMaxVersion) + ")");
  if (!messageTypeInVersion(messageType(message), version))
    throw std::invalid_argument(std::string("proto::encode: ") + messageTypeName(messageType(message)) +
                                " does not exist in version " + std::to_string(version));
  Sizer sizer(messageType(message), version);
  std::visit([&](const auto& m) { fields(sizer, m); }, message);
  if (sizer.total() > std::numeric_limits<uint32_t>::max())
    throw std::length_error(std::string("proto::encode: ") + messageTypeName(messageType(message)) + " body of " +
                            std::to_string(sizer.total()) + " bytes does not fit the u32 body length");
  const auto header = encodeHeader({version, messageType(message), requestId, uint32_t(sizer.total())});
  std::vector<uint8_t> out(header.begin(), header.end());
  out.reserve(kHeaderBytes + sizer.total());
  Writer writer(out);
  std::visit([&](const auto& m) { fields(writer, m); }, message);
  return out;
}

Header decodeHeader(std::span<const uint8_t, kHeaderBytes> bytes, const Limits& limits) {
  const uint32_t magic = getLittleEndian<uint32_t>(bytes.data());
  if (magic != kMagic) {
    char text[64];
    std::snprintf(text, sizeof text, "header: magic 0x%08X is not 0x%08X (\"VXBK\")", unsigned(magic),
                  unsigned(kMagic));
    throw ProtocolError(ErrorCode::BadMagic, text);
  }
  Header header;
  header.version = getLittleEndian<uint16_t>(bytes.data() + 4);
  header.type = MessageType(getLittleEndian<uint16_t>(bytes.data() + 6));
  header.requestId = getLittleEndian<uint32_t>(bytes.data() + 8);
  header.bodyBytes = getLittleEndian<uint32_t>(bytes.data() + 12);
  if (header.version < kMinVersion || header.version > kMaxVersion)
    throw ProtocolError(ErrorCode::UnsupportedVersion, "header: version " + std::to_string(header.version) +
                                                           " is not supported (this side speaks versions " +
                                                           std::to_string(kMinVersion) + ".." +
                                                           std::to_string(kMaxVersion) + ")");
  if (header.bodyBytes > limits.maxBodyBytes)
    throw ProtocolError(ErrorCode::TooLarge, "header: body of " + std::to_string(header.bodyBytes) +
                                                 " bytes exceeds limit " + std::to_string(limits.maxBodyBytes));
  return header;
}

Message decodeBody(const Header& header, std::span<const uint8_t> body, const Limits& limits) {
  if (body.size() != header.bodyBytes)
    throw std::invalid_argument("proto::decodeBody: body of " + std::to_string(body.size()) +
                                " bytes, the header says " + std::to_string(header.bodyBytes));
  if (!messageTypeInVersion(header.type, header.version))
    throw ProtocolError(ErrorCode::UnknownType, "message type " + std::to_string(uint16_t(header.type)) +
                                                    " is not known in protocol version " +
                                                    std::to_string(header.version));
  return decodeAs(header, body, limits);
}

}  // namespace voxbrick::proto
