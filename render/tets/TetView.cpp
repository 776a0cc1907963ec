// A frame's view of a mesh.
#include "render/tets/TetView.h"

namespace voxbrick::render {

TetView TetView::of(const Scene& scene, const TetMeshConstants& constants) {
  TetView v;
  const double aspect = double(scene.width) / double(scene.height);
  v.camera = scene.camera.resolve(constants.bounds, {}, aspect);
  v.camera.clipRange(constants.bounds, v.nearPlane, v.farPlane);
  v.clipFromWorld = v.camera.projection(aspect, v.nearPlane, v.farPlane) * v.camera.view();
  v.windowLo = constants.scalarMin;
  v.windowHi = constants.scalarMax;
  if (scene.window) {
    v.windowLo = (*scene.window)[0];
    v.windowHi = (*scene.window)[1];
  }
  if (!(v.windowHi > v.windowLo)) v.windowHi = v.windowLo + 1;
  return v;
}

}  // namespace voxbrick::render
