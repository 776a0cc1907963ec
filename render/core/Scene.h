// A render request's scene: camera, transfer function, image size, step, background and options, one struct per
// concern. Its JSON schema (render/core/SceneSchema.h) is read by `voxbrick render --scene`, the command line's
// scene options and the server.
#pragma once

#include <array>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "common/EnumNames.h"
#include "render/core/Camera.h"
#include "render/core/Quality.h"
#include "render/core/TransferFunction.h"
#include "render/core/WorldFrame.h"

namespace voxbrick::render {

class TransferFunctionPresets;

/// How polygons of the slice planes are computed (when slicing: slabs and the ray caster draw no slices). Every
/// slicer gives the same polygons; they differ in where the work is done.
enum class Slicer {
  Vertex,          ///< "vertex": the vertex program of Rezk-Salama & Kolb, 12 vertices per plane
  Cpu,             ///< "cpu": its mirror on the CPU, the reference and fallback
  VertexLean,      ///< "vertex-lean": the vertex program with the paths chosen on the CPU, one table (Zellmann & Lang)
  Geometry,        ///< "geometry": a geometry program, one point in per box and plane, a triangle strip out
  VertexGeometry,  ///< "vertex-geometry": P0, P2, P4 in the vertex program, P1, P3, P5 in a geometry program
};

/// Every slicer, in the enum's order.
inline constexpr std::array<Slicer, 5> kSlicers = {Slicer::Vertex, Slicer::Cpu, Slicer::VertexLean, Slicer::Geometry,
                                                   Slicer::VertexGeometry};

/// The slicers' names in scenes and on the command line.
inline constexpr common::EnumName<Slicer> kSlicerNames[] = {{Slicer::Vertex, "vertex"},
                                                            {Slicer::Cpu, "cpu"},
                                                            {Slicer::VertexLean, "vertex-lean"},
                                                            {Slicer::Geometry, "geometry"},
                                                            {Slicer::VertexGeometry, "vertex-geometry"}};
constexpr std::span<const common::EnumName<Slicer>> enumNames(Slicer) { return kSlicerNames; }

/// The slicer's name ("vertex", "cpu", "vertex-lean", "geometry", "vertex-geometry").
inline const char* slicerName(Slicer slicer) { return common::nameOf(slicer); }
/// The slicer named `name`; throws RenderInputError naming `what`, the closest name and the valid ones otherwise.
Slicer parseSlicer(const std::string& name, const std::string& what);

/// Which kernel of the ray casters draws a ray-cast frame: the grids' frame ray caster (render/gl/volume/RayCastPass.h)
/// and the meshes' adjacency ray caster (render/gl/tets/TetRayCaster.h). Both kernels of each march the same samples
/// through the same code (shaders/volume_march.glsl, shaders/tet_walk.glsl); they differ in how the GPU runs it: a
/// fragment per pixel blended into the target, or a compute invocation per pixel that composites into it itself, in
/// workgroups that reach every core of a data-centre GPU where its graphics pipeline reaches only a few.
enum class RayCaster {
  Auto,      ///< "auto": the faster as measured (GlContext.h: computeRayCasterByDefault; a mesh: fragment)
  Fragment,  ///< "fragment": a full-screen triangle per batch, blended
  Compute,   ///< "compute": a compute dispatch per batch and band
};
inline constexpr common::EnumName<RayCaster> kRayCasterNames[] = {
    {RayCaster::Auto, "auto"}, {RayCaster::Fragment, "fragment"}, {RayCaster::Compute, "compute"}};
constexpr std::span<const common::EnumName<RayCaster>> enumNames(RayCaster) { return kRayCasterNames; }
/// "auto", "fragment", "compute".
inline const char* rayCasterName(RayCaster kernel) { return common::nameOf(kernel); }
/// The kernel named `name`; throws RenderInputError naming `what`, the closest name and the valid ones otherwise.
RayCaster parseRayCaster(const std::string& name, const std::string& what);

/// What decides which bricks of a ray-cast frame are paged into the atlas (render/gl/volume/RayRequests.h). Octree:
/// every brick the octree walk finds visible and not empty, before the frame draws. Rays: the bricks the rays reached
/// and did not find resident (a feedback buffer the march writes), a few frames later; meanwhile they are drawn from
/// a coarser resident ancestor. Bricks behind an opaque front are then never paged. Both converge to the same image.
enum class ResidencyMode {
  Octree,  ///< "octree": the octree walk pages every visible brick
  Rays,    ///< "rays": the rays request the bricks they reach
};
inline constexpr common::EnumName<ResidencyMode> kResidencyModeNames[] = {{ResidencyMode::Octree, "octree"},
                                                                          {ResidencyMode::Rays, "rays"}};
constexpr std::span<const common::EnumName<ResidencyMode>> enumNames(ResidencyMode) { return kResidencyModeNames; }
/// "octree", "rays".
inline const char* residencyModeName(ResidencyMode mode) { return common::nameOf(mode); }
/// The mode named `name`; throws RenderInputError naming `what`, the closest name and the valid ones otherwise.
ResidencyMode parseResidencyMode(const std::string& name, const std::string& what);

/// How a tetrahedral mesh's cells are put in visibility order. Mpvo: the meshed-polyhedra visibility
/// order, a breadth-first walk of the face-adjacency graph from the cells nothing hides (exact for a convex mesh
/// without cycles). Centroid: cells by the distance of their centroids from the eye (cheaper, approximate where
/// cells of different sizes meet). Ray: no sort; each pixel's ray walks the face-adjacency graph from the boundary
/// face where it enters (render/gl/tets/TetRayCaster.h): exact for any mesh, with early ray termination (Scene::ert).
enum class TetSort { Mpvo, Centroid, Ray };
inline constexpr common::EnumName<TetSort> kTetSortNames[] = {
    {TetSort::Mpvo, "mpvo"}, {TetSort::Centroid, "centroid"}, {TetSort::Ray, "raycast"}};
constexpr std::span<const common::EnumName<TetSort>> enumNames(TetSort) { return kTetSortNames; }
/// "mpvo", "centroid", "raycast".
inline const char* tetSortName(TetSort sort) { return common::nameOf(sort); }
/// The order named `name`; throws RenderInputError naming `what` and the valid names otherwise.
TetSort parseTetSort(const std::string& name, const std::string& what);

/// The scene keys a quality target chooses (QualitySetting's fields): a scene with "quality" names none of them
/// (SceneSchema's rules).
extern const char* const kQualityChosenKeys[7];

/// The camera as a user gives it, in world coordinates (RAS for patient data; a volume without a patient frame has
/// its local frame as the world, ARCHITECTURE.md placement): an orbit around the volume, or eye/center/up.
struct CameraSpec {
  bool orbit = true;
  double azimuth = 30, elevation = 20;  ///< degrees, about upAxis (OrbitAxes in Camera.h: az 0 on front, 90 on side)
  /// The orbit's distance in bounding-sphere radii; empty (the default): fitted from the field of view and the aspect
  /// (Camera::fitDistance), the whole volume in frame at any angle.
  std::optional<double> distance;
  UpAxis upAxis = UpAxis::PosZ;                           ///< the orbit's pole (default +z: superior for patient data)
  glm::dvec3 eye{0, 0, 1}, center{0, 0, 0}, up{0, 1, 0};  ///< world coordinates; used when !orbit
  double fovY = 30;                                       ///< degrees
  bool orthographic = false;

  /// The camera in the local frame of a volume whose local box is `localBox` and whose world frame is `frame`
  /// (identity: local = world, as for meshes), for an image of `aspect` = width / height. The orbit turns about the
  /// world box's centre with the world up axis; an explicit eye, center and up are world coordinates. When
  /// frame.mirrored() the local camera is the proper one (its right vector is the world view's negated): the image
  /// must go through finishImage. Throws RenderInputError for invalid values.
  Camera resolve(const Box& localBox, const WorldFrame& frame = {}, double aspect = 1) const;

  /// Sets a named view: an orbit about +z (az, el) of anterior (0, 0), left (90, 0), posterior (180, 0), right
  /// (270, 0), superior (180, 90: looking down, anterior at the top) and inferior (0, -90: looking up, anterior at
  /// the top); the distance stays as it is. For patient data these are the anatomical views (RAS: the patient's
  /// left is -x); for other data the same axes (anterior = from +y, left = from -x, superior = from +z). Throws
  /// RenderInputError naming `what` and the valid names for another name.
  void setView(const std::string& name, const std::string& what);
};

/// The named views' names, "anterior", "posterior", "left", "right", "superior", "inferior", comma separated.
std::string viewNames();
/// The same names, one each.
std::vector<std::string> viewNameList();

/// A pixel's output from premultiplied colour `c` and opacity `a` (ARCHITECTURE.md, optical model: output):
/// c + (1 - a)·background with alpha 1; with a transparent background, straight colour c / a and alpha a (all 0
/// where nothing was drawn). Clamped to [0, 1].
glm::dvec4 outputPixel(const glm::dvec3& c, double a, const glm::dvec3& background, bool transparent);

/// The view: where the camera is, the image's size and what lies behind the volume (SceneSchema's concern "view").
struct SceneView {
  static constexpr int kMaxImageSide = 8192;

  CameraSpec camera;
  int width = 512, height = 512;
  glm::dvec3 background{0, 0, 0};  ///< opaque background colour, RGB in [0, 1]
  /// No background ("background": "none"): frames carry alpha, the accumulated opacity, with straight (not
  /// premultiplied) colour, as PNG stores it; `background` is then unused.
  bool transparent = false;

  /// A pixel's output from its premultiplied colour and opacity: outputPixel with this view's background.
  glm::dvec4 output(const glm::dvec3& c, double a) const;
};

/// Classification: how values become colour and opacity (concern "classification").
struct SceneClassification {
  /// Default: the grayscale ramp (as config/tf/grayscale.json), built in so a scene never needs the config files.
  /// Transparent up to 0.05 of the window, so that empty space (a background at the window's low end, and its
  /// noise) is skipped; then grey rising to white and opacity rising to 0.5.
  TransferFunction transferFunction{{{0.0, {0, 0, 0, 0}}, {0.05, {0.05, 0.05, 0.05, 0}}, {1.0, {1, 1, 1, 0.5}}}};
  std::string transferFunctionName = "grayscale";  ///< preset name or path, or "inline"
  std::optional<std::array<double, 2>> window;     ///< value window [lo, hi]; default the store's value range
  bool shading = false;
};

/// How a grid is drawn (concern "grid"); `skipEmpty` and `ert` apply to meshes as well, `quality` chooses the
/// drawing settings of either kind from the dataset's table.
struct GridTechnique {
  static constexpr int kMaxSubBlock = 256;
  static constexpr int kMaxSlab = 4096;
  static constexpr double kMaxLod = 1024;  ///< pixels; beyond it every node is coarse enough anyway

  /// Slice spacing in voxels of level 0 (of the smallest spacing). The default drawing, step 0.75 through the frame
  /// ray caster with termination at 0.999 and cells of sub-blocks of 8, is the fastest setting of the time-against-
  /// error sweep (`voxbrick bench`) that keeps every dataset at 40 dB or more against the reference (unshaded;
  /// shading needs finer).
  double step = 0.75;
  bool skipEmpty = true;
  bool cullFrustum = true;
  /// Where slice polygons are computed when slicing (slab 0, no raycast); no effect on slabs or the ray caster.
  Slicer slicer = Slicer::Vertex;
  /// Empty-space skipping inside bricks: bricks are drawn as boxes of sub-blocks of this many voxels per edge whose
  /// value range the transfer function does not reject. 0 (or anything not below the store's brick size) draws
  /// whole bricks. A power of two.
  int subBlock = 8;
  /// Texture slabs: 0 slices (one blended sample per fragment); N >= 1 draws each box once per slab of N
  /// consecutive global planes, and the fragment program marches the pixel's ray through them, compositing in
  /// registers. N at least a brick's planes makes it a brick ray caster. The samples are the same either way.
  int slab = 32;
  /// Frame ray casting (render/gl/volume/RayCastPass.h): one fragment per pixel and atlas batch marches the pixel's ray
  /// through every brick of the batch, finding each sample's brick in a table of cells (sub-blocks, else bricks)
  /// instead of drawing a proxy per box and slab. The samples are the same global planes' points as slicing and slabs
  /// take, so the image is the same beyond round-off; `slab` and `ess` then have no effect, ert and pre_integration
  /// apply. The default; a volume too large for the cell table (render/volume/FramePlan.h) is drawn with slabs instead.
  bool raycast = true;
  /// The ray casters' kernel (the grids' and the meshes'): the fragment program or the compute program, the same
  /// samples; auto chooses by device.
  RayCaster raycaster = RayCaster::Auto;
  /// What pages a ray-cast frame's bricks: the octree walk (every visible brick) or the rays' requests (the bricks
  /// rays reached; the others drawn from a resident ancestor until requested). Frames of one batch only; a frame of
  /// batches or a part's frame is paged by the octree.
  ResidencyMode residency = ResidencyMode::Octree;
  /// Early ray termination on texture slabs: 0 (off) or a threshold in [0.5, 1]. Between slabs a pass marks the
  /// pixels whose accumulated opacity reached it in the depth buffer (a slab silhouette map), and the early depth
  /// test skips their fragments in every later slab; a fragment also stops marching when its own opacity reaches
  /// it. The image then differs from the full integral by at most 1 - ert per channel. No effect when slab is 0.
  double ert = 0.999;
  /// Pre-integrated classification (Engel et al. 2001) on texture slabs: each segment between two samples is
  /// classified as a whole from its front and back values and length through a table rebuilt whenever the transfer
  /// function or the step changes, instead of one post-classified sample per segment. No effect when slab is 0.
  bool preIntegration = false;
  /// Empty-space silhouette maps on texture slabs (a conservative silhouette pass): before each slab, a pass
  /// marches the slab's samples of every pixel not yet terminated and marks in the depth buffer the pixels with any
  /// sample the transfer function does not make transparent; the slab is then drawn for those pixels only. The image
  /// is the same. No effect when slab is 0.
  bool ess = false;
  /// Level of detail: where a coarser level of the pyramid has voxels no taller than this many pixels on the image
  /// (at their nearest depth), draw that level instead of the finer ones; 0 draws level 0 everywhere. On texture
  /// slabs a level-m brick takes every 2^m-th global plane (fewer, longer segments, opacity corrected for their
  /// length); slicing takes every plane at every level. Default 1 (a voxel no larger than a pixel): in the level-of-
  /// detail sweep it changes no sample of the sweep's datasets at 256², where 2 costs the MRI 20 dB.
  double lod = 1;
  /// Quality by target ("psnr:40", "ms:200"): the drawing settings (step, raycast, slab, ert, pre_integration,
  /// sub_block, lod) are chosen from the dataset's quality table when the frame is drawn (render/core/Quality.h,
  /// resolveQuality in render/core/Dataset.h), replacing the scene's own; a scene with a target names none of them.
  std::optional<QualityTarget> quality;
};

/// How a tetrahedral mesh is drawn (concern "mesh").
struct MeshTechnique {
  /// How a tetrahedral mesh's cells are put in order (no effect on a grid). The default, the ray caster with `ert`
  /// 0.999, is the fastest setting of the mesh sweep (`voxbrick bench --mesh`) that keeps every mesh at 40 dB or more
  /// against the exact reference (4× MPVO's speed on the 1 M-tet ball; slower on the small Kuhn ball).
  TetSort visibility = TetSort::Ray;
};

/// How and when frames reach the client (concern "delivery"): coarse-to-fine, frames on a time budget, encodings.
struct SceneDelivery {
  static constexpr double kMinTimeBudgetMs = 10, kMaxTimeBudgetMs = 10000;
  /// The names `provisional_encoding` accepts.
  static constexpr const char* kEncodingNames[7] = {"raw", "png", "zstd", "jpeg", "vp8", "vp9", "webp"};

  /// Coarse-to-fine: the frame may be drawn first with stand-ins (bricks not yet resident drawn from a coarser
  /// resident level while they are paged), then again once they are resident. The server then answers a Render with
  /// a provisional Frame followed by the exact one (PROTOCOL.md); `voxbrick render` writes both. The final frame is
  /// the same as without it.
  bool progressive = false;
  /// A camera in motion (a drag): the frame is drawn within `timeBudgetMs`, choosing a reduced drawing size (scaled
  /// up bilinearly to width x height), a coarser level of detail and a longer step by the rate the device has shown
  /// (render/core/Interactive.h); the server answers it as a provisional Frame and sends the exact one once the camera
  /// rests (PROTOCOL.md, Session 8). No effect on the exact frame.
  bool interactive = false;
  /// The time an interactive frame may take, in ms (kMinTimeBudgetMs..kMaxTimeBudgetMs). The default, 100 ms (ten
  /// frames a second), is the smallest budget measured to keep the MRI at 512² at 40 dB or more against the exact
  /// frame on llvmpipe with 2 cores (`voxbrick orbit --interactive`: 40 to 47 dB at 100 ms, 38 to 39 dB at 50 ms,
  /// after the first view, which has no rate yet; docs/performance.md).
  double timeBudgetMs = 100;
  /// The JPEG quality (libjpeg's scale, 1..100) of a frame sent as JPEG; absent: the server's default
  /// (image::kDefaultJpegQuality, chosen where bytes against PSNR bend over). No effect on other encodings.
  std::optional<int> jpegQuality;
  /// The encoding of a request's provisional frames, by name ("raw", "png", "zstd", "jpeg", "vp8", "vp9", "webp";
  /// kEncodingNames): the server maps it to the protocol's encoding. Absent: the request's own encoding. vp8 and vp9
  /// make the session's moving frames one video stream (PROTOCOL.md).
  std::optional<std::string> provisionalEncoding;
  /// The session's video stream starts again at this frame: its next video frame is a key frame (a client whose
  /// decoder lost the stream asks so). No effect without a video `provisional_encoding`.
  bool keyframe = false;
  /// The client decodes lossless WebP: the server may send the request's png frames as webp instead (the same
  /// pixels in fewer bytes, longer to encode), which it does while the session's link, at the rate the server's
  /// measurements settled, is slow (server/RenderJob.h, webpFor). Protocol version 7 on. No effect on the image.
  bool acceptsWebp = false;
  /// The client decodes VP9 in 4:4:4 (profile 1): a session's vp9 video stream is then encoded with colour at every
  /// pixel instead of one colour sample a 2x2 block (image::VideoSettings::fullChroma). Protocol version 9 on. No
  /// effect on the image drawn, nor on a stream in another codec.
  bool acceptsVp9_444 = false;
  /// Work nobody watches as it happens (a script's frames, `voxbrick load --batch`): a server serves it after every
  /// moving camera's frame and every resting camera's exact frame, from a smaller share of its render time, and
  /// refuses it with `Busy` first when it is over capacity. No effect on the image.
  bool batch = false;
};

/// Everything a frame depends on besides the store: one struct per concern, so that `scene.step` reads as before
/// and a function that needs one concern takes that struct. Its JSON keys, their types, ranges, defaults (these
/// fields' initial values), help texts, command-line options and the rules between keys are one table,
/// render/core/SceneSchema.h; parsing, validation, toJson and the command line's scene options all read it.
struct Scene : SceneView, SceneClassification, GridTechnique, MeshTechnique, SceneDelivery {
  /// Parses a scene JSON object; absent keys keep their defaults. Throws RenderInputError naming `what`, the key,
  /// the value and what it may be: an unknown key (`camera.zoom` too), a value of the wrong type or out of range
  /// (sceneSchema()), or keys the schema's rules (sceneRules()) refuse together: a quality target beside a setting
  /// it chooses, two camera placements (orbit, view, eye), center or up without eye, fit or up_axis with eye, an up
  /// axis with a view. `allowPaths` false (the server) accepts transfer functions by preset name or inline only,
  /// never a file path.
  static Scene fromJson(const std::string& text, const std::string& what, bool allowPaths = true);
  /// The same, resolving preset names from `presets` (no file is read) and accepting no paths: what a server does
  /// on its I/O threads.
  static Scene fromJson(const std::string& text, const std::string& what, const TransferFunctionPresets& presets);
  /// Throws RenderInputError naming the key for a value outside its schema range (size, step, background, window,
  /// fov, slab, ert, lod, sub_block, time budget, ...).
  void validate() const;
  /// The scene as JSON (the transfer function inline), so a frame can be reproduced: every key the schema writes
  /// (SceneKey::written), a quality target standing for the settings it chooses.
  std::string toJson() const;
};

}  // namespace voxbrick::render
