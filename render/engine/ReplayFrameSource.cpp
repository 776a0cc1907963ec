// The frame source that replays frames drawn beforehand.
#include "render/engine/ReplayFrameSource.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <thread>

#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include "render/core/Camera.h"
#include "render/core/RenderErrors.h"

namespace voxbrick::render {

namespace fs = std::filesystem;

namespace {

/// The unit direction from what `camera` looks at to its eye.
glm::dvec3 eyeDirection(const CameraSpec& camera) {
  if (camera.orbit) return OrbitAxes::of(camera.upAxis).eyeDirection(camera.azimuth, camera.elevation);
  const glm::dvec3 d = camera.eye - camera.center;
  const double length = glm::length(d);
  return length > 0 ? d / length : glm::dvec3(0, 0, 1);
}

}  // namespace

ReplayFrames::ReplayFrames(const fs::path& dir) : mDir(dir) {
  const fs::path indexPath = dir / "replay.json";
  std::ifstream in(indexPath);
  if (!in) throw RenderInputError(indexPath.string() + ": cannot be read (a replay directory holds replay.json)");
  nlohmann::json index;
  try {
    index = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw RenderInputError(indexPath.string() + ": not JSON (" + e.what() + ")");
  }
  if (!index.is_object() || !index.contains("frames") || !index["frames"].is_array() || index["frames"].empty())
    throw RenderInputError(indexPath.string() + ": 'frames' must be a list of at least one frame");
  for (size_t i = 0; i < index["frames"].size(); ++i) {
    const nlohmann::json& f = index["frames"][i];
    const std::string where = indexPath.string() + ": frame " + std::to_string(i);
    if (!f.is_object() || !f.contains("file") || !f["file"].is_string())
      throw RenderInputError(where + ": 'file' must name a PNG in the directory");
    Frame frame;
    frame.file = dir / f["file"].get<std::string>();
    for (const char* key : {"azimuth", "elevation"}) {
      if (!f.contains(key) || !f[key].is_number() || !std::isfinite(f[key].get<double>()))
        throw RenderInputError(where + ": '" + key + "' must be a finite number of degrees");
    }
    frame.azimuth = f["azimuth"].get<double>();
    frame.elevation = f["elevation"].get<double>();
    frame.direction = OrbitAxes::of(UpAxis::PosZ).eyeDirection(frame.azimuth, frame.elevation);
    if (!fs::is_regular_file(frame.file)) throw RenderInputError(where + ": " + frame.file.string() + " does not exist");
    mFrames.push_back(std::move(frame));
  }
  // Every frame decoded now, on all cores: decoding one while a frame is asked for would be drawing time and CPU
  // that the machine the replay stands for does not spend.
  mPixels.resize(mFrames.size());
  std::vector<std::string> failures(mFrames.size());
  std::atomic<size_t> next{0};
  const auto decode = [&] {
    for (size_t i = next++; i < mFrames.size(); i = next++) {
      try {
        auto image = std::make_shared<image::Image8>(image::readPng(mFrames[i].file));
        mFrames[i].width = image->width;
        mFrames[i].height = image->height;
        mPixels[i] = std::move(image);
      } catch (const std::exception& e) {
        failures[i] = indexPath.string() + ": frame " + std::to_string(i) + ": " + e.what();
      }
    }
  };
  std::vector<std::thread> threads;
  const size_t helpers = std::min<size_t>(std::max(1u, std::thread::hardware_concurrency()), mFrames.size()) - 1;
  for (size_t t = 0; t < helpers; ++t) threads.emplace_back(decode);
  decode();
  for (std::thread& t : threads) t.join();
  for (const std::string& failure : failures)
    if (!failure.empty()) throw RenderInputError(failure);
}

size_t ReplayFrames::nearest(const CameraSpec& camera, int width, int height) const {
  const glm::dvec3 wanted = eyeDirection(camera);
  const bool sized = std::any_of(mFrames.begin(), mFrames.end(),
                                 [&](const Frame& f) { return f.width == width && f.height == height; });
  size_t best = 0;
  double bestCos = -2;
  for (size_t i = 0; i < mFrames.size(); ++i) {
    if (sized && (mFrames[i].width != width || mFrames[i].height != height)) continue;
    const double c = glm::dot(wanted, mFrames[i].direction);
    if (c > bestCos) {
      bestCos = c;
      best = i;
    }
  }
  return best;
}

std::shared_ptr<const image::Image8> ReplayFrames::pixels(size_t index) const { return mPixels.at(index); }

ReplayFrameSource::ReplayFrameSource(std::shared_ptr<const ReplayFrames> frames, std::chrono::microseconds drawTime)
    : mFrames(std::move(frames)), mDrawTime(drawTime) {}

std::string ReplayFrameSource::describe() const {
  char ms[32];
  std::snprintf(ms, sizeof ms, "%.1f", double(mDrawTime.count()) / 1000.0);
  return "replay of " + std::to_string(mFrames->frames().size()) + " frames from " + mFrames->dir().string() + ", " +
         ms + " ms a frame (draws nothing)";
}

image::Image8 ReplayFrameSource::render8(const std::shared_ptr<const Dataset>& dataset, const Scene& scene,
                                         FrameStats* stats, const FrameOptions& options) {
  const double samples = checkedPixelSamples(dataset, scene, options);
  const auto start = std::chrono::steady_clock::now();
  const std::shared_ptr<const image::Image8> stored =
      mFrames->pixels(mFrames->nearest(scene.camera, scene.width, scene.height));
  spendDrawingTime(start + mDrawTime, options);
  image::Image8 out;
  if (stored->width == scene.width && stored->height == scene.height) {
    out = *stored;
  } else {
    // Nearest pixel: the benchmarks ask for the stored size; another size (a thumbnail) only needs to be a picture.
    out.width = scene.width;
    out.height = scene.height;
    out.rgba.resize(size_t(scene.width) * size_t(scene.height) * 4);
    for (int y = 0; y < scene.height; ++y) {
      const int sy = std::min(stored->height - 1, int((y + 0.5) * stored->height / scene.height));
      for (int x = 0; x < scene.width; ++x) {
        const int sx = std::min(stored->width - 1, int((x + 0.5) * stored->width / scene.width));
        const uint8_t* from = stored->rgba.data() + 4 * (size_t(sy) * size_t(stored->width) + size_t(sx));
        std::copy(from, from + 4, out.rgba.data() + 4 * (size_t(y) * size_t(scene.width) + size_t(x)));
      }
    }
  }
  const double ms = msSince(start);
  if (stats) {
    *stats = {};
    stats->samplesEstimated = samples;
    stats->msTotal = ms;
    // A moving camera's frame is drawn whole at its size (rung 0), as a GPU would within its budget.
    if (scene.interactive)
      stats->interactive = {{"rung", 0},          {"scale", 1},      {"width", scene.width}, {"height", scene.height},
                            {"budget_ms", scene.timeBudgetMs}, {"predicted_ms", ms}, {"actual_ms", ms}};
  }
  return out;
}

image::ImageF ReplayFrameSource::render(const std::shared_ptr<const Dataset>& dataset, const Scene& scene,
                                        FrameStats* stats, const FrameOptions& options) {
  return image::toImageF(render8(dataset, scene, stats, options));
}

}  // namespace voxbrick::render
