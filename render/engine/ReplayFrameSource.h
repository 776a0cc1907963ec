// A frame source that replays frames drawn beforehand: each frame is the stored frame whose camera is nearest the
// scene's, after a set time of "drawing". What `voxbrick serve --replay-frames DIR` draws with, so that a benchmark
// measures everything a frame goes through but its drawing (the scheduler, the encoders, the link, the browser) on a
// machine whose own drawing is slow, with the drawing time of the machine it stands for (a GPU's). GL-free.
//
// DIR holds the frames (PNG) and `replay.json`:
//   {"frames": [{"file": "1024x1024/f000.png", "azimuth": 30, "elevation": 20}, ...]}
// each frame drawn with the orbit camera (azimuth, elevation) about the world's +z, as `voxbrick orbit` draws them;
// frames of several sizes may be listed. Every dataset gets these frames: the source looks only at the scene's camera
// and size.
#pragma once

#include <chrono>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "render/engine/FrameSource.h"

namespace voxbrick::render {

/// The frames of a replay directory, read and decoded once (held as 8-bit RGBA: 4 bytes a pixel) and shared by the
/// render threads' sources.
class ReplayFrames {
 public:
  /// Reads `dir`/replay.json and decodes every frame it lists; throws RenderInputError naming the file and what is
  /// wrong (no frames, a frame missing or not a PNG, an azimuth or elevation that is not a finite number).
  explicit ReplayFrames(const std::filesystem::path& dir);

  struct Frame {
    std::filesystem::path file;
    double azimuth = 0, elevation = 0;  ///< degrees
    glm::dvec3 direction{0, 0, 1};      ///< from the orbit's centre to the eye (about +z)
    int width = 0, height = 0;
  };
  const std::vector<Frame>& frames() const { return mFrames; }
  const std::filesystem::path& dir() const { return mDir; }

  /// The index of the frame whose view direction is nearest that of `camera` (an orbit's azimuth and elevation, or
  /// the direction from center to eye), by the angle between them, among the frames of `width` x `height` (among
  /// all frames when none has that size).
  size_t nearest(const CameraSpec& camera, int width, int height) const;
  /// Frame `index`'s pixels.
  std::shared_ptr<const image::Image8> pixels(size_t index) const;

 private:
  std::filesystem::path mDir;
  std::vector<Frame> mFrames;
  std::vector<std::shared_ptr<const image::Image8>> mPixels;
};

class ReplayFrameSource final : public FrameSource {
 public:
  /// Every frame takes `drawTime` (slept, cancellable) besides finding and scaling its stored frame.
  ReplayFrameSource(std::shared_ptr<const ReplayFrames> frames, std::chrono::microseconds drawTime);

  std::string describe() const override;
  /// The stored frame nearest the scene's camera at the scene's size (scaled, nearest pixel, where its size differs).
  /// Throws RenderInputError without a dataset, RenderLimitError when width times height is above options.maxSamples,
  /// FrameCancelled when options.cancelled says so.
  image::ImageF render(const std::shared_ptr<const Dataset>& dataset, const Scene& scene, FrameStats* stats = nullptr,
                       const FrameOptions& options = {}) override;
  image::Image8 render8(const std::shared_ptr<const Dataset>& dataset, const Scene& scene, FrameStats* stats = nullptr,
                        const FrameOptions& options = {}) override;

 private:
  std::shared_ptr<const ReplayFrames> mFrames;
  std::chrono::microseconds mDrawTime;
};

}  // namespace voxbrick::render
