// Loads the GL entry-point table of GlFunctions.h and turns glGetError codes into RenderError.
#include "render/gl/GlFunctions.h"

#include <string>

#include "render/core/RenderErrors.h"

namespace voxbrick::render {

namespace {

std::string glErrorName(GLenum code) {
  switch (code) {
    case GL_INVALID_ENUM: return "GL_INVALID_ENUM";
    case GL_INVALID_VALUE: return "GL_INVALID_VALUE";
    case GL_INVALID_OPERATION: return "GL_INVALID_OPERATION";
    case GL_INVALID_FRAMEBUFFER_OPERATION: return "GL_INVALID_FRAMEBUFFER_OPERATION";
    case GL_OUT_OF_MEMORY: return "GL_OUT_OF_MEMORY";
    case GL_STACK_UNDERFLOW: return "GL_STACK_UNDERFLOW";
    case GL_STACK_OVERFLOW: return "GL_STACK_OVERFLOW";
    default: return "GL error 0x" + std::to_string(code);
  }
}

}  // namespace

Gl loadGl(GlProcLoader loader, const char* loaderName) {
  Gl gl;
  // Function-to-function reinterpret_cast is well defined to round-trip; the loader hands back the right type.
#define VOXBRICK_GL_LOAD(type, name)                                                             \
  gl.name = reinterpret_cast<type>(loader(#name));                                               \
  if (gl.name == nullptr) {                                                                      \
    throw RenderError(std::string("loadGl: ") + loaderName + " returned no address for " #name); \
  }
  VOXBRICK_GL_FUNCTIONS(VOXBRICK_GL_LOAD)
#undef VOXBRICK_GL_LOAD
  return gl;
}

void checkGlError(const Gl& gl, const char* what) {
  GLenum first = gl.glGetError();
  if (first == GL_NO_ERROR) return;
  // GL queues one flag per error kind; drain them so the next check reports only new errors.
  for (int i = 0; i < 16 && gl.glGetError() != GL_NO_ERROR; ++i) {
  }
  throw RenderError(std::string(what) + ": " + glErrorName(first));
}

}  // namespace voxbrick::render
