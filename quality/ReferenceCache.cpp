// Reference frames cached on disk, keyed by what the reference renderer's frame depends on.
#include "quality/ReferenceCache.h"

#include <cstdio>
#include <fstream>
#include <functional>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "brickstore/read/BrickCache.h"
#include "quality/SweepSpec.h"

namespace voxbrick::quality {
namespace fs = std::filesystem;

namespace {

/// The scene as the reference renderer sees it: without the GPU renderer's drawing settings (which it ignores), so
/// that a cache made before they existed stays valid.
std::string referenceJson(const render::Scene& scene) {
  nlohmann::json j = nlohmann::json::parse(scene.toJson());
  // How the GPU draws does not change the reference's frame.
  for (const char* key : {"slab", "raycast", "ert", "pre_integration", "sub_block", "slicer"}) j.erase(key);
  return j.dump(2);
}

/// Reads the frame cached at `path` under `key` into `image` (sized already); false if it is missing or stale.
bool readCached(const fs::path& path, const std::string& key, image::ImageF& image) {
  std::ifstream in{path, std::ios::binary};
  if (!in) return false;
  std::string header(key.size(), '\0');
  in.read(header.data(), std::streamsize(header.size()));
  in.read(reinterpret_cast<char*>(image.rgba.data()), std::streamsize(image.rgba.size() * sizeof(float)));
  return in && header == key && in.peek() == std::char_traits<char>::eof();
}

void writeCached(const fs::path& path, const std::string& key, const image::ImageF& image) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(key.data(), std::streamsize(key.size()));
  out.write(reinterpret_cast<const char*>(image.rgba.data()), std::streamsize(image.rgba.size() * sizeof(float)));
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

}  // namespace

ReferenceCache::ReferenceCache(fs::path dir, std::shared_ptr<const store::BrickStore> s, size_t budget)
    : mDir(std::move(dir)), mStore(std::move(s)), mRenderer(std::make_shared<store::BrickCache>(mStore, budget, 2)) {
  fs::create_directories(mDir);
}

image::ImageF ReferenceCache::get(const render::Scene& scene, double step, double* msRendered) {
  const std::string key = "voxbrick-reference 2\n" + mStore->meta().source + "\n" + referenceJson(scene) + "\nstep " +
                          stepText(step) + "\n";
  char name[64];
  std::snprintf(name, sizeof name, "%016zx.ref", std::hash<std::string>{}(key));
  const fs::path path = mDir / name;
  image::ImageF image{scene.width, scene.height, std::vector<float>(size_t(scene.width) * size_t(scene.height) * 4)};
  if (readCached(path, key, image)) return image;
  render::ReferenceOptions options;
  options.step = step;
  render::ReferenceStats stats;
  image = mRenderer.render(scene, options, &stats);
  if (msRendered) *msRendered = stats.ms;
  writeCached(path, key, image);
  return image;
}

}  // namespace voxbrick::quality
