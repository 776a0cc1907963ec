// A render thread's work for one job: render, encode, add the server's timings.
#include "server/RenderJob.h"

#include <algorithm>
#include <string>
#include <utility>

#include <nlohmann/json.hpp>

#include "brickstore/format/Errors.h"
#include "image/FrameImage.h"
#include "image/Video.h"
#include "render/core/RenderErrors.h"
#include "server/ErrorReply.h"

namespace voxbrick::server {
namespace {

using Clock = std::chrono::steady_clock;

double jobMsBetween(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

}  // namespace

std::string withKey(std::string statsJson, std::string_view key, std::string_view value) {
  if (statsJson.size() < 2 || statsJson.back() != '}') return statsJson;
  statsJson.pop_back();
  statsJson += statsJson.size() > 1 ? "," : "";
  statsJson.append("\"").append(key).append("\":").append(value).append("}");
  return statsJson;
}

proto::Message encodeStill(proto::Frame frame, int jpegQuality, const RenderJob& job) {
  const image::PngSpeed pngSpeed = job.pngSpeed;
  const uint64_t maxBodyBytes = job.maxBodyBytes;
  const auto start = Clock::now();
  bool webpForSize = false;
  try {
    image::Image8 image;
    image.width = int(frame.width);
    image.height = int(frame.height);
    image.rgba = std::move(frame.payload);
    frame.payload = image::encodeFrameImage(image, frame.encoding, jpegQuality, pngSpeed);
    // A 1920x1080 png of a detailed view passes 1 MiB, the default limit; its webp takes about half.
    if (frame.encoding == proto::Encoding::Png && job.scene.acceptsWebp &&
        frameBodyBytes(frame.statsJson.size() + 128, frame.payload.size()) > maxBodyBytes) {
      frame.encoding = proto::Encoding::Webp;
      frame.payload = image::encodeFrameImage(image, frame.encoding, jpegQuality, pngSpeed);
      webpForSize = true;
    }
  } catch (...) {
    return errorReply(std::current_exception(), "the " + std::to_string(frame.width) + "x" +
                                                    std::to_string(frame.height) + " frame could not be encoded");
  }
  frame.statsJson =
      withKey(std::move(frame.statsJson), "encode_ms", nlohmann::json(jobMsBetween(start, Clock::now())).dump());
  frame.statsJson =
      withKey(std::move(frame.statsJson), "encode_start_ms", nlohmann::json(jobMsBetween(job.received, start)).dump());
  if (frame.encoding == proto::Encoding::Png)
    frame.statsJson = withKey(std::move(frame.statsJson), "png_speed",
                              pngSpeed == image::PngSpeed::Fast ? "\"fast\"" : "\"small\"");
  if (webpForSize) frame.statsJson = withKey(std::move(frame.statsJson), "webp_for_size", "true");
  if (const uint64_t body = frameBodyBytes(frame.statsJson.size(), frame.payload.size()); body > maxBodyBytes)
    return errorMessage(proto::ErrorCode::LimitExceeded,
                        "the " + std::to_string(frame.width) + "x" + std::to_string(frame.height) + " frame takes " +
                            std::to_string(body) + " bytes, above this server's message limit of " +
                            std::to_string(maxBodyBytes) + "; ask for a smaller image or another encoding");
  return frame;
}

proto::Encoding replyEncoding(const RenderJob& job, bool provisional) {
  const proto::Encoding encoding = provisional ? job.provisionalEncoding.value_or(job.encoding) : job.encoding;
  return encoding == proto::Encoding::Png && job.webpForPng ? proto::Encoding::Webp : encoding;
}

int replyJpegQuality(const RenderJob& job, bool provisional, int width, int height) {
  const int quality = provisional && job.provisionalJpegQuality ? *job.provisionalJpegQuality
                                                                : job.scene.jpegQuality.value_or(image::kDefaultJpegQuality);
  // A JPEG of a drawing the client scales up: each of its losses is magnified with it, and its bytes are few.
  const bool smaller = width > 0 && height > 0 && (width != job.scene.width || height != job.scene.height);
  return provisional && smaller ? std::min(kAsDrawnJpegQualityMax, quality + kAsDrawnJpegQualityRaise) : quality;
}

uint64_t frameBodyBytes(size_t statsBytes, size_t payloadBytes) {
  return 4 + 4 + 1 + 4 + uint64_t(statsBytes) + 4 + uint64_t(payloadBytes);
}

RenderReply renderReply(render::FrameSource& source, const RenderJob& job, int thread,
                        const std::function<bool()>& cancelled) {
  const auto start = Clock::now();
  try {
    render::FrameStats stats;
    render::FrameOptions options;
    options.standIns = job.scene.progressive && !job.refinement;
    options.maxSamples = job.maxSamples;
    options.cancelled = cancelled;
    options.rateSamplesPerMs = job.rateSamplesPerMs;
    options.fixedMs = job.fixedMs;
    options.outputScale = job.outputScale;
    render::Scene scene = job.scene;
    if (job.refinement) scene.interactive = false;  // the exact frame of an interactive request
    // A moving frame for a client that shows it scaled goes at the size it was drawn (a video stream's frames go at
    // the stream's: outputScale).
    options.keepReducedSize =
        job.provisionalAsDrawn && scene.interactive && !image::isVideoEncoding(replyEncoding(job, true));
    image::Image8 image = source.render8(job.dataset, scene, &stats, options);
    // A frame with stand-ins, or an interactive frame: the exact one follows.
    const bool provisional = stats.bricksStandIn > 0 || scene.interactive;
    proto::Frame frame;
    frame.width = uint32_t(image.width);
    frame.height = uint32_t(image.height);
    frame.encoding = replyEncoding(job, provisional);
    const int jpegQuality = replyJpegQuality(job, provisional, image.width, image.height);
    // A video frame leaves as its pixels: the session's stream encodes it off this thread (server/VideoStream.h); so
    // does a still frame whose session encodes aside (a raw one needs no encoding).
    const bool video = image::isVideoEncoding(frame.encoding);
    const bool aside = video || (job.encodeAside && frame.encoding != proto::Encoding::RawRgba8);
    frame.payload = std::move(image.rgba);
    nlohmann::json statsJson = stats.toJson();
    statsJson["queue_ms"] = jobMsBetween(job.received, start);
    statsJson["render_thread"] = thread;
    statsJson["provisional"] = provisional;
    statsJson["class"] = common::nameOf(frameClassOf(job));
    if (job.requestedBudgetMs > 0) {
      // The crowd cut this interactive frame's budget (its scene's is `requested`).
      statsJson["load"] = {{"time_budget_ms", scene.timeBudgetMs},
                           {"requested_budget_ms", job.requestedBudgetMs},
                           {"jpeg_quality", jpegQuality}};
    }
    frame.statsJson = statsJson.dump();
    RenderReply reply{
        aside ? proto::Message(std::move(frame))
              : encodeStill(std::move(frame), jpegQuality, job),
        provisional};
    // A provisional frame too large to send answers its request with the error: no exact frame follows.
    reply.provisional = provisional && std::holds_alternative<proto::Frame>(reply.message);
    if (aside && !video) reply.stillToEncode = jpegQuality;
    reply.samples = stats.samplesEstimated;
    reply.ms = stats.interactive.is_object() ? stats.interactive.value("actual_ms", stats.msTotal) : stats.msTotal;
    reply.warmupMs = stats.msWarmup;
    return reply;
  } catch (const render::FrameCancelled&) {
    return {proto::Error{proto::ErrorCode::Internal, "cancelled"}, false, true};
  } catch (const store::CorruptStoreError& e) {
    // The data failed its checks: the dataset's later renders are refused without drawing (MessageHandler).
    if (job.dataset) job.dataset->quarantine(e.what());
    return {errorReply(std::current_exception(), "render of request " + std::to_string(job.requestId) + " on '" +
                                                     (job.dataset ? job.dataset->name() : std::string("no dataset")) +
                                                     "' failed; the dataset is quarantined until it is replaced"),
            false};
  } catch (...) {
    return {errorReply(std::current_exception(), "render of request " + std::to_string(job.requestId) + " on '" +
                                                     (job.dataset ? job.dataset->name() : std::string("no dataset")) +
                                                     "' failed"),
            false};
  }
}

namespace {

/// The camera one more step along the motion from `a` to `b`; nothing if it did not move.
std::optional<render::CameraSpec> extrapolate(const render::CameraSpec& a, const render::CameraSpec& b) {
  if (a.orbit != b.orbit || a.upAxis != b.upAxis) return std::nullopt;
  render::CameraSpec next = b;
  if (b.orbit) {
    if (a.azimuth == b.azimuth && a.elevation == b.elevation && a.distance == b.distance) return std::nullopt;
    next.azimuth = 2 * b.azimuth - a.azimuth;
    next.elevation = std::clamp(2 * b.elevation - a.elevation, -89.0, 89.0);
    // A zoom goes on; a fitted orbit (no distance) stays fitted.
    if (a.distance && b.distance) next.distance = *b.distance * (*b.distance / *a.distance);
  } else {
    if (a.eye == b.eye && a.center == b.center) return std::nullopt;
    next.eye = 2.0 * b.eye - a.eye;
    next.center = 2.0 * b.center - a.center;
  }
  return next;
}

}  // namespace

void prefetchAhead(render::FrameSource& source, const RenderJob& job) {
  if (!job.previousCamera || !job.dataset) return;
  const auto next = extrapolate(*job.previousCamera, job.scene.camera);
  if (!next) return;
  render::Scene scene = job.scene;
  scene.camera = *next;
  try {
    source.prefetch(job.dataset, scene);
  } catch (...) {
    // Advisory: an extrapolated camera can be invalid (inside out, degenerate), and then nothing is paged ahead.
  }
}

}  // namespace voxbrick::server
