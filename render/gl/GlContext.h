// A headless OpenGL 4.3+ core context: EGL (device platform, then Mesa surfaceless) or OSMesa, behind one interface.
//
// Rendering always goes to framebuffer objects, so a context has no window and no usable default framebuffer. One
// context per render thread is the intended use; contexts can be created and destroyed many times per process.
#pragma once

#include <memory>
#include <string>

#include "render/core/Backend.h"
#include "render/gl/GlFunctions.h"

namespace voxbrick::render {

/// Implementation limits, queried once when the context is created (never per frame).
struct GlLimits {
  int versionMajor = 0;           ///< GL_MAJOR_VERSION
  int versionMinor = 0;           ///< GL_MINOR_VERSION
  int max3DTextureSize = 0;       ///< GL_MAX_3D_TEXTURE_SIZE: the largest atlas edge in texels
  int maxTextureSize = 0;         ///< GL_MAX_TEXTURE_SIZE: the largest 1D/2D edge
  int maxTextureUnits = 0;        ///< GL_MAX_COMBINED_TEXTURE_IMAGE_UNITS
  int maxRenderbufferSize = 0;    ///< GL_MAX_RENDERBUFFER_SIZE: the largest framebuffer edge
  int maxViewportWidth = 0;       ///< GL_MAX_VIEWPORT_DIMS[0]
  int maxViewportHeight = 0;      ///< GL_MAX_VIEWPORT_DIMS[1]
  int maxVertexAttribs = 0;       ///< GL_MAX_VERTEX_ATTRIBS
  int maxUniformBlockSize = 0;    ///< GL_MAX_UNIFORM_BLOCK_SIZE in bytes
  int maxColorAttachments = 0;    ///< GL_MAX_COLOR_ATTACHMENTS
  int maxFeedbackComponents = 0;  ///< GL_MAX_TRANSFORM_FEEDBACK_INTERLEAVED_COMPONENTS
};

/// An OpenGL 4.3+ core-profile context with its function table. Move-free: hold it by unique_ptr.
class GlContext {
 public:
  virtual ~GlContext() = default;
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  /// Binds the context to the calling thread (it may be current on at most one thread at a time); throws RenderError.
  virtual void makeCurrent() = 0;
  /// Unbinds the context from the calling thread so that another thread may make it current.
  virtual void releaseCurrent() = 0;
  /// The library that created it: Backend::Egl or Backend::OsMesa, never Auto.
  virtual Backend backend() const = 0;

  /// The entry points; call them only while this context is current on the calling thread.
  const Gl& gl() const { return mGl; }
  /// The limits queried once at creation.
  const GlLimits& limits() const { return mLimits; }
  /// How it was made and what runs it, e.g. "EGL surfaceless — llvmpipe (LLVM 15.0.6, 256 bits), 4.5 (Core ...)".
  std::string describe() const { return mPath + " — " + mRenderer + ", " + mVersion; }
  /// True for a software rasteriser (llvmpipe, softpipe, OSMesa): textures and buffers are host memory.
  bool software() const;
  /// GL_RENDERER as the driver reports it.
  const std::string& renderer() const { return mRenderer; }
  /// GL_VERSION as the driver reports it.
  const std::string& version() const { return mVersion; }

 protected:
  GlContext() = default;
  /// Called by subclasses once the context is current: loads the entry points, checks the version, reads the
  /// limits and strings. `path` names how it was made ("EGL device (NVIDIA ...)", "EGL surfaceless", "OSMesa").
  void initialise(GlProcLoader loader, const char* loaderName, std::string path);

 private:
  Gl mGl;
  GlLimits mLimits;
  std::string mPath;
  std::string mRenderer;
  std::string mVersion;
};

/// Creates a context and makes it current on the calling thread. Auto tries the EGL device platform (hardware
/// devices), EGL on Mesa's surfaceless platform, the EGL software device, then OSMesa; Egl tries only the EGL paths;
/// OsMesa only OSMesa. Throws RenderError listing every attempt and why it failed.
std::unique_ptr<GlContext> createContext(Backend backend = Backend::Auto);

/// EGL only: the context from the first EGL path that works; appends "what: why" lines to `failures`, nullptr if
/// none works. Used by createContext.
std::unique_ptr<GlContext> createEglContext(std::string& failures);

/// OSMesa only: as createEglContext.
std::unique_ptr<GlContext> createOsMesaContext(std::string& failures);

/// Empty where the libOSMesa this process runs with is Mesa's; where it is the GPU kit's stand-in (bench/gpu/
/// osmesa_stub.c: every entry point fails, so there is no OSMesa backend at all), what that library says it is.
std::string osMesaStandIn();

/// Whether RayCaster::Auto takes the grids' compute ray caster on `context`'s device (the meshes' ray caster keeps
/// its fragment kernel under Auto until a GPU has measured its compute kernel): on NVIDIA, where the graphics pipeline
/// reaches only part of a data-centre chip (measured on the H200: the grids' compute kernel at 24-26 G samples/s
/// against the fragment kernel's 2.5-2.8). Not on a software rasteriser, where the compute kernel was never clearly the
/// faster and up to 1.85x the slower on the MRI (docs/performance.md), nor on any other device, where the fragment
/// kernels are the long-tested path.
bool computeRayCasterByDefault(const GlContext& context);

}  // namespace voxbrick::render
