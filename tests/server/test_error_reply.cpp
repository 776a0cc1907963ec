// The one mapping from exceptions to protocol errors, and which codes end a session.
#include <gtest/gtest.h>

#include "render/core/RenderErrors.h"
#include "server/Datasets.h"
#include "server/ErrorReply.h"

namespace voxbrick::server {
namespace {

using proto::ErrorCode;

template <typename E>
proto::Error replyTo(const E& exception, const std::string& context = "doing the test") {
  return errorReply(std::make_exception_ptr(exception), context);
}

TEST(ErrorReply, ProtocolErrorsKeepTheirCodeAndMessage) {
  for (ErrorCode code : {ErrorCode::BadMagic, ErrorCode::Malformed, ErrorCode::UnexpectedMessage,
                         ErrorCode::UnsupportedVersion, ErrorCode::UnknownType}) {
    const proto::Error e = replyTo(proto::ProtocolError(code, "field x: bad"));
    EXPECT_EQ(e.code, code) << proto::errorCodeName(code);
    EXPECT_EQ(e.message, "field x: bad");
  }
}

TEST(ErrorReply, EachTypedExceptionGetsItsDocumentedCode) {
  EXPECT_EQ(replyTo(DatasetNotFound("no dataset 'x'")).code, ErrorCode::UnknownDataset);
  EXPECT_EQ(replyTo(render::RenderInputError("scene: 'step' out of range")).code, ErrorCode::InvalidScene);
  EXPECT_EQ(replyTo(LimitExceededError("image too large")).code, ErrorCode::LimitExceeded);
  EXPECT_EQ(replyTo(DatasetNotFound("no dataset 'x'")).message, "no dataset 'x'");
  EXPECT_EQ(replyTo(render::RenderInputError("scene: 'step' out of range")).message, "scene: 'step' out of range");
}

TEST(ErrorReply, AnythingElseIsInternalAndSaysWhatFailed) {
  // A GL failure is a RenderError but not the client's fault.
  proto::Error e = replyTo(render::RenderError("glDrawArrays: out of memory"), "render of request 3 failed");
  EXPECT_EQ(e.code, ErrorCode::Internal);
  EXPECT_EQ(e.message, "render of request 3 failed: glDrawArrays: out of memory");
  e = replyTo(std::runtime_error("disk on fire"));
  EXPECT_EQ(e.code, ErrorCode::Internal);
  EXPECT_EQ(e.message, "doing the test: disk on fire");
  e = replyTo(42);
  EXPECT_EQ(e.code, ErrorCode::Internal);
  EXPECT_NE(e.message.find("unknown type"), std::string::npos) << e.message;
  e = errorReply(nullptr);
  EXPECT_EQ(e.code, ErrorCode::Internal);
  EXPECT_NE(e.message.find("internal error"), std::string::npos) << e.message;
}

TEST(ErrorReply, LongMessagesAreCutWithoutBreakingACharacter) {
  EXPECT_EQ(errorMessage(ErrorCode::Internal, std::string(5000, 'a')).message.size(), 4096u);
  EXPECT_EQ(errorMessage(ErrorCode::Internal, std::string(4096, 'a')).message.size(), 4096u);
  // "é" is two bytes; placed across the cut, it is left out whole.
  const std::string text = std::string(4095, 'a') + "\xC3\xA9" + "tail";
  const proto::Error e = errorMessage(ErrorCode::InvalidScene, text);
  EXPECT_EQ(e.message, std::string(4095, 'a'));
  // The reply still decodes (a cut character would make it Malformed for the client).
  const std::vector<uint8_t> bytes = proto::encode(e, 1);
  const proto::Limits limits;
  const proto::Header header =
      proto::decodeHeader(std::span<const uint8_t, proto::kHeaderBytes>(bytes.data(), proto::kHeaderBytes), limits);
  EXPECT_EQ(proto::decodeBody(header, std::span(bytes).subspan(proto::kHeaderBytes), limits), proto::Message(e));
}

TEST(ErrorReply, OnlyTheClosingCodesEndASession) {
  for (ErrorCode code : {ErrorCode::BadMagic, ErrorCode::UnsupportedVersion, ErrorCode::TooLarge, ErrorCode::Timeout,
                         ErrorCode::ShuttingDown})
    EXPECT_TRUE(closesSession(code)) << proto::errorCodeName(code);
  for (ErrorCode code :
       {ErrorCode::UnknownType, ErrorCode::Malformed, ErrorCode::UnexpectedMessage, ErrorCode::UnknownDataset,
        ErrorCode::InvalidScene, ErrorCode::LimitExceeded, ErrorCode::Superseded, ErrorCode::Internal})
    EXPECT_FALSE(closesSession(code)) << proto::errorCodeName(code);
}

TEST(ErrorReply, ClientsGetValidUtf8AndNoServerPaths) {
  // Raw bytes (a binary store.json quoted in a message) become U+FFFD; valid characters stay.
  const std::string bytes = std::string("store.json: unexpected '") + char(0xFF) + char(0xC3) + "' near é";
  const std::string clean = clientText(bytes);
  EXPECT_EQ(proto::invalidUtf8At(reinterpret_cast<const uint8_t*>(clean.data()), clean.size()), clean.size());
  EXPECT_EQ(clean, "store.json: unexpected '\xEF\xBF\xBD\xEF\xBF\xBD' near é");
  // Paths of the server keep their last part only; what only looks like one stays.
  EXPECT_EQ(clientText("/srv/data/ct/bricks.bin: frame at offset 12 does not decode"),
            "…/bricks.bin: frame at offset 12 does not decode");
  EXPECT_EQ(clientText("cannot open '/etc/voxbrick/tf/hot.json' (No such file)"),
            "cannot open '…/hot.json' (No such file)");
  EXPECT_EQ(clientText("ert must be 0 or in [0.5, 1]; 1/255 is the step; a / b"),
            "ert must be 0 or in [0.5, 1]; 1/255 is the step; a / b");
  const proto::Error e = replyTo(std::runtime_error("reading /tmp/x/datasets/bad/bricks.bin failed"), "render");
  EXPECT_EQ(e.message, "render: reading …/bricks.bin failed");
  const proto::Error cut = errorMessage(ErrorCode::Internal, std::string(5000, 'x') + char(0xFF));
  EXPECT_LE(cut.message.size(), 4096u);
}

}  // namespace
}  // namespace voxbrick::server
