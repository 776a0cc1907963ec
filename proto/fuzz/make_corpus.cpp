// Writes the fuzzer's seed corpus (committed in proto/fuzz/corpus/): one file per message type, a whole session,
// and malformed inputs whose names start with "bad-". Usage: proto_make_corpus DIRECTORY
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "proto/Messages.h"
#include "proto/fuzz/WireBytes.h"

namespace {

using namespace voxbrick::proto;
using namespace voxbrick::proto::wire;

Bytes header(MessageType type, uint32_t bodyBytes, uint16_t version = kVersion) {
  const auto bytes = encodeHeader({version, type, 7, bodyBytes});
  return Bytes(bytes.begin(), bytes.end());
}

/// A message with any body, valid or not.
Bytes raw(MessageType type, const Bytes& body, uint16_t version = kVersion) {
  return concat({header(type, uint32_t(body.size()), version), body});
}

Bytes withByte(Bytes bytes, size_t offset, uint8_t value) {
  bytes.at(offset) = value;
  return bytes;
}

const std::string kScene = R"({"camera": {"orbit": [30, 20, 2.5]}, "size": [64, 48]})";

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s DIRECTORY\n", argv[0]);
    return 2;
  }
  const std::vector<std::pair<std::string, Bytes>> seeds = {
      {"hello", encode(Hello{1, 1, "seed"}, 1)},
      {"capabilities", encode(Capabilities{1, "voxbrick", 1u << 20, 8192, 4, {Encoding::Png, Encoding::RawRgba8}}, 1)},
      {"list-datasets", encode(ListDatasets{}, 2)},
      {"dataset-list", encode(DatasetList{{"mri", "", "sparse"}}, 2)},
      {"open-dataset", encode(OpenDataset{"mri"}, 3)},
      {"dataset-info", encode(DatasetInfo{"mri", R"({"dims": [256, 256, 128]})"}, 3)},
      {"render", encode(RenderRequest{Encoding::Png, kScene}, 4)},
      {"frame", encode(Frame{2, 1, Encoding::RawRgba8, R"({"queue_ms": 0.5})", {1, 2, 3, 4, 5, 6, 7, 8}}, 4)},
      {"error", encode(Error{ErrorCode::Superseded, "replaced by request 5"}, 4)},
      {"get-stats", encode(GetStats{}, 6)},
      {"stats", encode(Stats{R"({"sessions": 1})"}, 6)},
      {"goodbye", encode(Goodbye{}, 7)},
      {"session",
       concat({encode(Hello{1, 1, "seed"}, 1), encode(ListDatasets{}, 2), encode(OpenDataset{"mri"}, 3),
               encode(RenderRequest{Encoding::ZstdRgba8, kScene}, 4), encode(GetStats{}, 5), encode(Goodbye{}, 6)})},
      {"session-v2",
       concat({encode(Hello{1, 2, "seed"}, 1),
               encode(Capabilities{2, "voxbrick", 1u << 20, 8192, 4, encodingsOf(2)}, 1, 2),
               encode(RenderRequest{Encoding::Jpeg, kScene}, 2, 2),
               encode(Frame{1, 1, Encoding::Jpeg, R"({"provisional": false})", {0xFF, 0xD8, 0xFF, 0xD9}}, 2, 2)})},
      {"session-v4",
       concat(
           {encode(Hello{1, 4, "seed"}, 1),
            encode(Capabilities{4, "voxbrick", 1u << 20, 8192, 4, encodingsOf(4)}, 1, 4),
            encode(RenderRequest{Encoding::Png, R"({"interactive": true, "provisional_encoding": "vp8"})"}, 2, 4),
            encode(Frame{1, 1, Encoding::Vp8, R"({"provisional": true, "video": {"key": true}})", {0x10, 0x02, 0x00}},
                   2, 4),
            encode(FrameReceived{64}, 2, 4)})},
      {"session-v7",
       concat({encode(Hello{1, 7, "seed"}, 1),
               encode(Capabilities{7, "voxbrick", 1u << 20, 8192, 4, encodingsOf(7)}, 1, 7),
               encode(RenderRequest{Encoding::Png, R"({"accepts_webp": true})"}, 2, 7),
               encode(Frame{1, 1, Encoding::Webp, R"({"provisional": false})", {'R', 'I', 'F', 'F'}}, 2, 7)})},
      {"frame-received", encode(FrameReceived{1234}, 9, 4)},
      {"authenticate", encode(Authenticate{"3d1f9c0e7b2a4d6f8e0c1b3a5d7f9e2c"}, 2, 5)},
      {"authenticated", encode(Authenticated{"radiology"}, 2, 5)},
      {"session-v5",
       concat({encode(Hello{1, 5, "seed"}, 1),
               encode(Capabilities{5, "voxbrick", 1u << 20, 8192, 1, encodingsOf(5)}, 1, 5),
               encode(Authenticate{"3d1f9c0e7b2a4d6f8e0c1b3a5d7f9e2c"}, 2, 5), encode(Authenticated{"radiology"}, 2, 5),
               encode(ListDatasets{}, 3, 5), encode(DatasetList{{"mri"}}, 3, 5),
               encode(Error{ErrorCode::Forbidden, "wrong access token"}, 4, 5)})},
      {"upload", encode(Upload{"scan-7", R"({"dims": [4, 2, 1], "type": "uint16"})", 16}, 2, 6)},
      {"upload-ready", encode(UploadReady{1u << 20}, 2, 6)},
      {"upload-chunk", encode(UploadChunk{{1, 0, 2, 0, 3, 0, 4, 0}}, 3, 6)},
      {"session-v6",
       concat({encode(Hello{1, 6, "seed"}, 1),
               encode(Capabilities{6, "voxbrick", 1u << 20, 8192, 1, encodingsOf(6)}, 1, 6),
               encode(Authenticate{"3d1f9c0e7b2a4d6f8e0c1b3a5d7f9e2c"}, 2, 6), encode(Authenticated{"radiology"}, 2, 6),
               encode(Upload{"scan-7", R"({"dims": [2, 2, 1], "type": "uint8"})", 4}, 3, 6),
               encode(UploadReady{1u << 20}, 3, 6), encode(UploadChunk{{1, 2}}, 4, 6), encode(UploadChunk{{3, 4}}, 5, 6),
               encode(DatasetInfo{"scan-7", R"({"dims": [2, 2, 1]})"}, 5, 6),
               encode(Error{ErrorCode::AlreadyExists, "a dataset named 'scan-7' exists"}, 6, 6)})},
      {"bad-upload-v5", raw(MessageType::Upload, concat({str("a"), str("{}"), u64(0)}), 5)},
      {"bad-already-exists-v5", raw(MessageType::Error, concat({{16, 0}, u32(0)}), 5)},
      {"bad-upload-chunk-length", raw(MessageType::UploadChunk, concat({u32(9), {1, 2, 3}}), 6)},
      {"bad-authenticate-v4", raw(MessageType::Authenticate, concat({u32(2), {'a', 'b'}}), 4)},
      {"bad-forbidden-v4", raw(MessageType::Error, concat({{15, 0}, u32(0)}), 4)},
      {"bad-frame-received-v3", raw(MessageType::FrameReceived, u32(64), 3)},
      {"bad-unknown-type-then-goodbye", concat({raw(MessageType(99), {1, 2, 3}), encode(Goodbye{}, 8)})},
      {"bad-magic", withByte(encode(Goodbye{}, 1), 3, 'X')},
      {"bad-version", raw(MessageType::Goodbye, {}, kMaxVersion + 1)},
      {"bad-too-large", header(MessageType::Stats, 2u << 20)},
      {"bad-truncated", raw(MessageType::Render, {1, 10, 0, 0, 0, '{', '}'})},
      {"bad-trailing-byte", raw(MessageType::Goodbye, {0})},
      {"bad-encoding", raw(MessageType::Render, concat({{3}, u32(2), {'{', '}'}}))},  // jpeg does not exist in v1
      {"bad-encoding-v2", raw(MessageType::Render, concat({{4}, u32(2), {'{', '}'}}), 2)},
      {"bad-encoding-v6", raw(MessageType::Render, concat({{6}, u32(2), {'{', '}'}}), 6)},  // webp is version 7's
      {"bad-error-code", raw(MessageType::Error, concat({{14, 0}, u32(0)}))},
      {"bad-string-limit", raw(MessageType::OpenDataset, concat({u32(300), Bytes(300, 'a')}))},
      {"bad-list-count", raw(MessageType::DatasetList, concat({u32(17), Bytes(17 * 4, 0)}))},
      {"bad-huge-length", raw(MessageType::Frame, concat({u32(1), u32(1), {1}, u32(0), u32(0xFFFFFFF0u)}))},
      {"bad-utf8", raw(MessageType::Hello, concat({{1, 0, 1, 0}, u32(2), {0xC0, 0xAF}}))},
  };
  for (const auto& [name, bytes] : seeds) {
    const std::string path = std::string(argv[1]) + "/" + name;
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    if (!out) {
      std::fprintf(stderr, "cannot write %s\n", path.c_str());
      return 1;
    }
  }
  return 0;
}
