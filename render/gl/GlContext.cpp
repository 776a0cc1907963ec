// The backend-independent half of GlContext: loading, version check, limits, and the Auto/Egl/OsMesa choice.
#include "render/gl/GlContext.h"

#include "render/core/RenderErrors.h"

namespace voxbrick::render {

void GlContext::initialise(GlProcLoader loader, const char* loaderName, std::string path) {
  mPath = std::move(path);
  // With libglvnd every "gl*" name resolves to a dispatch stub, so an entry point the driver lacks is not caught by
  // loadGl; it shows as a version below 4.3 (where all of them are core), which the check below catches.
  mGl = loadGl(loader, loaderName);
  auto text = [this](GLenum name) {
    const GLubyte* s = mGl.glGetString(name);
    return s ? std::string(reinterpret_cast<const char*>(s)) : std::string("?");
  };
  mRenderer = text(GL_RENDERER);
  mVersion = text(GL_VERSION);

  auto integer = [this](GLenum name) {
    GLint value = 0;
    mGl.glGetIntegerv(name, &value);
    return int(value);
  };
  mLimits.versionMajor = integer(GL_MAJOR_VERSION);
  mLimits.versionMinor = integer(GL_MINOR_VERSION);
  if (mLimits.versionMajor * 10 + mLimits.versionMinor < 43) {
    throw RenderError(mPath + ": OpenGL " + mVersion + " on " + mRenderer + " is older than the 4.3 core needed");
  }
  if ((integer(GL_CONTEXT_PROFILE_MASK) & GL_CONTEXT_CORE_PROFILE_BIT) == 0) {
    throw RenderError(mPath + ": got a compatibility-profile context (" + mVersion + "), asked for core");
  }
  mLimits.max3DTextureSize = integer(GL_MAX_3D_TEXTURE_SIZE);
  mLimits.maxTextureSize = integer(GL_MAX_TEXTURE_SIZE);
  mLimits.maxTextureUnits = integer(GL_MAX_COMBINED_TEXTURE_IMAGE_UNITS);
  mLimits.maxRenderbufferSize = integer(GL_MAX_RENDERBUFFER_SIZE);
  GLint dims[2] = {0, 0};
  mGl.glGetIntegerv(GL_MAX_VIEWPORT_DIMS, dims);
  mLimits.maxViewportWidth = dims[0];
  mLimits.maxViewportHeight = dims[1];
  mLimits.maxVertexAttribs = integer(GL_MAX_VERTEX_ATTRIBS);
  mLimits.maxUniformBlockSize = integer(GL_MAX_UNIFORM_BLOCK_SIZE);
  mLimits.maxColorAttachments = integer(GL_MAX_COLOR_ATTACHMENTS);
  mLimits.maxFeedbackComponents = integer(GL_MAX_TRANSFORM_FEEDBACK_INTERLEAVED_COMPONENTS);
  checkGlError(mGl, (mPath + ": querying limits").c_str());
}

bool GlContext::software() const {
  if (backend() == Backend::OsMesa) return true;
  for (const char* name : {"llvmpipe", "softpipe", "swrast", "SWR"})
    if (mRenderer.find(name) != std::string::npos) return true;
  return false;
}

std::unique_ptr<GlContext> createContext(Backend backend) {
  std::string failures;
  if (backend == Backend::Auto || backend == Backend::Egl) {
    if (auto context = createEglContext(failures)) return context;
  }
  if (backend == Backend::Auto || backend == Backend::OsMesa) {
    if (auto context = createOsMesaContext(failures)) return context;
  }
  throw RenderError(std::string("createContext(") + backendName(backend) +
                    "): no OpenGL 4.3 core context; tried:" + failures);
}

bool computeRayCasterByDefault(const GlContext& context) {
  return !context.software() && context.renderer().find("NVIDIA") != std::string::npos;
}

}  // namespace voxbrick::render
