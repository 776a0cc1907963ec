// Partial frames of sort-last rendering: active rectangles, the over operator, the serial reference, finishing.
#include "render/core/PartialFrame.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace voxbrick::render {

PixelRect activeRect(const image::ImageF& image) {
  PixelRect r{image.width, image.height, 0, 0};
  for (int y = 0; y < image.height; ++y) {
    const float* row = image.pixel(0, y);
    for (int x = 0; x < image.width; ++x) {
      const float* p = row + 4 * x;
      if (p[0] == 0 && p[1] == 0 && p[2] == 0 && p[3] == 0) continue;
      r.x0 = std::min(r.x0, x), r.x1 = std::max(r.x1, x + 1);
      r.y0 = std::min(r.y0, y), r.y1 = std::max(r.y1, y + 1);
    }
  }
  return r.empty() ? PixelRect{} : r;
}

PixelRect projectedRect(const Camera& camera, const Box& box, int width, int height, int margin) {
  if (width <= 0 || height <= 0) return {};
  const PixelRect whole{0, 0, width, height};
  const glm::dmat4 view = camera.view();
  const glm::dmat4 projection = camera.projection(double(width) / double(height), 1.0, 2.0);  // x and y only
  double lo[2] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  double hi[2] = {-lo[0], -lo[1]};
  for (int c = 0; c < 8; ++c) {
    const glm::dvec3 corner{(c & 1) ? box.max.x : box.min.x, (c & 2) ? box.max.y : box.min.y,
                            (c & 4) ? box.max.z : box.min.z};
    const glm::dvec4 eye = view * glm::dvec4(corner, 1.0);
    if (!camera.orthographic && !(-eye.z > 1e-9 * (1.0 + glm::length(glm::dvec3(eye))))) return whole;
    const glm::dvec4 clip = projection * eye;
    const double px = (clip.x / clip.w + 1.0) * 0.5 * width, py = (1.0 - clip.y / clip.w) * 0.5 * height;
    if (!std::isfinite(px) || !std::isfinite(py)) return whole;
    lo[0] = std::min(lo[0], px), hi[0] = std::max(hi[0], px);
    lo[1] = std::min(lo[1], py), hi[1] = std::max(hi[1], py);
  }
  auto clamped = [](double v, int limit) { return int(std::clamp(v, 0.0, double(limit))); };
  const PixelRect r{clamped(std::floor(lo[0]) - margin, width), clamped(std::floor(lo[1]) - margin, height),
                    clamped(std::ceil(hi[0]) + margin, width), clamped(std::ceil(hi[1]) + margin, height)};
  return r.empty() ? PixelRect{} : r;
}

void compositeOver(image::ImageF& front, const image::ImageF& back) {
  if (front.width != back.width || front.height != back.height || front.rgba.size() != back.rgba.size())
    throw std::invalid_argument("compositeOver: partial frames of different sizes");
  float* f = front.rgba.data();
  const float* b = back.rgba.data();
  for (size_t i = 0; i < front.rgba.size(); i += 4) {
    const float t = 1.0f - f[i + 3];
    for (int c = 0; c < 4; ++c) f[i + c] += t * b[i + c];
  }
}

image::ImageF compositeSerial(const std::vector<image::ImageF>& parts, const std::vector<int>& order) {
  if (order.empty() || order.size() != parts.size())
    throw std::invalid_argument("compositeSerial: the order must name every part once");
  image::ImageF out = parts.at(size_t(order[0]));
  for (size_t k = 1; k < order.size(); ++k) compositeOver(out, parts.at(size_t(order[k])));
  return out;
}

image::ImageF finishPartial(const image::ImageF& premultiplied, const Scene& scene) {
  image::ImageF out = premultiplied;
  for (size_t i = 0; i < out.rgba.size(); i += 4) {
    const float* p = premultiplied.rgba.data() + i;
    const glm::dvec4 o = scene.output(glm::dvec3(p[0], p[1], p[2]), p[3]);
    for (int c = 0; c < 4; ++c) out.rgba[i + c] = float(o[c]);
  }
  return out;
}

}  // namespace voxbrick::render
