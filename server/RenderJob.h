// One accepted Render request on its way to a render thread, what the queue did with it, and how a render thread
// turns it into its reply (a Frame, or an Error).
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>

#include "proto/Messages.h"
#include "render/Dataset.h"
#include "render/RenderEngine.h"
#include "render/Scene.h"

namespace voxbrick::server {

/// A Render request, checked and parsed, waiting for or on a render thread.
struct RenderJob {
  uint32_t requestId = 0;
  proto::Encoding encoding = proto::Encoding::Png;  ///< of the Frame's payload
  render::Scene scene;
  std::shared_ptr<const render::Dataset> dataset;  ///< the one open when the request came
  std::chrono::steady_clock::time_point received;   ///< for queue_ms and the latency statistics
};

/// What the render queue did with a submitted job.
struct Submission {
  enum class Result {
    Queued,   ///< it waits for a render thread
    Full,     ///< the session has ServerConfig::kMaxQueuedWithoutCoalescing jobs waiting (only without coalescing)
    Stopped,  ///< the server is stopping: it will never be rendered
  };
  Result result = Result::Queued;
  std::optional<RenderJob> replaced;  ///< the session's waiting job this one replaced (latest wins)
};

/// Renders `job` on `engine` (its context current on this thread) and encodes it: a Frame whose statistics add
/// queue_ms, encode_ms and render_thread (`thread`) to the renderer's, or the Error that errorReply makes of what
/// the renderer threw. Throws nothing but std::bad_alloc.
proto::Message renderReply(render::RenderEngine& engine, const RenderJob& job, int thread);

}  // namespace voxbrick::server
