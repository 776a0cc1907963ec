// The wire codec: header layout, round trips of every message, every way a message can be malformed, the seed
// corpus of the fuzzer.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "proto/Messages.h"
#include "proto/fuzz/FuzzCheck.h"
#include "proto/fuzz/WireBytes.h"
#include "support/TestSupport.h"

namespace {

using namespace voxbrick::proto;
using namespace voxbrick::proto::wire;

Bytes headerBytes(MessageType type, uint32_t requestId, size_t bodyBytes, uint16_t version = kVersion) {
  const auto bytes = encodeHeader({version, type, requestId, uint32_t(bodyBytes)});
  return Bytes(bytes.begin(), bytes.end());
}

std::string hex(const Bytes& bytes) {
  std::string text;
  for (uint8_t b : bytes) {
    char two[4];
    std::snprintf(two, sizeof two, "%02X ", b);
    text += two;
  }
  if (!text.empty()) text.pop_back();
  return text;
}

Header decodeHeaderOf(const Bytes& wire, const Limits& limits = {}) {
  return decodeHeader(std::span<const uint8_t, kHeaderBytes>(wire.data(), kHeaderBytes), limits);
}

/// Decodes a whole message (header and body).
Message decodeWhole(const Bytes& wire, const Limits& limits = {}) {
  const Header header = decodeHeaderOf(wire, limits);
  return decodeBody(header, std::span(wire).subspan(kHeaderBytes), limits);
}

/// Decodes `body` as a message of `type`, with a header that matches it.
Message decodeRaw(MessageType type, const Bytes& body, const Limits& limits = {}) {
  return decodeBody({kVersion, type, 1, uint32_t(body.size())}, body, limits);
}

/// The ProtocolError that `f` throws (fails the test if it throws nothing or something else).
template <class F>
ProtocolError thrown(F&& f) {
  try {
    f();
  } catch (const ProtocolError& e) {
    return e;
  }
  ADD_FAILURE() << "no ProtocolError thrown";
  return ProtocolError(ErrorCode::Internal, "nothing thrown");
}

ProtocolError malformed(MessageType type, const Bytes& body, const Limits& limits = {}) {
  ProtocolError e = thrown([&] { decodeRaw(type, body, limits); });
  EXPECT_EQ(e.code(), ErrorCode::Malformed) << e.what();
  return e;
}

Bytes pattern(size_t n) {
  Bytes b(n);
  for (size_t i = 0; i < n; ++i) b[i] = uint8_t(i * 31 + (i >> 8));
  return b;
}

/// One message of every type with contents that exercise its fields, including empty strings and lists and a large
/// payload.
std::vector<Message> sampleMessages() {
  return {
      Hello{1, 3, "voxbrick-request 0.1"},
      Hello{0, 65535, ""},
      Capabilities{1, "voxbrick 0.1", 64u << 20, 8192, 4, {Encoding::RawRgba8, Encoding::Png, Encoding::ZstdRgba8}},
      Capabilities{1, "", 0, 0, 0, {}},
      ListDatasets{},
      DatasetList{{"mri", "", "sparse field", "ünïcødé 体积 🧠"}},
      DatasetList{{}},
      OpenDataset{"mri"},
      OpenDataset{""},
      DatasetInfo{"mri", R"({"dims": [256, 256, 128], "type": "u16"})"},
      RenderRequest{Encoding::ZstdRgba8, R"({"camera": {"orbit": [30, 20, 2.5]}, "size": [640, 480]})"},
      RenderRequest{Encoding::RawRgba8, ""},
      Frame{640, 480, Encoding::RawRgba8, R"({"bricks_drawn": 12, "queue_ms": 0.25})", pattern((3u << 20) + 7)},
      Frame{1, 1, Encoding::Png, "", {}},
      Error{ErrorCode::Superseded, "replaced by request 9"},
      Error{ErrorCode::Timeout, ""},
      GetStats{},
      Stats{R"({"sessions": 3})"},
      Goodbye{},
      Frame{320, 200, Encoding::Vp8, R"({"video": {"key": true}})", pattern(999)},
      FrameReceived{123456},
      FrameReceived{0},
      Authenticate{"5f1c0ad2e9b34c7a8d6e0f1a2b3c4d5e"},
      Authenticate{""},
      Authenticated{"radiology"},
      Upload{"scan-7", R"({"dims": [256, 256, 128], "type": "uint16"})", 256ull * 256 * 128 * 2},
      Upload{"", "", 0},
      Upload{"big", "{}", 0xFFFFFFFFFFFFFFFFull},
      UploadReady{1u << 20},
      UploadChunk{pattern(4099)},
      UploadChunk{{}},
  };
}

TEST(Header, LayoutIsPinned) {
  EXPECT_EQ(kHeaderBytes, 16u);
  EXPECT_EQ(kVersion, 1u);
  const auto bytes = encodeHeader({kVersion, MessageType::Render, 0x04030201u, 0x0D0C0B0Au});
  // offset 0 magic "VXBK", 4 version, 6 type, 8 request id, 12 body length; all little-endian
  EXPECT_EQ(hex(Bytes(bytes.begin(), bytes.end())), "56 58 42 4B 01 00 07 00 01 02 03 04 0A 0B 0C 0D");
}

TEST(Versions, JpegExistsFromVersionTwoOn) {
  EXPECT_EQ(kMinVersion, 1u);
  EXPECT_EQ(kMaxVersion, 9u);
  EXPECT_EQ(encodingsOf(8), encodingsOf(7)) << "version 8 adds no encoding";
  EXPECT_EQ(encodingsOf(9), encodingsOf(8)) << "version 9 adds a scene key, no encoding";
  EXPECT_EQ(uint8_t(Encoding::Jpeg), 3u);
  EXPECT_EQ(encodingsOf(1), (std::vector<Encoding>{Encoding::RawRgba8, Encoding::Png, Encoding::ZstdRgba8}));
  EXPECT_EQ(encodingsOf(2),
            (std::vector<Encoding>{Encoding::RawRgba8, Encoding::Png, Encoding::ZstdRgba8, Encoding::Jpeg}));
  EXPECT_FALSE(encodingInVersion(Encoding::Jpeg, 1));
  EXPECT_TRUE(encodingInVersion(Encoding::Jpeg, 2));
  EXPECT_FALSE(encodingInVersion(Encoding(4), 2));
  EXPECT_EQ(encodingsOf(3), encodingsOf(2));
  EXPECT_STREQ(encodingName(Encoding::Jpeg), "jpeg");
  EXPECT_EQ(encodingFromShortName("jpeg"), Encoding::Jpeg);
  EXPECT_EQ(encodingFromShortName("zstd"), Encoding::ZstdRgba8);
  EXPECT_EQ(encodingFromShortName("jpg"), std::nullopt);
}

// Version 7 adds lossless WebP (6); a Frame of version 6 or older carrying it is refused as an unknown encoding.
TEST(Versions, WebpExistsFromVersionSevenOn) {
  EXPECT_EQ(uint8_t(Encoding::Webp), 6u);
  for (uint16_t version = 1; version <= 6; ++version) EXPECT_FALSE(encodingInVersion(Encoding::Webp, version));
  EXPECT_TRUE(encodingInVersion(Encoding::Webp, 7));
  EXPECT_EQ(encodingsOf(6), encodingsOf(4));
  EXPECT_EQ(encodingsOf(7), (std::vector<Encoding>{Encoding::RawRgba8, Encoding::Png, Encoding::ZstdRgba8,
                                                   Encoding::Jpeg, Encoding::Vp8, Encoding::Vp9, Encoding::Webp}));
  EXPECT_EQ(encodingFromShortName("webp"), Encoding::Webp);
  EXPECT_STREQ(encodingName(Encoding::Webp), "webp");
  EXPECT_EQ(firstVersionOf(Encoding::Webp), 7);
  EXPECT_EQ(firstVersionOf(Encoding::Jpeg), 2);
  EXPECT_EQ(firstVersionOf(Encoding::Png), 1);
  const Frame frame{2, 2, Encoding::Webp, "{}", {1, 2, 3}};
  const Bytes wire = encode(frame, 5, 7);
  EXPECT_TRUE(decodeWhole(wire) == Message(frame));
  EXPECT_THROW(encode(frame, 5, 6), std::invalid_argument);
  Bytes older = wire;
  older[4] = 6;  // the same bytes in a version-6 header
  EXPECT_THROW(decodeWhole(older), ProtocolError);
}

TEST(Versions, VideoAndFrameReceivedExistFromVersionFourOn) {
  EXPECT_EQ(uint8_t(Encoding::Vp8), 4u);
  EXPECT_EQ(uint8_t(Encoding::Vp9), 5u);
  for (uint16_t version = 1; version <= 3; ++version) {
    EXPECT_FALSE(encodingInVersion(Encoding::Vp8, version));
    EXPECT_FALSE(messageTypeInVersion(MessageType::FrameReceived, version));
  }
  EXPECT_TRUE(encodingInVersion(Encoding::Vp9, 4));
  EXPECT_TRUE(messageTypeInVersion(MessageType::FrameReceived, 4));
  EXPECT_EQ(encodingsOf(4), (std::vector<Encoding>{Encoding::RawRgba8, Encoding::Png, Encoding::ZstdRgba8,
                                                   Encoding::Jpeg, Encoding::Vp8, Encoding::Vp9}));
  EXPECT_EQ(encodingFromShortName("vp8"), Encoding::Vp8);
  EXPECT_STREQ(encodingName(Encoding::Vp9), "vp9");
  // FrameReceived: one u32, frame_bytes; refused by the encoder and the decoder before version 4.
  EXPECT_EQ(hex(encode(FrameReceived{0x01020304}, 9, 4)), hex(concat({[] {
                                                              const auto h = encodeHeader(
                                                                  {4, MessageType::FrameReceived, 9, 4});
                                                              return Bytes(h.begin(), h.end());
                                                            }(),
                                                            u32(0x01020304)})));
  EXPECT_THROW(encode(FrameReceived{1}, 9, 3), std::invalid_argument);
  const Bytes body = u32(7);
  ProtocolError e = thrown([&] { decodeBody({3, MessageType::FrameReceived, 1, 4}, body, Limits{}); });
  EXPECT_EQ(e.code(), ErrorCode::UnknownType) << e.what();
  EXPECT_TRUE(decodeBody({4, MessageType::FrameReceived, 1, 4}, body, Limits{}) == Message(FrameReceived{7}));
  // A video Frame in version 3 is an unknown encoding, as jpeg is in version 1.
  const Bytes frame = concat({u32(1), u32(1), {4}, str(""), u32(0)});
  e = thrown([&] { decodeBody({3, MessageType::Frame, 1, uint32_t(frame.size())}, frame, Limits{}); });
  EXPECT_EQ(e.code(), ErrorCode::Malformed);
  EXPECT_STREQ(e.what(), "Frame.encoding: unknown value 4 in protocol version 3");
}

TEST(Versions, AuthenticateAndForbiddenExistFromVersionFiveOn) {
  EXPECT_EQ(uint16_t(MessageType::Authenticate), 14u);
  EXPECT_EQ(uint16_t(MessageType::Authenticated), 15u);
  EXPECT_EQ(uint16_t(ErrorCode::Forbidden), 15u);
  for (uint16_t version = 1; version <= 4; ++version) {
    EXPECT_FALSE(messageTypeInVersion(MessageType::Authenticate, version));
    EXPECT_FALSE(messageTypeInVersion(MessageType::Authenticated, version));
    EXPECT_FALSE(errorCodeInVersion(ErrorCode::Forbidden, version));
  }
  EXPECT_TRUE(messageTypeInVersion(MessageType::Authenticate, 5));
  EXPECT_TRUE(messageTypeInVersion(MessageType::Authenticated, 5));
  EXPECT_TRUE(errorCodeInVersion(ErrorCode::Forbidden, 5));
  EXPECT_EQ(encodingsOf(5), encodingsOf(4));
  // Authenticate: one string, token; Authenticated: one string, token_id. Neither exists before version 5.
  EXPECT_EQ(hex(encode(Authenticate{"s3"}, 2, 5)),
            hex(concat({headerBytes(MessageType::Authenticate, 2, 6, 5), str("s3")})));
  EXPECT_EQ(hex(encode(Authenticated{"id"}, 2, 5)),
            hex(concat({headerBytes(MessageType::Authenticated, 2, 6, 5), str("id")})));
  EXPECT_THROW(encode(Authenticate{"s3"}, 2, 4), std::invalid_argument);
  EXPECT_THROW(encode(Error{ErrorCode::Forbidden, "x"}, 1, 4), std::invalid_argument);
  const Bytes body = str("s3");
  ProtocolError e = thrown([&] {
    decodeBody({4, MessageType::Authenticate, 1, uint32_t(body.size())}, body, Limits{});
  });
  EXPECT_EQ(e.code(), ErrorCode::UnknownType) << e.what();
  EXPECT_TRUE(decodeBody({5, MessageType::Authenticate, 1, uint32_t(body.size())}, body, Limits{}) ==
              Message(Authenticate{"s3"}));
  // Forbidden in a version-4 Error is an unknown value, as Busy is in version 2.
  const Bytes error = concat({u16(15), str("x")});
  e = thrown([&] { decodeBody({4, MessageType::Error, 1, uint32_t(error.size())}, error, Limits{}); });
  EXPECT_EQ(e.code(), ErrorCode::Malformed);
  EXPECT_TRUE(decodeBody({5, MessageType::Error, 1, uint32_t(error.size())}, error, Limits{}) ==
              Message(Error{ErrorCode::Forbidden, "x"}));
}

TEST(Versions, UploadsAndAlreadyExistsExistFromVersionSixOn) {
  EXPECT_EQ(uint16_t(MessageType::Upload), 16u);
  EXPECT_EQ(uint16_t(MessageType::UploadReady), 17u);
  EXPECT_EQ(uint16_t(MessageType::UploadChunk), 18u);
  EXPECT_EQ(uint16_t(ErrorCode::AlreadyExists), 16u);
  for (uint16_t version = 1; version <= 5; ++version) {
    for (MessageType type : {MessageType::Upload, MessageType::UploadReady, MessageType::UploadChunk})
      EXPECT_FALSE(messageTypeInVersion(type, version)) << messageTypeName(type) << " " << version;
    EXPECT_FALSE(errorCodeInVersion(ErrorCode::AlreadyExists, version));
  }
  for (MessageType type : {MessageType::Upload, MessageType::UploadReady, MessageType::UploadChunk})
    EXPECT_TRUE(messageTypeInVersion(type, 6));
  EXPECT_TRUE(errorCodeInVersion(ErrorCode::AlreadyExists, 6));
  EXPECT_EQ(encodingsOf(6), encodingsOf(5));
  // Upload: string name, string meta_json, u64 bytes (little-endian); UploadReady: u32; UploadChunk: bytes.
  EXPECT_EQ(hex(encode(Upload{"a", "{}", 0x0102030405060708ull}, 2, 6)),
            hex(concat({headerBytes(MessageType::Upload, 2, 5 + 6 + 8, 6), str("a"), str("{}"),
                        {8, 7, 6, 5, 4, 3, 2, 1}})));
  EXPECT_EQ(hex(encode(UploadReady{65536}, 2, 6)),
            hex(concat({headerBytes(MessageType::UploadReady, 2, 4, 6), u32(65536)})));
  EXPECT_EQ(hex(encode(UploadChunk{{9, 8}}, 3, 6)),
            hex(concat({headerBytes(MessageType::UploadChunk, 3, 6, 6), u32(2), {9, 8}})));
  EXPECT_THROW(encode(Upload{"a", "{}", 0}, 2, 5), std::invalid_argument);
  EXPECT_THROW(encode(Error{ErrorCode::AlreadyExists, "x"}, 1, 5), std::invalid_argument);
  const Bytes body = concat({str("a"), str("{}"), u64(3)});
  ProtocolError e = thrown([&] { decodeBody({5, MessageType::Upload, 1, uint32_t(body.size())}, body, Limits{}); });
  EXPECT_EQ(e.code(), ErrorCode::UnknownType) << e.what();
  EXPECT_TRUE(decodeBody({6, MessageType::Upload, 1, uint32_t(body.size())}, body, Limits{}) ==
              Message(Upload{"a", "{}", 3}));
  // A u64 cut short is named.
  const Bytes cut(body.begin(), body.end() - 3);
  e = thrown([&] { decodeBody({6, MessageType::Upload, 1, uint32_t(cut.size())}, cut, Limits{}); });
  EXPECT_EQ(e.code(), ErrorCode::Malformed);
  EXPECT_NE(std::string(e.what()).find("Upload.bytes"), std::string::npos) << e.what();
  const Bytes error = concat({u16(16), str("x")});
  e = thrown([&] { decodeBody({5, MessageType::Error, 1, uint32_t(error.size())}, error, Limits{}); });
  EXPECT_EQ(e.code(), ErrorCode::Malformed);
  EXPECT_TRUE(decodeBody({6, MessageType::Error, 1, uint32_t(error.size())}, error, Limits{}) ==
              Message(Error{ErrorCode::AlreadyExists, "x"}));
}

TEST(Versions, HeadersOfEveryVersionSpokenDecode) {
  for (uint16_t version = kMinVersion; version <= kMaxVersion; ++version) {
    const Bytes wire = encode(ListDatasets{}, 3, version);
    EXPECT_EQ(decodeHeaderOf(wire).version, version);
  }
  EXPECT_THROW(encode(ListDatasets{}, 3, 0), std::invalid_argument);
  EXPECT_THROW(encode(ListDatasets{}, 3, kMaxVersion + 1), std::invalid_argument);
}

TEST(Versions, JpegRenderIsMalformedInVersionOneAndDecodesInVersionTwo) {
  const Bytes body = concat({{3}, str("{}")});
  // Version 1: refused exactly as any unknown encoding, naming the field.
  ProtocolError e = thrown([&] { decodeBody({1, MessageType::Render, 1, uint32_t(body.size())}, body, Limits{}); });
  EXPECT_EQ(e.code(), ErrorCode::Malformed);
  EXPECT_STREQ(e.what(), "Render.encoding: unknown value 3 in protocol version 1");
  // Version 2: a jpeg Render.
  const Message decoded = decodeBody({2, MessageType::Render, 1, uint32_t(body.size())}, body, Limits{});
  EXPECT_EQ(std::get<RenderRequest>(decoded), (RenderRequest{Encoding::Jpeg, "{}"}));
  // And 4 is unknown in version 2.
  const Bytes four = concat({{4}, str("{}")});
  EXPECT_EQ(thrown([&] {
              decodeBody({2, MessageType::Render, 1, uint32_t(four.size())}, four, Limits{});
            }).code(),
            ErrorCode::Malformed);
}

TEST(Versions, EncoderRefusesJpegInVersionOneAndRoundTripsItInVersionTwo) {
  const Frame frame{4, 2, Encoding::Jpeg, "{}", {0xFF, 0xD8}};
  EXPECT_THROW(encode(frame, 1), std::invalid_argument);
  EXPECT_THROW(encode(RenderRequest{Encoding::Jpeg, "{}"}, 1, 1), std::invalid_argument);
  EXPECT_THROW(encode(Capabilities{1, "s", 1, 1, 1, encodingsOf(2)}, 1, 1), std::invalid_argument);
  const Bytes wire = encode(frame, 9, 2);
  const Header header = decodeHeaderOf(wire);
  EXPECT_EQ(header.version, 2u);
  EXPECT_EQ(std::get<Frame>(decodeBody(header, std::span(wire).subspan(kHeaderBytes), Limits{})), frame);
  // The same Capabilities, with jpeg in its encodings, decodes in a version-2 header only.
  const Capabilities caps{2, "s", 1, 1, 1, encodingsOf(2)};
  const Bytes capsWire = encode(caps, 1, 2);
  Header v1 = decodeHeaderOf(capsWire);
  EXPECT_EQ(std::get<Capabilities>(decodeBody(v1, std::span(capsWire).subspan(kHeaderBytes), Limits{})), caps);
  v1.version = 1;
  EXPECT_STREQ(thrown([&] { decodeBody(v1, std::span(capsWire).subspan(kHeaderBytes), Limits{}); }).what(),
               "Capabilities.encodings[3]: unknown value 3 in protocol version 1");
}

TEST(Header, RoundTripsEveryField) {
  const Header header{kVersion, MessageType(0xBEEF), 0xFFFFFFFFu, 12345};
  const auto bytes = encodeHeader(header);
  EXPECT_EQ(decodeHeader(bytes, Limits{}), header);
}

TEST(Header, HelloMatchesTheWorkedExampleInProtocolMd) {
  const std::string headerHex = "56 58 42 4B 01 00 01 00 01 00 00 00 0F 00 00 00";
  const std::string bodyHex = "01 00 01 00 07 00 00 00 65 78 61 6D 70 6C 65";
  EXPECT_EQ(hex(encode(Hello{1, 1, "example"}, 1)), headerHex + " " + bodyHex);
  std::ifstream in(std::string(VOXBRICK_SOURCE_DIR) + "/proto/PROTOCOL.md");
  ASSERT_TRUE(in) << "cannot read proto/PROTOCOL.md";
  std::stringstream spec;
  spec << in.rdbuf();
  EXPECT_NE(spec.str().find(headerHex), std::string::npos) << "PROTOCOL.md does not show the header bytes";
  EXPECT_NE(spec.str().find(bodyHex), std::string::npos) << "PROTOCOL.md does not show the body bytes";
}

TEST(Header, BadMagicAnyByte) {
  for (size_t i = 0; i < 4; ++i) {
    Bytes wire = encode(Goodbye{}, 1);
    wire[i] ^= 0x20;
    ProtocolError e = thrown([&] { decodeHeaderOf(wire); });
    EXPECT_EQ(e.code(), ErrorCode::BadMagic) << e.what();
    EXPECT_NE(std::string(e.what()).find("magic"), std::string::npos) << e.what();
  }
}

TEST(Header, UnsupportedVersion) {
  for (uint16_t version : {uint16_t(0), uint16_t(kMaxVersion + 1), uint16_t(0xFFFF)}) {
    const auto bytes = encodeHeader({version, MessageType::Hello, 1, 0});
    ProtocolError e = thrown([&] { decodeHeader(bytes, Limits{}); });
    EXPECT_EQ(e.code(), ErrorCode::UnsupportedVersion) << e.what();
    EXPECT_NE(std::string(e.what()).find("version " + std::to_string(version)), std::string::npos) << e.what();
  }
}

TEST(Header, BodyAboveTheLimitIsTooLarge) {
  const Limits defaults;
  EXPECT_EQ(defaults.maxBodyBytes, 64u << 20);
  EXPECT_EQ(decodeHeader(encodeHeader({kVersion, MessageType::Frame, 1, 64u << 20}), defaults).bodyBytes, 64u << 20);
  ProtocolError e = thrown([&] {
    decodeHeader(encodeHeader({kVersion, MessageType::Frame, 1, (64u << 20) + 1}), defaults);
  });
  EXPECT_EQ(e.code(), ErrorCode::TooLarge);
  EXPECT_STREQ(e.what(), "header: body of 67108865 bytes exceeds limit 67108864");

  const Limits lowered{.maxBodyBytes = 100};
  EXPECT_NO_THROW(decodeHeader(encodeHeader({kVersion, MessageType::Frame, 1, 100}), lowered));
  EXPECT_EQ(thrown([&] {
              decodeHeader(encodeHeader({kVersion, MessageType::Frame, 1, 101}), lowered);
            }).code(),
            ErrorCode::TooLarge);
}

TEST(Header, UnknownTypePassesTheHeaderAndFailsTheBody) {
  for (uint16_t type : {uint16_t(0), uint16_t(13), uint16_t(0xFFFF)}) {
    const auto bytes = encodeHeader({kVersion, MessageType(type), 5, 3});
    const Header header = decodeHeader(bytes, Limits{});
    EXPECT_EQ(uint16_t(header.type), type);
    const Bytes body = {1, 2, 3};
    ProtocolError e = thrown([&] { decodeBody(header, body, Limits{}); });
    EXPECT_EQ(e.code(), ErrorCode::UnknownType) << e.what();
    EXPECT_NE(std::string(e.what()).find(std::to_string(type)), std::string::npos) << e.what();
  }
}

TEST(Header, BodySpanMustMatchTheHeader) {
  const Bytes body = {1, 0, 1, 0, 0, 0, 0, 0};
  EXPECT_THROW(decodeBody({kVersion, MessageType::Hello, 1, 9}, body, Limits{}), std::invalid_argument);
}

TEST(Messages, EveryMessageRoundTrips) {
  std::set<MessageType> types;
  uint32_t requestId = 1000;
  for (const Message& message : sampleMessages()) {
    SCOPED_TRACE(messageTypeName(messageType(message)));
    // Version 1 where the message exists in it, else the latest (a video Frame, FrameReceived).
    uint16_t version = kVersion;
    try {
      encode(message, 1, version);
    } catch (const std::invalid_argument&) {
      version = kMaxVersion;
    }
    const Bytes wire = encode(message, ++requestId, version);
    const Header header = decodeHeaderOf(wire);
    EXPECT_EQ(header.version, version);
    EXPECT_EQ(header.type, messageType(message));
    EXPECT_EQ(header.requestId, requestId);
    EXPECT_EQ(header.bodyBytes, wire.size() - kHeaderBytes);
    const Message decoded = decodeBody(header, std::span(wire).subspan(kHeaderBytes), Limits{});
    EXPECT_TRUE(decoded == message);
    EXPECT_EQ(encode(decoded, requestId, version), wire);
    types.insert(messageType(message));
  }
  EXPECT_EQ(types.size(), std::variant_size_v<Message>);
}

TEST(Messages, FieldsAreLaidOutAsSpecified) {
  const std::vector<std::pair<Message, Bytes>> cases = {
      {Hello{2, 3, "ab"}, concat({u16(2), u16(3), str("ab")})},
      {Capabilities{1, "s", 10, 20, 30, {Encoding::Png, Encoding::ZstdRgba8}},
       concat({u16(1), str("s"), u32(10), u32(20), u32(30), u32(2), {1, 2}})},
      {ListDatasets{}, {}},
      {DatasetList{{"a", ""}}, concat({u32(2), str("a"), str("")})},
      {OpenDataset{"x"}, str("x")},
      {DatasetInfo{"n", "{}"}, concat({str("n"), str("{}")})},
      {RenderRequest{Encoding::ZstdRgba8, "{}"}, concat({{2}, str("{}")})},
      {Frame{3, 2, Encoding::Png, "{}", {9, 8, 7}}, concat({u32(3), u32(2), {1}, str("{}"), u32(3), {9, 8, 7}})},
      {Error{ErrorCode::LimitExceeded, "m"}, concat({u16(9), str("m")})},
      {GetStats{}, {}},
      {Stats{"{}"}, str("{}")},
      {Goodbye{}, {}},
  };
  for (const auto& [message, body] : cases) {
    const MessageType type = messageType(message);
    SCOPED_TRACE(messageTypeName(type));
    EXPECT_EQ(hex(encode(message, 77)), hex(concat({headerBytes(type, 77, body.size()), body})));
    EXPECT_TRUE(decodeRaw(type, body) == message);
  }
}

TEST(Messages, TypeValuesAndNames) {
  const std::vector<std::pair<Message, std::string>> cases = {
      {Hello{}, "Hello"},
      {Capabilities{}, "Capabilities"},
      {ListDatasets{}, "ListDatasets"},
      {DatasetList{}, "DatasetList"},
      {OpenDataset{}, "OpenDataset"},
      {DatasetInfo{}, "DatasetInfo"},
      {RenderRequest{}, "Render"},
      {Frame{}, "Frame"},
      {Error{}, "Error"},
      {GetStats{}, "GetStats"},
      {Stats{}, "Stats"},
      {Goodbye{}, "Goodbye"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    EXPECT_EQ(uint16_t(messageType(cases[i].first)), i + 1);
    EXPECT_EQ(messageTypeName(messageType(cases[i].first)), cases[i].second);
  }
  EXPECT_STREQ(messageTypeName(MessageType(0)), "unknown");
  EXPECT_STREQ(messageTypeName(MessageType::FrameReceived), "FrameReceived");
  EXPECT_EQ(uint16_t(MessageType::FrameReceived), 13u);
  EXPECT_STREQ(messageTypeName(MessageType::Authenticate), "Authenticate");
  EXPECT_STREQ(messageTypeName(MessageType::Authenticated), "Authenticated");
  EXPECT_STREQ(messageTypeName(MessageType::Upload), "Upload");
  EXPECT_STREQ(messageTypeName(MessageType::UploadReady), "UploadReady");
  EXPECT_STREQ(messageTypeName(MessageType::UploadChunk), "UploadChunk");
  EXPECT_STREQ(messageTypeName(MessageType(19)), "unknown");
}

TEST(Messages, ErrorCodeNames) {
  const char* names[] = {"BadMagic",          "UnsupportedVersion", "UnknownType",  "TooLarge",      "Malformed",
                         "UnexpectedMessage", "UnknownDataset",     "InvalidScene", "LimitExceeded", "Superseded",
                         "Internal",          "ShuttingDown",       "Timeout",      "Busy",          "Forbidden",
                         "AlreadyExists"};
  for (uint16_t code = 1; code <= 16; ++code) {
    EXPECT_STREQ(errorCodeName(ErrorCode(code)), names[code - 1]);
    // every code decodes in the latest version
    const Bytes body = concat({u16(code), str("")});
    EXPECT_TRUE(decodeBody({kMaxVersion, MessageType::Error, 1, uint32_t(body.size())}, body, Limits{}) ==
                Message(Error{ErrorCode(code), ""}));
  }
  EXPECT_STREQ(errorCodeName(ErrorCode(0)), "unknown");
  EXPECT_STREQ(errorCodeName(ErrorCode(17)), "unknown");
}

TEST(Versions, BusyExistsFromVersionThreeOn) {
  EXPECT_FALSE(errorCodeInVersion(ErrorCode::Busy, 1));
  EXPECT_FALSE(errorCodeInVersion(ErrorCode::Busy, 2));
  EXPECT_TRUE(errorCodeInVersion(ErrorCode::Busy, 3));
  EXPECT_TRUE(errorCodeInVersion(ErrorCode::Timeout, 1));
  const Bytes body = concat({u16(14), str("x")});
  // Version 2: an unknown code, refused as any unknown enum value; version 3 decodes it.
  ProtocolError e = thrown([&] { decodeBody({2, MessageType::Error, 1, uint32_t(body.size())}, body, Limits{}); });
  EXPECT_EQ(e.code(), ErrorCode::Malformed);
  EXPECT_TRUE(decodeBody({3, MessageType::Error, 1, uint32_t(body.size())}, body, Limits{}) ==
              Message(Error{ErrorCode::Busy, "x"}));
  EXPECT_THROW(encode(Error{ErrorCode::Busy, "x"}, 1, 2), std::invalid_argument);
}

TEST(Versions, BusyMessagesCarryTheirRetryHint) {
  const std::string text = busyMessage("4 batch frames are queued", 1500);
  EXPECT_EQ(text, "4 batch frames are queued; retry after 1500 ms");
  EXPECT_EQ(retryAfterMs(text), 1500u);
  EXPECT_EQ(retryAfterMs(busyMessage("x", 0)), 1u);  // a hint is never 0
  EXPECT_EQ(retryAfterMs("no hint"), std::nullopt);
  EXPECT_EQ(retryAfterMs("; retry after  ms"), std::nullopt);
  EXPECT_EQ(retryAfterMs("; retry after 12x ms"), std::nullopt);
  EXPECT_EQ(retryAfterMs("; retry after 1234567890 ms"), std::nullopt);  // more than 9 digits
}

TEST(Malformed, TruncatedAtEveryCutPoint) {
  const std::vector<Message> messages = {
      Hello{1, 2, "client"},
      Capabilities{1, "srv", 1, 2, 3, {Encoding::Png, Encoding::RawRgba8}},
      DatasetList{{"one", "", "three"}},
      OpenDataset{"mri"},
      DatasetInfo{"mri", "{}"},
      RenderRequest{Encoding::Png, R"({"size": [8, 8]})"},
      Frame{4, 4, Encoding::RawRgba8, R"({"a": 1})", pattern(64)},
      Error{ErrorCode::Internal, "boom"},
      Stats{"{}"},
  };
  for (const Message& message : messages) {
    const MessageType type = messageType(message);
    const Bytes wire = encode(message, 1);
    const Bytes body(wire.begin() + kHeaderBytes, wire.end());
    for (size_t cut = 0; cut < body.size(); ++cut) {
      ProtocolError e = malformed(type, Bytes(body.begin(), body.begin() + long(cut)));
      EXPECT_EQ(std::string(e.what()).rfind(std::string(messageTypeName(type)) + ".", 0), 0u)
          << "cut " << cut << ": " << e.what();
    }
  }
}

TEST(Malformed, TrailingByteAfterTheLastField) {
  for (const Message& message : sampleMessages()) {
    const MessageType type = messageType(message);
    SCOPED_TRACE(messageTypeName(type));
    const Bytes wire = encode(message, 1, kMaxVersion);
    Bytes body(wire.begin() + kHeaderBytes, wire.end());
    body.push_back(0);
    ProtocolError e = thrown([&] { decodeBody({kMaxVersion, type, 1, uint32_t(body.size())}, body, Limits{}); });
    EXPECT_EQ(e.code(), ErrorCode::Malformed);
    EXPECT_EQ(std::string(e.what()), std::string(messageTypeName(type)) + ": 1 trailing byte(s) after the last field");
  }
}

TEST(Malformed, UnknownEnumValues) {
  EXPECT_STREQ(malformed(MessageType::Render, concat({{3}, str("{}")})).what(),
               "Render.encoding: unknown value 3 in protocol version 1");
  EXPECT_STREQ(malformed(MessageType::Render, concat({{255}, str("{}")})).what(),
               "Render.encoding: unknown value 255 in protocol version 1");
  EXPECT_STREQ(malformed(MessageType::Frame, concat({u32(1), u32(1), {7}, str(""), u32(0)})).what(),
               "Frame.encoding: unknown value 7 in protocol version 1");
  EXPECT_STREQ(
      malformed(MessageType::Capabilities, concat({u16(1), str(""), u32(0), u32(0), u32(0), u32(3), {1, 9, 0}})).what(),
      "Capabilities.encodings[1]: unknown value 9 in protocol version 1");
  for (uint16_t code : {uint16_t(0), uint16_t(14), uint16_t(0xFFFF)})
    EXPECT_EQ(std::string(malformed(MessageType::Error, concat({u16(code), str("x")})).what()),
              "Error.code: unknown value " + std::to_string(code) + " in protocol version 1");
}

TEST(Malformed, StringOverTheLimit) {
  EXPECT_EQ(Limits{}.maxStringBytes, 1u << 20);
  EXPECT_STREQ(malformed(MessageType::Render, concat({{1}, u32(5000000), Bytes(12, 'x')})).what(),
               "Render.scene_json: length 5000000 exceeds limit 1048576");

  // Every string field, at the limit (decodes) and one byte over it.
  const Limits limits{.maxStringBytes = 16};
  struct Case {
    MessageType type;
    Bytes before, after;
    std::string field;
  };
  const std::vector<Case> cases = {
      {MessageType::Hello, concat({u16(1), u16(1)}), {}, "Hello.client"},
      {MessageType::Capabilities, u16(1), concat({u32(0), u32(0), u32(0), u32(0)}), "Capabilities.server"},
      {MessageType::DatasetList, concat({u32(2), str("a")}), {}, "DatasetList.names[1]"},
      {MessageType::OpenDataset, {}, {}, "OpenDataset.name"},
      {MessageType::DatasetInfo, {}, str(""), "DatasetInfo.name"},
      {MessageType::DatasetInfo, str(""), {}, "DatasetInfo.meta_json"},
      {MessageType::Render, {0}, {}, "Render.scene_json"},
      {MessageType::Frame, concat({u32(1), u32(1), {1}}), u32(0), "Frame.stats_json"},
      {MessageType::Error, u16(5), {}, "Error.message"},
      {MessageType::Stats, {}, {}, "Stats.json"},
  };
  for (const Case& c : cases) {
    EXPECT_NO_THROW(decodeRaw(c.type, concat({c.before, str(std::string(16, 'a')), c.after}), limits)) << c.field;
    EXPECT_EQ(std::string(malformed(c.type, concat({c.before, str(std::string(17, 'a')), c.after}), limits).what()),
              c.field + ": length 17 exceeds limit 16");
  }
}

TEST(Malformed, PayloadIsBoundedByTheBodyNotTheStringLimit) {
  const Limits limits{.maxStringBytes = 16};
  const Message frame = Frame{2, 2, Encoding::RawRgba8, "", pattern(1000)};
  EXPECT_TRUE(decodeWhole(encode(frame, 1), limits) == frame);
  EXPECT_STREQ(malformed(MessageType::Frame, concat({u32(1), u32(1), {1}, str(""), u32(11), Bytes(10, 0)})).what(),
               "Frame.payload: length 11 exceeds the 10 bytes left in the body");
}

TEST(Malformed, CountOverTheLimit) {
  EXPECT_EQ(Limits{}.maxListCount, 4096u);
  const Message atLimit = DatasetList{std::vector<std::string>(4096)};
  EXPECT_TRUE(decodeWhole(encode(atLimit, 1)) == atLimit);
  EXPECT_STREQ(malformed(MessageType::DatasetList, concat({u32(4097), Bytes(4097 * 4, 0)})).what(),
               "DatasetList.names: count 4097 exceeds limit 4096");
  EXPECT_STREQ(
      malformed(MessageType::Capabilities, concat({u16(1), str(""), u32(0), u32(0), u32(0), u32(3), {0, 1, 2}}),
                Limits{.maxListCount = 2})
          .what(),
      "Capabilities.encodings: count 3 exceeds limit 2");
}

TEST(Malformed, HugeClaimsInATinyBodyFailBeforeAllocating) {
  // With the limits out of the way only the bytes left stop these; an allocation of the claimed size would throw
  // std::bad_alloc (not a ProtocolError) or take seconds.
  const uint32_t kMax = 0xFFFFFFFFu;
  const Limits open{.maxBodyBytes = kMax, .maxStringBytes = kMax, .maxListCount = kMax};
  const auto start = std::chrono::steady_clock::now();
  EXPECT_STREQ(malformed(MessageType::Frame, concat({u32(1), u32(1), {1}, str(""), u32(kMax)}), open).what(),
               "Frame.payload: length 4294967295 exceeds the 0 bytes left in the body");
  EXPECT_STREQ(malformed(MessageType::Render, concat({{1}, u32(0xFFFFFFF0u), {'{'}}), open).what(),
               "Render.scene_json: length 4294967280 exceeds the 1 bytes left in the body");
  EXPECT_STREQ(malformed(MessageType::DatasetList, concat({u32(kMax), str("a")}), open).what(),
               "DatasetList.names: count 4294967295 needs at least 17179869180 bytes, 5 left in the body");
  EXPECT_STREQ(malformed(MessageType::Capabilities,
                         concat({u16(1), str(""), u32(0), u32(0), u32(0), u32(1000), Bytes(999, 1)}), open)
                   .what(),
               "Capabilities.encodings: count 1000 needs at least 1000 bytes, 999 left in the body");
  // The same claims under the default limits are refused by the limits.
  EXPECT_EQ(malformed(MessageType::Render, concat({{1}, u32(kMax)})).code(), ErrorCode::Malformed);
  EXPECT_EQ(malformed(MessageType::DatasetList, u32(kMax)).code(), ErrorCode::Malformed);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(2));
}

TEST(Malformed, StringsMustBeUtf8) {
  for (const std::string valid : {"plain", "\x7F", "\xC3\xBC", "\xE4\xBD\x93", "\xEF\xBF\xBD", "\xF0\x9F\xA7\xA0",
                                  "\xF4\x8F\xBF\xBF", "\xED\x9F\xBF"}) {
    EXPECT_TRUE(decodeRaw(MessageType::OpenDataset, str(valid)) == Message(OpenDataset{valid})) << hex(str(valid));
  }
  const std::vector<std::pair<std::string, int>> invalid = {
      {"a\x80", 1},             // continuation byte without a lead
      {"\xC0\xAF", 0},          // overlong two-byte form
      {"\xC1\xBF", 0},          // overlong two-byte form
      {"ab\xE0\x80\x80", 2},    // overlong three-byte form
      {"\xED\xA0\x80", 0},      // a surrogate
      {"\xF0\x80\x80\x80", 0},  // overlong four-byte form
      {"\xF4\x90\x80\x80", 0},  // above U+10FFFF
      {"\xF5\x80\x80\x80", 0},  // never a lead byte
      {"\xFF", 0},              // never a lead byte
      {"xyz\xE2\x82", 3},       // sequence cut short by the end of the string
      {"\xE2\x28\xA1", 0},      // second byte not a continuation
      {"\xF0\x9F\xA7\x41", 0},  // fourth byte not a continuation
  };
  for (const auto& [text, offset] : invalid) {
    EXPECT_EQ(std::string(malformed(MessageType::OpenDataset, str(text)).what()),
              "OpenDataset.name: not valid UTF-8 at byte " + std::to_string(offset))
        << hex(str(text));
  }
}

/// Reads a committed corpus file.
Bytes corpusFile(const std::string& name) {
  const std::vector<char> data =
      voxbrick::test::readFile(std::filesystem::path(VOXBRICK_SOURCE_DIR) / "proto/fuzz/corpus" / name);
  return Bytes(data.begin(), data.end());
}

TEST(FuzzCorpus, EveryFileReplaysThroughTheFuzzCheck) {
  // What the malformed seeds must provoke, so that each keeps covering its path.
  const std::map<std::string, std::vector<ErrorCode>> expectedErrors = {
      {"bad-magic", {ErrorCode::BadMagic}},
      {"bad-version", {ErrorCode::UnsupportedVersion}},
      {"bad-too-large", {ErrorCode::TooLarge}},
      {"bad-truncated", {ErrorCode::Malformed}},
      {"bad-trailing-byte", {ErrorCode::Malformed}},
      {"bad-encoding", {ErrorCode::Malformed}},
      {"bad-error-code", {ErrorCode::Malformed}},
      {"bad-string-limit", {ErrorCode::Malformed}},
      {"bad-list-count", {ErrorCode::Malformed}},
      {"bad-huge-length", {ErrorCode::Malformed}},
      {"bad-utf8", {ErrorCode::Malformed}},
      {"bad-unknown-type-then-goodbye", {ErrorCode::UnknownType}},
      {"bad-encoding-v2", {ErrorCode::Malformed}},
      {"bad-encoding-v6", {ErrorCode::Malformed}},
      {"bad-frame-received-v3", {ErrorCode::UnknownType}},
      {"bad-authenticate-v4", {ErrorCode::UnknownType}},
      {"bad-forbidden-v4", {ErrorCode::Malformed}},
      {"bad-upload-v5", {ErrorCode::UnknownType}},
      {"bad-already-exists-v5", {ErrorCode::Malformed}},
      {"bad-upload-chunk-length", {ErrorCode::Malformed}},
  };
  std::set<MessageType> decodedTypes;
  size_t files = 0;
  for (const auto& entry :
       std::filesystem::directory_iterator(std::filesystem::path(VOXBRICK_SOURCE_DIR) / "proto/fuzz/corpus")) {
    const std::string name = entry.path().filename().string();
    SCOPED_TRACE(name);
    ++files;
    fuzz::CheckResult result;
    ASSERT_NO_THROW(result = fuzz::checkStream(corpusFile(name), fuzz::kFuzzLimits));
    EXPECT_NO_THROW(fuzz::checkStream(corpusFile(name), fuzz::kNoLimits));
    if (name.starts_with("bad-")) {
      ASSERT_TRUE(expectedErrors.contains(name)) << "add the malformed seed's expected errors here";
      EXPECT_EQ(result.errors, expectedErrors.at(name));
    } else {
      EXPECT_TRUE(result.errors.empty());
      EXPECT_FALSE(result.decoded.empty());
    }
    decodedTypes.insert(result.decoded.begin(), result.decoded.end());
  }
  EXPECT_GE(files, std::variant_size_v<Message> + expectedErrors.size());
  EXPECT_EQ(decodedTypes.size(), std::variant_size_v<Message>) << "a message type has no valid seed";
}

TEST(FuzzCorpus, StreamCheckFollowsTheSession) {
  // A body that does not decode is skipped and the stream goes on.
  const auto goesOn = fuzz::checkStream(corpusFile("bad-unknown-type-then-goodbye"), fuzz::kFuzzLimits);
  EXPECT_EQ(goesOn.decoded, std::vector<MessageType>{MessageType::Goodbye});
  // A header that does not decode ends the stream.
  const auto ends = fuzz::checkStream(concat({encode(Goodbye{}, 1), corpusFile("bad-magic"), encode(Goodbye{}, 2)}),
                                      fuzz::kFuzzLimits);
  EXPECT_EQ(ends.decoded, std::vector<MessageType>{MessageType::Goodbye});
  EXPECT_EQ(ends.errors, std::vector<ErrorCode>{ErrorCode::BadMagic});
  // An incomplete last message is left unread.
  const Bytes render = encode(RenderRequest{Encoding::Png, "{}"}, 2);
  const auto partial =
      fuzz::checkStream(concat({encode(Hello{}, 1), Bytes(render.begin(), render.end() - 1)}), fuzz::kFuzzLimits);
  EXPECT_EQ(partial.decoded, std::vector<MessageType>{MessageType::Hello});
  EXPECT_TRUE(partial.errors.empty());
  // A whole session decodes in order.
  const auto session = fuzz::checkStream(corpusFile("session"), fuzz::kFuzzLimits);
  EXPECT_EQ(session.decoded,
            (std::vector<MessageType>{MessageType::Hello, MessageType::ListDatasets, MessageType::OpenDataset,
                                      MessageType::Render, MessageType::GetStats, MessageType::Goodbye}));
}

}  // namespace
