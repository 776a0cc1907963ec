// Sort-last rendering's pieces that need neither GL nor MPI: the box of the volume one process draws, the partial
// frame it yields (premultiplied colour and opacity, no background), the rectangle of its pixels that carry anything,
// the "over" operator that joins two partial frames in visibility order, and the finished frame over the scene's
// background. The serial compositor here is the reference the distributed one is held to.
#pragma once

#include <array>
#include <vector>

#include "image/Image.h"
#include "render/core/Scene.h"

namespace voxbrick::render {

/// A part of a grid dataset, in level-0 voxels, half-open: [lo, hi) on each axis. A frame drawn with
/// FrameOptions::part takes exactly the samples the whole frame takes whose owning level-0 voxel lies in the box, so
/// that the parts of a partition composited in visibility order give the whole frame.
struct PartBox {
  std::array<int, 3> lo{0, 0, 0};
  std::array<int, 3> hi{0, 0, 0};
  bool operator==(const PartBox&) const = default;
};

/// A part of a tetrahedral mesh dataset: a box in world coordinates, [lo, hi] on each axis. A frame drawn with
/// FrameOptions::meshPart integrates each ray only over its stretch inside the box (a cell straddling the box's faces
/// is cut there exactly), so that the parts of a partition, whose boxes tile space, composited in visibility order
/// give the whole frame.
struct MeshPartBox {
  std::array<double, 3> lo{0.0, 0.0, 0.0};
  std::array<double, 3> hi{0.0, 0.0, 0.0};
  bool operator==(const MeshPartBox&) const = default;
};

/// A rectangle of pixels, half-open: [x0, x1) × [y0, y1), row 0 at the top. Empty when x0 >= x1 or y0 >= y1.
struct PixelRect {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  bool empty() const { return x0 >= x1 || y0 >= y1; }
  long long pixels() const { return empty() ? 0 : (long long)(x1 - x0) * (y1 - y0); }
  bool operator==(const PixelRect&) const = default;
};

/// The smallest rectangle holding every pixel of `premultiplied` with any non-zero channel (empty if none).
PixelRect activeRect(const image::ImageF& premultiplied);

/// The rectangle of a width × height frame that `box` covers when `camera` draws it (at the aspect width / height),
/// grown by `margin` pixels a side and clipped to the frame: a pixel whose ray meets the box lies in it. The whole
/// frame when a corner of the box is not in front of a perspective eye (its projection is then unbounded); empty
/// for a box wholly off the frame or an empty frame. GL conventions: row 0 at the top.
PixelRect projectedRect(const Camera& camera, const Box& box, int width, int height, int margin = 2);

/// front = front over back, pixel by pixel on premultiplied RGBA: c = c_f + (1 − a_f)·c_b, a = a_f + (1 − a_f)·a_b.
/// Both images have the same size; throws std::invalid_argument otherwise.
void compositeOver(image::ImageF& front, const image::ImageF& back);

/// The serial reference: the partial frames joined front to back (`order[0]` the nearest part's index into `parts`).
image::ImageF compositeSerial(const std::vector<image::ImageF>& parts, const std::vector<int>& order);

/// A finished frame from a premultiplied one: each pixel through Scene::output (over the background, or straight
/// colour and alpha when the background is transparent), as the renderers finish a whole frame.
image::ImageF finishPartial(const image::ImageF& premultiplied, const Scene& scene);

}  // namespace voxbrick::render
