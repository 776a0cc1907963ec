// A render thread's work for one job: render, encode, add the server's timings.
#include "server/RenderJob.h"

#include <string>

#include <nlohmann/json.hpp>

#include "server/ErrorReply.h"
#include "image/FrameImage.h"

namespace voxbrick::server {
namespace {

using Clock = std::chrono::steady_clock;

double msBetween(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

}  // namespace

proto::Message renderReply(render::RenderEngine& engine, const RenderJob& job, int thread) {
  const auto start = Clock::now();
  try {
    render::FrameStats stats;
    const image::ImageF image = engine.render(job.dataset, job.scene, &stats);
    const auto encodeStart = Clock::now();
    proto::Frame frame;
    frame.width = uint32_t(image.width);
    frame.height = uint32_t(image.height);
    frame.encoding = job.encoding;
    frame.payload = image::encodeFrameImage(image::toImage8(image), job.encoding);
    nlohmann::json statsJson = stats.toJson();
    statsJson["queue_ms"] = msBetween(job.received, start);
    statsJson["encode_ms"] = msBetween(encodeStart, Clock::now());
    statsJson["render_thread"] = thread;
    frame.statsJson = statsJson.dump();
    return frame;
  } catch (...) {
    return errorReply(std::current_exception(),
                      "render of request " + std::to_string(job.requestId) + " on '" +
                          (job.dataset ? job.dataset->name() : std::string("no dataset")) + "' failed");
  }
}

}  // namespace voxbrick::server
