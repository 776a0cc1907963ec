// The table of OpenGL 4.3+ core entry points the renderer uses, loaded per context through a getProcAddress.
//
// Hand-written rather than libepoxy/glad because epoxy cannot load through OSMesa and linking libOpenGL beside
// libOSMesa makes the two GL dispatch tables clash; every call goes through a pointer fetched from the context's
// own loader (eglGetProcAddress or OSMesaGetProcAddress) instead.
#pragma once

#include <GL/glcorearb.h>

namespace voxbrick::render {

/// X-macro list of every entry point in Gl: X(pointer type, entry point name). Add a function here and nowhere else.
#define VOXBRICK_GL_FUNCTIONS(X)                                                 \
  /* state, errors, synchronisation */                                           \
  X(PFNGLGETERRORPROC, glGetError)                                               \
  X(PFNGLGETINTEGERVPROC, glGetIntegerv)                                         \
  X(PFNGLGETINTEGER64VPROC, glGetInteger64v)                                     \
  X(PFNGLGETFLOATVPROC, glGetFloatv)                                             \
  X(PFNGLGETSTRINGPROC, glGetString)                                             \
  X(PFNGLGETSTRINGIPROC, glGetStringi)                                           \
  X(PFNGLENABLEPROC, glEnable)                                                   \
  X(PFNGLDISABLEPROC, glDisable)                                                 \
  X(PFNGLFINISHPROC, glFinish)                                                   \
  X(PFNGLFLUSHPROC, glFlush)                                                     \
  X(PFNGLMEMORYBARRIERPROC, glMemoryBarrier)                                     \
  X(PFNGLFENCESYNCPROC, glFenceSync)                                             \
  X(PFNGLCLIENTWAITSYNCPROC, glClientWaitSync)                                   \
  X(PFNGLDELETESYNCPROC, glDeleteSync)                                           \
  /* framebuffer state, clearing, blending, readback */                          \
  X(PFNGLVIEWPORTPROC, glViewport)                                               \
  X(PFNGLSCISSORPROC, glScissor)                                                 \
  X(PFNGLCLEARPROC, glClear)                                                     \
  X(PFNGLCLEARCOLORPROC, glClearColor)                                           \
  X(PFNGLCLEARDEPTHPROC, glClearDepth)                                           \
  X(PFNGLCLEARBUFFERFVPROC, glClearBufferfv)                                     \
  X(PFNGLCLEARBUFFERUIVPROC, glClearBufferuiv)                                   \
  X(PFNGLCOLORMASKPROC, glColorMask)                                             \
  X(PFNGLDEPTHMASKPROC, glDepthMask)                                             \
  X(PFNGLDEPTHFUNCPROC, glDepthFunc)                                             \
  X(PFNGLDEPTHRANGEPROC, glDepthRange)                                           \
  X(PFNGLCULLFACEPROC, glCullFace)                                               \
  X(PFNGLFRONTFACEPROC, glFrontFace)                                             \
  X(PFNGLPOLYGONMODEPROC, glPolygonMode)                                         \
  X(PFNGLBLENDFUNCPROC, glBlendFunc)                                             \
  X(PFNGLBLENDFUNCSEPARATEPROC, glBlendFuncSeparate)                             \
  X(PFNGLBLENDEQUATIONPROC, glBlendEquation)                                     \
  X(PFNGLREADPIXELSPROC, glReadPixels)                                           \
  X(PFNGLREADBUFFERPROC, glReadBuffer)                                           \
  X(PFNGLDRAWBUFFERSPROC, glDrawBuffers)                                         \
  X(PFNGLPIXELSTOREIPROC, glPixelStorei)                                         \
  /* buffers */                                                                  \
  X(PFNGLGENBUFFERSPROC, glGenBuffers)                                           \
  X(PFNGLDELETEBUFFERSPROC, glDeleteBuffers)                                     \
  X(PFNGLBINDBUFFERPROC, glBindBuffer)                                           \
  X(PFNGLBINDBUFFERBASEPROC, glBindBufferBase)                                   \
  X(PFNGLBINDBUFFERRANGEPROC, glBindBufferRange)                                 \
  X(PFNGLBUFFERDATAPROC, glBufferData)                                           \
  X(PFNGLBUFFERSUBDATAPROC, glBufferSubData)                                     \
  X(PFNGLGETBUFFERSUBDATAPROC, glGetBufferSubData)                               \
  X(PFNGLMAPBUFFERRANGEPROC, glMapBufferRange)                                   \
  X(PFNGLUNMAPBUFFERPROC, glUnmapBuffer)                                         \
  /* vertex arrays, drawing, compute */                                          \
  X(PFNGLGENVERTEXARRAYSPROC, glGenVertexArrays)                                 \
  X(PFNGLDELETEVERTEXARRAYSPROC, glDeleteVertexArrays)                           \
  X(PFNGLBINDVERTEXARRAYPROC, glBindVertexArray)                                 \
  X(PFNGLENABLEVERTEXATTRIBARRAYPROC, glEnableVertexAttribArray)                 \
  X(PFNGLDISABLEVERTEXATTRIBARRAYPROC, glDisableVertexAttribArray)               \
  X(PFNGLVERTEXATTRIBPOINTERPROC, glVertexAttribPointer)                         \
  X(PFNGLVERTEXATTRIBIPOINTERPROC, glVertexAttribIPointer)                       \
  X(PFNGLVERTEXATTRIBDIVISORPROC, glVertexAttribDivisor)                         \
  X(PFNGLDRAWARRAYSPROC, glDrawArrays)                                           \
  X(PFNGLDRAWARRAYSINSTANCEDPROC, glDrawArraysInstanced)                         \
  X(PFNGLDRAWARRAYSINSTANCEDBASEINSTANCEPROC, glDrawArraysInstancedBaseInstance) \
  X(PFNGLDISPATCHCOMPUTEPROC, glDispatchCompute)                                 \
  /* textures */                                                                 \
  X(PFNGLGENTEXTURESPROC, glGenTextures)                                         \
  X(PFNGLDELETETEXTURESPROC, glDeleteTextures)                                   \
  X(PFNGLACTIVETEXTUREPROC, glActiveTexture)                                     \
  X(PFNGLBINDTEXTUREPROC, glBindTexture)                                         \
  X(PFNGLTEXPARAMETERIPROC, glTexParameteri)                                     \
  X(PFNGLTEXPARAMETERFVPROC, glTexParameterfv)                                   \
  X(PFNGLTEXIMAGE1DPROC, glTexImage1D)                                           \
  X(PFNGLTEXSUBIMAGE1DPROC, glTexSubImage1D)                                     \
  X(PFNGLTEXIMAGE2DPROC, glTexImage2D)                                           \
  X(PFNGLTEXSUBIMAGE2DPROC, glTexSubImage2D)                                     \
  X(PFNGLTEXIMAGE3DPROC, glTexImage3D)                                           \
  X(PFNGLTEXSUBIMAGE3DPROC, glTexSubImage3D)                                     \
  X(PFNGLTEXSTORAGE1DPROC, glTexStorage1D)                                       \
  X(PFNGLTEXSTORAGE2DPROC, glTexStorage2D)                                       \
  X(PFNGLTEXSTORAGE3DPROC, glTexStorage3D)                                       \
  X(PFNGLTEXBUFFERPROC, glTexBuffer)                                             \
  X(PFNGLGETTEXIMAGEPROC, glGetTexImage)                                         \
  X(PFNGLBINDIMAGETEXTUREPROC, glBindImageTexture)                               \
  /* framebuffers and renderbuffers */                                           \
  X(PFNGLGENFRAMEBUFFERSPROC, glGenFramebuffers)                                 \
  X(PFNGLDELETEFRAMEBUFFERSPROC, glDeleteFramebuffers)                           \
  X(PFNGLBINDFRAMEBUFFERPROC, glBindFramebuffer)                                 \
  X(PFNGLFRAMEBUFFERTEXTURE2DPROC, glFramebufferTexture2D)                       \
  X(PFNGLFRAMEBUFFERRENDERBUFFERPROC, glFramebufferRenderbuffer)                 \
  X(PFNGLCHECKFRAMEBUFFERSTATUSPROC, glCheckFramebufferStatus)                   \
  X(PFNGLGENRENDERBUFFERSPROC, glGenRenderbuffers)                               \
  X(PFNGLDELETERENDERBUFFERSPROC, glDeleteRenderbuffers)                         \
  X(PFNGLBINDRENDERBUFFERPROC, glBindRenderbuffer)                               \
  X(PFNGLRENDERBUFFERSTORAGEPROC, glRenderbufferStorage)                         \
  X(PFNGLBLITFRAMEBUFFERPROC, glBlitFramebuffer)                                 \
  /* shaders, programs, uniforms */                                              \
  X(PFNGLCREATESHADERPROC, glCreateShader)                                       \
  X(PFNGLDELETESHADERPROC, glDeleteShader)                                       \
  X(PFNGLSHADERSOURCEPROC, glShaderSource)                                       \
  X(PFNGLCOMPILESHADERPROC, glCompileShader)                                     \
  X(PFNGLGETSHADERIVPROC, glGetShaderiv)                                         \
  X(PFNGLGETSHADERINFOLOGPROC, glGetShaderInfoLog)                               \
  X(PFNGLCREATEPROGRAMPROC, glCreateProgram)                                     \
  X(PFNGLDELETEPROGRAMPROC, glDeleteProgram)                                     \
  X(PFNGLATTACHSHADERPROC, glAttachShader)                                       \
  X(PFNGLDETACHSHADERPROC, glDetachShader)                                       \
  X(PFNGLLINKPROGRAMPROC, glLinkProgram)                                         \
  X(PFNGLGETPROGRAMIVPROC, glGetProgramiv)                                       \
  X(PFNGLGETPROGRAMINFOLOGPROC, glGetProgramInfoLog)                             \
  X(PFNGLUSEPROGRAMPROC, glUseProgram)                                           \
  X(PFNGLGETUNIFORMLOCATIONPROC, glGetUniformLocation)                           \
  X(PFNGLGETATTRIBLOCATIONPROC, glGetAttribLocation)                             \
  X(PFNGLUNIFORM1IPROC, glUniform1i)                                             \
  X(PFNGLUNIFORM1IVPROC, glUniform1iv)                                           \
  X(PFNGLUNIFORM2IPROC, glUniform2i)                                             \
  X(PFNGLUNIFORM1FPROC, glUniform1f)                                             \
  X(PFNGLUNIFORM1FVPROC, glUniform1fv)                                           \
  X(PFNGLUNIFORM2FPROC, glUniform2f)                                             \
  X(PFNGLUNIFORM3FPROC, glUniform3f)                                             \
  X(PFNGLUNIFORM3FVPROC, glUniform3fv)                                           \
  X(PFNGLUNIFORM4FPROC, glUniform4f)                                             \
  X(PFNGLUNIFORM4FVPROC, glUniform4fv)                                           \
  X(PFNGLUNIFORMMATRIX4FVPROC, glUniformMatrix4fv)                               \
  X(PFNGLPROGRAMUNIFORM1IPROC, glProgramUniform1i)                               \
  X(PFNGLPROGRAMUNIFORM1IVPROC, glProgramUniform1iv)                             \
  X(PFNGLPROGRAMUNIFORM1FPROC, glProgramUniform1f)                               \
  X(PFNGLPROGRAMUNIFORM1FVPROC, glProgramUniform1fv)                             \
  X(PFNGLPROGRAMUNIFORM2FPROC, glProgramUniform2f)                               \
  X(PFNGLPROGRAMUNIFORM3FPROC, glProgramUniform3f)                               \
  X(PFNGLPROGRAMUNIFORM4FPROC, glProgramUniform4f)                               \
  X(PFNGLPROGRAMUNIFORM4IPROC, glProgramUniform4i)                               \
  X(PFNGLPROGRAMUNIFORMMATRIX4FVPROC, glProgramUniformMatrix4fv)                 \
  X(PFNGLGETUNIFORMBLOCKINDEXPROC, glGetUniformBlockIndex)                       \
  X(PFNGLUNIFORMBLOCKBINDINGPROC, glUniformBlockBinding)                         \
  /* transform feedback */                                                       \
  X(PFNGLTRANSFORMFEEDBACKVARYINGSPROC, glTransformFeedbackVaryings)             \
  X(PFNGLBEGINTRANSFORMFEEDBACKPROC, glBeginTransformFeedback)                   \
  X(PFNGLENDTRANSFORMFEEDBACKPROC, glEndTransformFeedback)                       \
  /* queries */                                                                  \
  X(PFNGLGENQUERIESPROC, glGenQueries)                                           \
  X(PFNGLDELETEQUERIESPROC, glDeleteQueries)                                     \
  X(PFNGLBEGINQUERYPROC, glBeginQuery)                                           \
  X(PFNGLENDQUERYPROC, glEndQuery)                                               \
  X(PFNGLQUERYCOUNTERPROC, glQueryCounter)                                       \
  X(PFNGLGETQUERYOBJECTIVPROC, glGetQueryObjectiv)                               \
  X(PFNGLGETQUERYOBJECTUI64VPROC, glGetQueryObjectui64v)

/// A function pointer as getProcAddress returns it, before the cast to the entry point's real type.
using GlProc = void (*)();

/// eglGetProcAddress and OSMesaGetProcAddress both have exactly this type, so neither needs a wrapper.
using GlProcLoader = GlProc (*)(const char* name);

/// The GL entry points of one context. Members are named exactly like the GL functions (gl.glClear(...)) so code
/// reads like plain GL and greps like it. Valid only while its context is current on the calling thread.
struct Gl {
#define VOXBRICK_GL_DECLARE(type, name) type name = nullptr;
  VOXBRICK_GL_FUNCTIONS(VOXBRICK_GL_DECLARE)
#undef VOXBRICK_GL_DECLARE
};

/// Fills every entry of the table through `loader`; throws RenderError naming the first entry point it lacks.
Gl loadGl(GlProcLoader loader, const char* loaderName);

/// Throws RenderError naming `what` and the GL error code if glGetError reports one (drains the error queue).
void checkGlError(const Gl& gl, const char* what);

}  // namespace voxbrick::render
