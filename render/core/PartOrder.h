// The front-to-back order of sort-last rendering's parts when they are the leaves of a k-d tree, whatever the parts
// are (a grid's boxes of level-0 voxels, a mesh's world-space boxes): at each split the side holding the eye, or the
// side an orthographic view comes from, goes first. Each part is convex and the splits are planes, so the order is
// exact for any camera, one inside the data included. GL-free, header-only.
#pragma once

#include <vector>

#include <glm/glm.hpp>

namespace voxbrick::render {

/// A view in the coordinates the splits are placed in (a grid's level-0 voxels, a mesh's world units).
struct PartView {
  bool orthographic = false;
  glm::dvec3 eye{0.0};        ///< perspective: the eye
  glm::dvec3 direction{0.0};  ///< orthographic: the view direction (only its signs matter)
};

/// One node of a k-d tree of parts: a split (axis 0..2 at `position` on it, children `lower` and `upper`), or a leaf
/// (part >= 0). Position: a grid's level-0 voxel (int) or a mesh's world coordinate (double).
template <typename Position>
struct KdNode {
  int axis = -1;
  Position position = 0;
  int lower = -1, upper = -1;
  int part = -1;
};

namespace detail {

template <typename Node>
void kdFrontToBack(const std::vector<Node>& nodes, int node, const PartView& view, std::vector<int>& order) {
  const Node& n = nodes.at(size_t(node));
  if (n.part >= 0) {
    order.push_back(n.part);
    return;
  }
  const bool lowerFirst = view.orthographic ? view.direction[n.axis] >= 0 : view.eye[n.axis] <= double(n.position);
  kdFrontToBack(nodes, lowerFirst ? n.lower : n.upper, view, order);
  kdFrontToBack(nodes, lowerFirst ? n.upper : n.lower, view, order);
}

}  // namespace detail

/// The parts' indices nearest first for `view`, over a k-d tree whose nodes[0] is the root. A node is a split (its
/// `axis` 0..2, the plane's `position` on it, children `lower` and `upper`) or a leaf (`part` >= 0). At each split:
/// the side holding the eye (perspective; an eye on the plane takes the lower side first), or the side the view
/// comes from (orthographic, by the direction's sign on the axis).
template <typename Node>
std::vector<int> kdFrontToBack(const std::vector<Node>& nodes, const PartView& view) {
  std::vector<int> order;
  if (nodes.empty()) return order;
  detail::kdFrontToBack(nodes, 0, view, order);
  return order;
}

}  // namespace voxbrick::render
