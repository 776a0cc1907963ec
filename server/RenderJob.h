// One accepted Render request on its way to a render thread, what the queue did with it, and how a render thread
// turns it into its reply (a Frame, or an Error).
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "image/Image.h"
#include "proto/Messages.h"
#include "render/core/Dataset.h"
#include "render/core/Scene.h"
#include "render/engine/FrameSource.h"
#include "server/FrameClass.h"

namespace voxbrick::server {

/// A Render request, checked and parsed, waiting for or on a render thread.
struct RenderJob {
  uint32_t requestId = 0;
  proto::Encoding encoding = proto::Encoding::Png;  ///< of the exact Frame's payload
  /// Of a provisional Frame's payload (the scene's `provisional_encoding`); none: `encoding`. See replyEncoding.
  std::optional<proto::Encoding> provisionalEncoding;
  render::Scene scene;
  std::shared_ptr<const render::Dataset> dataset;  ///< the one open when the request came
  std::chrono::steady_clock::time_point received;  ///< for queue_ms and the latency statistics
  /// The camera of the session's previous Render of the same dataset, if any: the render thread pages ahead for
  /// the camera a drag would reach next (prefetchAhead).
  std::optional<render::CameraSpec> previousCamera;
  /// The exact frame of a progressive request already answered with a provisional one: queued by the render
  /// thread, not by the client, so it is dropped silently when a newer Render of the session arrives.
  bool refinement = false;
  /// The exact frame that ends a drag: a still Render of a session that dragged within the last
  /// RenderScheduler::kInteractiveWindow (a page asks one on release), or the exact frame of its last interactive
  /// frame once the camera rested. Served in the interactive class, so that a viewer who lets go sees the exact
  /// frame at once rather than after a still crowd's share (the scheduler sets it).
  bool endsDrag = false;
  /// endsDrag for a drag that was refused Busy (the session never dragged): not a cost of the drags the threads keep,
  /// so not counted in the measured capacity (a crowd's refused drags would otherwise shrink it, and be refused more).
  bool endsRefusedDrag = false;
  /// The body limit of the session (Capabilities' max_message_bytes): a Frame whose body would exceed it is
  /// answered LimitExceeded instead.
  uint64_t maxBodyBytes = UINT64_MAX;
  /// The most samples the frame may cost (ServerConfig::maxRenderMSamples); 0: no limit.
  double maxSamples = 0;
  /// An interactive frame's rate (estimated samples per ms), the session's as the scheduler measured its frames; 0:
  /// the render thread's recent rate (a session's first frame).
  double rateSamplesPerMs = 0;
  double fixedMs = 0;  ///< with rateSamplesPerMs: the session's time a frame takes besides its samples
  /// Not to be drawn before this time: the exact frame of an interactive request waits for the camera to rest.
  std::chrono::steady_clock::time_point notBefore{};
  /// Set by the scheduler for an interactive frame under a crowd: the scene's own time budget (the scene then
  /// carries the smaller one the load leaves), and the JPEG quality of its provisional frame.
  double requestedBudgetMs = 0;
  std::optional<int> provisionalJpegQuality;
  /// The key of the frame it asks for (shareKeyOf), made once when it is queued; empty when it is never shared.
  std::string shareKey;
  /// Answered from the render of another session's identical frame.
  bool shared = false;
  /// The session encodes this job's still frames itself, off the render thread (ServerConfig::encodeAside): a Frame
  /// in png, jpeg or zstd_rgba8 leaves the render thread with its RGBA8 pixels as its payload, so that the thread
  /// goes on to its next frame while this one is encoded (Connection).
  bool encodeAside = false;
  /// Set on the copy of the job a Frame is delivered with, never on a queued job: the Frame's payload is still its
  /// RGBA8 pixels, to be encoded (encodeStill) at this JPEG quality.
  std::optional<int> stillToEncode = std::nullopt;
  /// With stillToEncode: the Frame is provisional (RenderReply::provisional), an exact one to follow.
  bool stillProvisional = false;
  /// How its png Frames are encoded: pngSpeedFor the session's link when it was submitted.
  image::PngSpeed pngSpeed = image::PngSpeed::Fast;
  /// Its png Frames travel as lossless webp instead (the scene's `accepts_webp`, on a link webpFor finds slow
  /// enough); see replyEncoding.
  bool webpForPng = false;
  /// An interactive frame is drawn at no more than this fraction of the scene's sides and returned at that size
  /// (render::FrameOptions::outputScale): set to the session's video stream's scale for a frame of that stream
  /// (Connection), so that a stream sent smaller for its link, the encoders or the video memory has its pixels drawn
  /// at its size. 1: the scene's size. The sort-last source (distributed/) draws at it on every rank too.
  double outputScale = 1;
  /// The session speaks proto::kProvisionalAsDrawnVersion: a provisional frame in a still encoding is returned at the
  /// size it was drawn (render::FrameOptions::keepReducedSize), not scaled up to the scene's, and its client shows it
  /// scaled. Fewer bytes to encode and send: a 1024² frame drawn at a quarter of its sides is a 256² JPEG.
  bool provisionalAsDrawn = false;
};

/// Links measured slower than this (kbit/s) get png frames encoded Small, faster or unmeasured ones Fast: on the MRI
/// Fast saves 56 ms of a 1024² frame's encoding for 18 KB more (15 ms at 10 Mbit/s); on a flat picture it saves
/// 14 ms of a 512² frame's for 18 KB, about even at 10 Mbit/s (bench/results/image/png-speed.md).
inline constexpr double kSmallPngBelowKbps = 10000;
/// The png speed for a session whose link's rate is `linkKbps` (LinkPacer::settledLinkKbps: none until something
/// measured it, as while the link keeps up with every frame).
inline image::PngSpeed pngSpeedFor(std::optional<double> linkKbps) {
  return linkKbps && *linkKbps < kSmallPngBelowKbps ? image::PngSpeed::Small : image::PngSpeed::Fast;
}

/// Links measured slower than this (kbit/s) get a png frame as lossless webp where the client accepts it
/// (`accepts_webp`). webp takes 0.44-0.56 of a fast png's bytes on the MRI's frames, for 13-141 ms more encoding and
/// 3-24 ms more decoding in Chromium: it reaches the canvas first below 12 to 28 Mbit/s, by frame (1920x1080 the
/// lowest; the MRI at 1024², 19), and at 10 Mbit/s first for every frame measured (bench/results/image/png-speed.md).
inline constexpr double kWebpBelowKbps = 12000;
/// Whether a session whose link's rate is `linkKbps` (LinkPacer::settledLinkKbps: none until something measured it)
/// gets its png frames as webp, if its scene accepts them.
inline bool webpFor(std::optional<double> linkKbps) { return linkKbps && *linkKbps < kWebpBelowKbps; }

/// The class the scheduler serves `job` in: batch for a scene with "batch", else interactive for a moving camera's
/// frame (an interactive scene's first drawing) and for the frame that ends a drag (endsDrag), else still (another
/// plain Render, or the exact frame of a progressive one).
inline FrameClass frameClassOf(const RenderJob& job) {
  if (job.scene.batch) return FrameClass::Batch;
  return (job.scene.interactive && !job.refinement) || job.endsDrag ? FrameClass::Interactive : FrameClass::Still;
}

/// The encoding of a Frame answering `job`: the provisional encoding for a provisional Frame (one the exact frame is
/// to follow), the request's own for an exact one; webp in place of png where the job says so (webpForPng).
proto::Encoding replyEncoding(const RenderJob& job, bool provisional);

/// The JPEG quality of a Frame answering `job`: a provisional Frame's may be lowered under a crowd
/// (provisionalJpegQuality: quality yields first); otherwise the scene's, else image::kDefaultJpegQuality. A
/// provisional Frame of `width` x `height` smaller than its scene (sent as drawn) gets kAsDrawnJpegQualityRaise more.
int replyJpegQuality(const RenderJob& job, bool provisional, int width = 0, int height = 0);
/// A provisional JPEG frame sent at the size it was drawn, smaller than its scene (RenderJob::provisionalAsDrawn), is
/// encoded this much above replyJpegQuality's, at most kAsDrawnJpegQualityMax: scaled up by its client, its losses
/// grow with it. On the MRI at 512², drawn at 64² to 256² (bench/results/jpeg/as-drawn.md), against the exact
/// frame: sent as drawn at q95, 0.10-0.17 dB below the drawing scaled up first and sent at q85, in 0.17-0.73 of its
/// bytes (at q85 as drawn, 0.2-0.5 dB below); at q80, 0.25-0.35 dB below q70's scaled up, in 0.15-0.51 of its bytes.
inline constexpr int kAsDrawnJpegQualityRaise = 10, kAsDrawnJpegQualityMax = 95;

/// The body bytes of a Frame: width, height, encoding, and the two length-prefixed fields.
uint64_t frameBodyBytes(size_t statsBytes, size_t payloadBytes);

/// What the render queue did with a submitted job.
struct Submission {
  enum class Result {
    Queued,   ///< it waits for a render thread
    Full,     ///< the session has ServerConfig::kMaxQueuedWithoutCoalescing jobs waiting (only without coalescing)
    Stopped,  ///< the server is stopping: it will never be rendered
    Busy,     ///< a batch job or a first drag over capacity, or past a quota: retry after retryAfterMs
  };
  Result result = Result::Queued;
  uint32_t retryAfterMs = 0;  ///< with Busy
  std::string why;            ///< with Busy: what is over capacity
  bool quota = false;         ///< with Busy: a quota of its address or token, not the scheduler's capacity
  std::optional<RenderJob> replaced;  ///< the session's waiting job this one replaced (latest wins)
};

/// A render thread's answer to a job.
struct RenderReply {
  proto::Message message;    ///< a Frame or an Error
  bool provisional = false;  ///< a Frame drawn with stand-ins: the exact one is to follow (a refinement job)
  bool cancelled = false;    ///< given up part way (`cancelled` said so): nobody is to get `message`
  /// The frame's estimated samples and the ms it took to draw (FrameStats samplesEstimated and msTotal), for the
  /// session's rate; 0 when nothing was drawn.
  double samples = 0, ms = 0;
  /// The frame's one-time work on its context (FrameStats::msWarmup: a renderer made, programs built), which the
  /// scheduler charges to no session.
  double warmupMs = 0;
  /// A still Frame left with its RGBA8 pixels (RenderJob::encodeAside): the JPEG quality to encode it at.
  std::optional<int> stillToEncode = std::nullopt;
};

/// `statsJson` (a JSON object's text) with `"key": value` (JSON text) added at its end; unchanged if it is not an
/// object. A frame's statistics gain a key without being parsed again.
std::string withKey(std::string statsJson, std::string_view key, std::string_view value);

/// Encodes a still Frame of `job` whose payload is its RGBA8 pixels into its encoding (png at the job's pngSpeed, jpeg
/// at `jpegQuality`, webp, zstd_rgba8, raw_rgba8) and adds encode_ms (and a png's png_speed, "fast" or "small") to its
/// statistics, and encode_start_ms (the encoding's start after the job's Render arrived). A png whose body exceeds
/// the job's maxBodyBytes goes as lossless webp where its scene says `accepts_webp` (the same pixels in about half the
/// bytes; its statistics say `"webp_for_size": true`); answers LimitExceeded instead when the encoded body still
/// exceeds it, or the Error naming an encoding failure. Throws nothing but std::bad_alloc.
proto::Message encodeStill(proto::Frame frame, int jpegQuality, const RenderJob& job);

/// Renders `job` with `source` (current on this thread) and encodes it (a frame in a video encoding, vp8 or vp9, keeps
/// its raw RGBA8 pixels as its payload: the session's VideoStream encodes it in order and checks its size; its stats
/// then lack encode_ms; so does a still frame of a job with encodeAside, but raw_rgba8, whose reply says
/// stillToEncode): a Frame whose statistics add
/// queue_ms, encode_ms, render_thread (`thread`) and provisional to the renderer's, or the Error that errorReply
/// makes of what the renderer threw. A progressive scene's first frame is drawn with stand-ins (provisional when
/// any brick stood in); an interactive scene's frame is drawn within its time budget at job.rateSamplesPerMs and is
/// provisional; a refinement is drawn exactly. A frame above job.maxSamples is answered LimitExceeded
/// before anything is drawn; `cancelled` (may be empty) is asked between batches and slabs, and gives the frame up.
/// Throws nothing but std::bad_alloc.
RenderReply renderReply(render::FrameSource& source, const RenderJob& job, int thread,
                        const std::function<bool()>& cancelled = {});

/// Pages ahead of a drag: when `job` moved the camera from its previous one, asks `source` to page ahead for the next
/// camera along the same motion (the camera extrapolated one step; FrameSource::prefetch, which for a grid queues on
/// its host cache the bricks that frame would draw, fitted to the budget it will be fitted to). Advisory: does
/// nothing for a camera that did not move, and never throws.
void prefetchAhead(render::FrameSource& source, const RenderJob& job);

}  // namespace voxbrick::server
