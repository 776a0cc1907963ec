// VP8 and VP9 through libvpx in its realtime mode: one pass, constant bitrate (the server's; bench_video compares VBR),
// no lag, no dropped frames, key frames only when asked (a reliable stream never needs a periodic one); colour through
// libyuv.
#include "image/Video.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <libyuv/convert.h>
#include <libyuv/convert_argb.h>
#include <libyuv/convert_from_argb.h>
#include <vpx/vp8cx.h>
#include <vpx/vp8dx.h>
#include <vpx/vpx_decoder.h>
#include <vpx/vpx_encoder.h>

namespace voxbrick::image {
namespace {

constexpr int kMaxSide = VideoDecoder::kMaxSide;

std::string codecName(proto::Encoding codec) { return proto::encodingName(codec); }

void check(vpx_codec_err_t status, vpx_codec_ctx_t* ctx, const std::string& what) {
  if (status == VPX_CODEC_OK) return;
  std::string detail = vpx_codec_err_to_string(status);
  if (ctx) {
    if (const char* more = vpx_codec_error_detail(ctx)) detail += std::string(": ") + more;
  }
  throw ImageFailure(what + ": " + detail);
}

}  // namespace

bool isVideoEncoding(proto::Encoding encoding) {
  return encoding == proto::Encoding::Vp8 || encoding == proto::Encoding::Vp9;
}

struct VideoEncoder::Codec {
  vpx_codec_ctx_t ctx{};
  vpx_codec_enc_cfg_t cfg{};
  vpx_image_t image{};
  std::vector<uint8_t> argb;  ///< a frame in libyuv's ARGB order, on the way to 4:4:4
  bool initialised = false;
  ~Codec() {
    if (initialised) vpx_codec_destroy(&ctx);
    vpx_img_free(&image);
  }
};

int videoThreadsFor(proto::Encoding codec, int width, int height, int available) {
  if (codec == proto::Encoding::Vp8) return 1;
  const int64_t pixels = int64_t(std::max(1, width)) * std::max(1, height);
  const int wanted = int((pixels + 512 * 512 - 1) / (512 * 512));
  return std::clamp(wanted, 1, std::clamp(available, 1, 8));
}

uint64_t videoEncoderBytes(proto::Encoding codec, int width, int height, int threads, bool fullChroma) {
  // Fitted to bench_stream_start's held_mib (bench/results/video/encoder-memory.md), each within 6 % from 256x256 to
  // 2048x2048: VP8 (one thread, the server's) 0.5 MiB and 46 bytes a pixel; VP9 12 MiB with its first thread,
  // 7.5 MiB for each further one (its tile workers' buffers) and 80 bytes a pixel (frame buffers for eight
  // references, scaled copies, the cyclic refresh's maps); VP9 in 4:4:4 104 bytes a pixel (its colour planes four
  // times as large; 0.91-1.03 of what it held from 256x256 to 2048x2048). VP8's threads, which the server does not
  // use, are counted as VP9's.
  constexpr uint64_t kMiB = 1 << 20;
  const uint64_t pixels = uint64_t(std::max(1, width)) * uint64_t(std::max(1, height));
  const uint64_t extraThreads = uint64_t(std::max(1, threads) - 1);
  if (codec == proto::Encoding::Vp8) return kMiB / 2 + 46 * pixels + extraThreads * 15 * kMiB / 2;
  return 12 * kMiB + (fullChroma ? 104 : 80) * pixels + extraThreads * 15 * kMiB / 2;
}

int startQuantizerFor(double bitsPerPixel) {
  if (!(bitsPerPixel > 0)) return kVideoMaxQuantizer;
  const double q = 40 - 10 * std::log2(bitsPerPixel / 0.09);
  return int(std::lround(std::clamp(q, double(kVideoStartQuantizerFloor), double(kVideoMaxQuantizer))));
}

VideoEncoder::VideoEncoder(proto::Encoding codec, const VideoSettings& settings)
    : mCodec(codec), mSettings(settings), mCodecState(std::make_unique<Codec>()) {
  if (!isVideoEncoding(codec))
    throw ImageFailure("video: " + codecName(codec) + " is not a video codec (vp8 or vp9)");
  if (settings.width < 1 || settings.height < 1 || settings.width > kMaxSide || settings.height > kMaxSide)
    throw ImageFailure("video: size " + std::to_string(settings.width) + "x" + std::to_string(settings.height) +
                       " is outside 1.." + std::to_string(kMaxSide) + " a side");
  if (settings.bitrateKbps < 1) throw ImageFailure("video: bitrate must be at least 1 kbit/s");
  if (settings.startFrames < 0) throw ImageFailure("video: start frames must be at least 0");
  if (!(settings.maxFrameMs >= 0)) throw ImageFailure("video: the most time a frame is reckoned over must be at least 0");
  if (settings.aqMode < 0 || settings.aqMode > 3)
    throw ImageFailure("video: adaptive quantisation mode " + std::to_string(settings.aqMode) + " is outside 0..3");
  const bool vp9 = codec == proto::Encoding::Vp9;
  if (settings.fullChroma && !vp9) throw ImageFailure("video: 4:4:4 colour is VP9's only");
  vpx_codec_iface_t* iface = vp9 ? vpx_codec_vp9_cx() : vpx_codec_vp8_cx();
  Codec& c = *mCodecState;
  check(vpx_codec_enc_config_default(iface, &c.cfg, 0), nullptr, "video: " + codecName(codec) + " defaults");
  c.cfg.g_profile = settings.fullChroma ? 1 : 0;
  c.cfg.g_w = unsigned(settings.width);
  c.cfg.g_h = unsigned(settings.height);
  c.cfg.g_timebase = {1, 1000};  // timestamps in milliseconds
  c.cfg.g_threads = unsigned(std::max(1, settings.threads));
  c.cfg.g_lag_in_frames = 0;  // each frame comes out as it goes in
  c.cfg.g_pass = VPX_RC_ONE_PASS;
  c.cfg.g_error_resilient = 0;  // the stream is reliable (TCP): no frame is lost
  c.cfg.rc_end_usage = settings.constantBitrate ? VPX_CBR : VPX_VBR;
  c.cfg.rc_target_bitrate = unsigned(settings.bitrateKbps);
  c.cfg.rc_dropframe_thresh = 0;  // never drop a frame: a dropped one would be a frame the client waits for
  c.cfg.rc_min_quantizer = kVideoMinQuantizer;
  c.cfg.rc_max_quantizer = kVideoMaxQuantizer;
  c.cfg.rc_undershoot_pct = 50;
  c.cfg.rc_overshoot_pct = 50;
  // A short buffer: the rate control answers within about half a second, so a frame never waits for bits.
  c.cfg.rc_buf_initial_sz = 300;
  c.cfg.rc_buf_optimal_sz = 400;
  c.cfg.rc_buf_sz = 600;
  c.cfg.kf_mode = VPX_KF_DISABLED;  // key frames when asked only
  check(vpx_codec_enc_init(&c.ctx, iface, &c.cfg, 0), nullptr, "video: " + codecName(codec) + " encoder");
  c.initialised = true;
  const std::string what = "video: " + codecName(codec) + " settings";
  if (vp9) {
    check(vpx_codec_control(&c.ctx, VP8E_SET_CPUUSED, std::clamp(settings.speed, 5, 9)), &c.ctx, what);
    check(vpx_codec_control(&c.ctx, VP9E_SET_AQ_MODE, settings.aqMode), &c.ctx, what);
    check(vpx_codec_control(&c.ctx, VP9E_SET_ROW_MT, 1), &c.ctx, what);
    // Tile columns (log2; libvpx keeps each at least 256 pixels wide), one a thread.
    const int tiles = settings.threads >= 4 ? 2 : settings.threads >= 2 ? 1 : 0;
    check(vpx_codec_control(&c.ctx, VP9E_SET_TILE_COLUMNS, tiles), &c.ctx, what);
  } else {
    // libvpx's VP8 in realtime: a positive value lets it choose the speed frame by frame, a negative one fixes it.
    const int speed = std::clamp(settings.speed, 4, 16);
    check(vpx_codec_control(&c.ctx, VP8E_SET_CPUUSED, settings.adaptiveSpeed ? speed : -speed), &c.ctx, what);
    check(vpx_codec_control(&c.ctx, VP8E_SET_NOISE_SENSITIVITY, 0), &c.ctx, what);
    // Token partitions (1, 2, 4 or 8; log2 here) let the threads pack a frame's rows side by side.
    const int partitions = settings.threads >= 8 ? 3 : settings.threads >= 4 ? 2 : settings.threads >= 2 ? 1 : 0;
    check(vpx_codec_control(&c.ctx, VP8E_SET_TOKEN_PARTITIONS, partitions), &c.ctx, what);
  }
  // A key frame may take at most three frames' worth of bits, so it does not stall the link.
  check(vpx_codec_control(&c.ctx, VP8E_SET_MAX_INTRA_BITRATE_PCT, 300), &c.ctx, what);
  check(vpx_codec_control(&c.ctx, VP8E_SET_STATIC_THRESHOLD, 0), &c.ctx, what);
  if (!vpx_img_alloc(&c.image, settings.fullChroma ? VPX_IMG_FMT_I444 : VPX_IMG_FMT_I420, c.cfg.g_w, c.cfg.g_h, 16))
    throw ImageFailure("video: no memory for a " + std::to_string(settings.width) + "x" +
                       std::to_string(settings.height) + " frame");
}

VideoEncoder::~VideoEncoder() = default;

void VideoEncoder::setBitrate(int kbps) {
  kbps = std::max(1, kbps);
  if (kbps == mSettings.bitrateKbps) return;
  Codec& c = *mCodecState;
  c.cfg.rc_target_bitrate = unsigned(kbps);
  check(vpx_codec_enc_config_set(&c.ctx, &c.cfg), &c.ctx, "video: bitrate " + std::to_string(kbps));
  mSettings.bitrateKbps = kbps;
}

VideoChunk VideoEncoder::encode(const Image8& image, double timeMs, bool key) {
  if (image.width != mSettings.width || image.height != mSettings.height ||
      image.rgba.size() != size_t(image.width) * size_t(image.height) * 4)
    throw ImageFailure("video: a " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                       " image in a stream of " + std::to_string(mSettings.width) + "x" +
                       std::to_string(mSettings.height));
  Codec& c = *mCodecState;
  vpx_image_t& yuv = c.image;
  // libyuv's "ABGR" is R, G, B, A in memory: our Image8.
  if (mSettings.fullChroma) {
    // libyuv turns only its "ARGB" (B, G, R, A in memory) into 4:4:4.
    c.argb.resize(image.rgba.size());
    libyuv::ABGRToARGB(image.rgba.data(), image.width * 4, c.argb.data(), image.width * 4, image.width, image.height);
    libyuv::ARGBToI444(c.argb.data(), image.width * 4, yuv.planes[VPX_PLANE_Y], yuv.stride[VPX_PLANE_Y],
                       yuv.planes[VPX_PLANE_U], yuv.stride[VPX_PLANE_U], yuv.planes[VPX_PLANE_V],
                       yuv.stride[VPX_PLANE_V], image.width, image.height);
  } else {
    libyuv::ABGRToI420(image.rgba.data(), image.width * 4, yuv.planes[VPX_PLANE_Y], yuv.stride[VPX_PLANE_Y],
                       yuv.planes[VPX_PLANE_U], yuv.stride[VPX_PLANE_U], yuv.planes[VPX_PLANE_V],
                       yuv.stride[VPX_PLANE_V], image.width, image.height);
  }
  // Strictly increasing timestamps; each frame's duration is the time to the one before (at least 1 ms, at most
  // maxFrameMs where that is set).
  timeMs = std::max(0.0, timeMs);
  if (mLastPts < 0) {
    mStreamMs = timeMs;
  } else {
    const double gap = std::max(0.0, timeMs - mLastTimeMs);
    mStreamMs += mSettings.maxFrameMs > 0 ? std::min(gap, mSettings.maxFrameMs) : gap;
  }
  mLastTimeMs = timeMs;
  const int64_t pts = std::max<int64_t>(mLastPts + 1, int64_t(std::llround(mStreamMs)));
  const unsigned long duration = mLastPts < 0 ? 33 : (unsigned long)std::max<int64_t>(1, pts - mLastPts);
  const vpx_enc_frame_flags_t flags = key || mFrames == 0 ? VPX_EFLAG_FORCE_KF : 0;
  // The stream's start (VideoSettings::startFrames). Bytes a millisecond: kbit/s / 8.
  const double bytesPerMs = mSettings.bitrateKbps / 8.0, frameBytes = bytesPerMs * 1000.0 / 30.0;
  if (mFrames == 0) {
    const double bitsPerPixel = frameBytes * 8.0 / (double(mSettings.width) * double(mSettings.height));
    mStart = {pts, 0, 0, mSettings.startFrames > 0 ? startQuantizerFor(bitsPerPixel) : kVideoMaxQuantizer};
  } else if (mStart.frames < mSettings.startFrames && mStart.quantizer < kVideoMaxQuantizer) {
    const double share = bytesPerMs * double(pts - mStart.pts);
    if (mStart.bytes > share + 2 * frameBytes)
      mStart.quantizer = kVideoMaxQuantizer;
    else if (mStart.bytes < share)
      mStart.quantizer = std::max(kVideoStartQuantizerFloor, mStart.quantizer - 4);
  }
  const unsigned maxQuantizer =
      unsigned(mStart.frames < mSettings.startFrames ? mStart.quantizer : kVideoMaxQuantizer);
  if (maxQuantizer != c.cfg.rc_max_quantizer) {
    c.cfg.rc_max_quantizer = maxQuantizer;
    check(vpx_codec_enc_config_set(&c.ctx, &c.cfg), &c.ctx,
          "video: quantizer at most " + std::to_string(maxQuantizer));
  }
  check(vpx_codec_encode(&c.ctx, &yuv, pts, duration, flags, VPX_DL_REALTIME), &c.ctx,
        "video: " + codecName(mCodec) + " encoding");
  mLastPts = pts;
  VideoChunk chunk;
  vpx_codec_iter_t iter = nullptr;
  while (const vpx_codec_cx_pkt_t* packet = vpx_codec_get_cx_data(&c.ctx, &iter)) {
    if (packet->kind != VPX_CODEC_CX_FRAME_PKT) continue;
    const auto* bytes = static_cast<const uint8_t*>(packet->data.frame.buf);
    chunk.bytes.insert(chunk.bytes.end(), bytes, bytes + packet->data.frame.sz);
    chunk.key = chunk.key || (packet->data.frame.flags & VPX_FRAME_IS_KEY) != 0;
  }
  if (chunk.bytes.empty())  // cannot happen with no lag and no frame dropping; a stream must not skip a frame
    throw ImageFailure("video: " + codecName(mCodec) + " put out no frame");
  ++mFrames;
  if (mStart.frames < mSettings.startFrames) {
    mStart.bytes += double(chunk.bytes.size());
    ++mStart.frames;
  }
  return chunk;
}

int VideoEncoder::maxQuantizer() const { return int(mCodecState->cfg.rc_max_quantizer); }

struct VideoDecoder::Codec {
  vpx_codec_ctx_t ctx{};
  bool initialised = false;
  ~Codec() {
    if (initialised) vpx_codec_destroy(&ctx);
  }
};

VideoDecoder::VideoDecoder(proto::Encoding codec) : mCodec(codec), mCodecState(std::make_unique<Codec>()) {
  if (!isVideoEncoding(codec))
    throw ImageFailure("video: " + codecName(codec) + " is not a video codec (vp8 or vp9)");
  vpx_codec_dec_cfg_t cfg{};
  cfg.threads = 1;
  check(vpx_codec_dec_init(&mCodecState->ctx, codec == proto::Encoding::Vp9 ? vpx_codec_vp9_dx() : vpx_codec_vp8_dx(),
                           &cfg, 0),
        nullptr, "video: " + codecName(codec) + " decoder");
  mCodecState->initialised = true;
}

VideoDecoder::~VideoDecoder() = default;

Image8 VideoDecoder::decode(std::span<const uint8_t> chunk) {
  vpx_codec_ctx_t& ctx = mCodecState->ctx;
  const std::string what = "video: " + codecName(mCodec) + " frame of " + std::to_string(chunk.size()) + " bytes";
  if (chunk.empty()) throw ImageFailure(what + ": empty");
  // libvpx reads the size from the frame's header before it allocates: check it first where the codec lets us.
  vpx_codec_stream_info_t info{};
  info.sz = sizeof(info);
  if (vpx_codec_peek_stream_info(mCodec == proto::Encoding::Vp9 ? vpx_codec_vp9_dx() : vpx_codec_vp8_dx(),
                                 chunk.data(), unsigned(chunk.size()), &info) == VPX_CODEC_OK &&
      info.is_kf && (info.w > unsigned(kMaxSide) || info.h > unsigned(kMaxSide)))
    throw ImageFailure(what + ": size " + std::to_string(info.w) + "x" + std::to_string(info.h) + " above " +
                       std::to_string(kMaxSide) + " a side");
  check(vpx_codec_decode(&ctx, chunk.data(), unsigned(chunk.size()), nullptr, 0), &ctx, what);
  vpx_codec_iter_t iter = nullptr;
  const vpx_image_t* yuv = vpx_codec_get_frame(&ctx, &iter);
  if (!yuv) throw ImageFailure(what + ": no image (a delta frame before any key frame?)");
  if (yuv->fmt != VPX_IMG_FMT_I420 && yuv->fmt != VPX_IMG_FMT_I444)
    throw ImageFailure(what + ": not 8-bit 4:2:0 or 4:4:4");
  if (yuv->d_w < 1 || yuv->d_h < 1 || yuv->d_w > unsigned(kMaxSide) || yuv->d_h > unsigned(kMaxSide))
    throw ImageFailure(what + ": size " + std::to_string(yuv->d_w) + "x" + std::to_string(yuv->d_h));
  Image8 image{int(yuv->d_w), int(yuv->d_h), {}};
  image.rgba.resize(size_t(image.width) * size_t(image.height) * 4);
  const auto toRgba = yuv->fmt == VPX_IMG_FMT_I444 ? libyuv::I444ToABGR : libyuv::I420ToABGR;
  toRgba(yuv->planes[VPX_PLANE_Y], yuv->stride[VPX_PLANE_Y], yuv->planes[VPX_PLANE_U], yuv->stride[VPX_PLANE_U],
         yuv->planes[VPX_PLANE_V], yuv->stride[VPX_PLANE_V], image.rgba.data(), image.width * 4, image.width,
         image.height);
  return image;
}

Image8 FrameDecoder::decode(const proto::Frame& frame) {
  if (!isVideoEncoding(frame.encoding)) return decodeFrameImage(frame);
  if (!mVideo || mVideo->codec() != frame.encoding) mVideo = std::make_unique<VideoDecoder>(frame.encoding);
  Image8 image = mVideo->decode(frame.payload);
  if (image.width != int(frame.width) || image.height != int(frame.height))
    throw ImageFailure("frame: the " + codecName(frame.encoding) + " frame decodes to " + std::to_string(image.width) +
                       "x" + std::to_string(image.height) + ", not the frame's " + std::to_string(frame.width) + "x" +
                       std::to_string(frame.height));
  ++mVideoFrames;
  return image;
}

}  // namespace voxbrick::image
