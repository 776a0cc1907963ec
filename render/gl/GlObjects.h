// RAII owners of GL objects: move-only, constructible empty, deleted with the context they were made in.
//
// Each keeps a pointer to its context's Gl table, so it must be destroyed (or reset) while that context is alive
// and current on the destroying thread; an empty object (id() == 0) can be destroyed anywhere.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "render/gl/GlFunctions.h"

namespace voxbrick::render {

namespace detail {

/// One GL name plus the table that deletes it. `Delete` is called with a non-zero name exactly once.
template <void (*Delete)(const Gl&, GLuint)>
class GlName {
 public:
  GlName() = default;
  GlName(const Gl& gl, GLuint id) : mGl(&gl), mId(id) {}
  ~GlName() { reset(); }
  GlName(GlName&& other) noexcept : mGl(other.mGl), mId(std::exchange(other.mId, 0)) {}
  GlName& operator=(GlName&& other) noexcept {
    if (this != &other) {
      reset();
      mGl = other.mGl;
      mId = std::exchange(other.mId, 0);
    }
    return *this;
  }
  GlName(const GlName&) = delete;
  GlName& operator=(const GlName&) = delete;

  /// The GL name, 0 when empty.
  GLuint id() const { return mId; }
  /// True unless empty.
  explicit operator bool() const { return mId != 0; }
  /// The table it was made with; nullptr when default-constructed.
  const Gl* gl() const { return mGl; }
  /// Deletes the GL object now (the context must be current); the object becomes empty.
  void reset() {
    if (mId != 0) Delete(*mGl, std::exchange(mId, 0));
  }

 private:
  const Gl* mGl = nullptr;
  GLuint mId = 0;
};

void deleteBuffer(const Gl& gl, GLuint id);
void deleteVertexArray(const Gl& gl, GLuint id);
void deleteTexture(const Gl& gl, GLuint id);
void deleteFramebuffer(const Gl& gl, GLuint id);
void deleteProgram(const Gl& gl, GLuint id);
void deleteQuery(const Gl& gl, GLuint id);

}  // namespace detail

/// A buffer object (vertex, instance, uniform, transform-feedback or pixel-pack data).
class Buffer : public detail::GlName<detail::deleteBuffer> {
 public:
  Buffer() = default;
  /// Generates a new, unallocated buffer.
  explicit Buffer(const Gl& gl);
  /// Binds it to `target` and (re)allocates `bytes` bytes, copying from `data` unless it is nullptr.
  void allocate(GLenum target, size_t bytes, const void* data, GLenum usage);
  /// Binds it to `target`.
  void bind(GLenum target) const;
  /// Copies `bytes` bytes from offset `offset` into `out` (binds to GL_COPY_READ_BUFFER; waits for the GPU).
  void read(size_t offset, size_t bytes, void* out) const;
};

/// A vertex array object: the attribute layout of one kind of draw.
class VertexArray : public detail::GlName<detail::deleteVertexArray> {
 public:
  VertexArray() = default;
  /// Generates a new vertex array.
  explicit VertexArray(const Gl& gl);
  /// Binds it.
  void bind() const;
};

/// A texture object of one target (GL_TEXTURE_1D, GL_TEXTURE_2D, GL_TEXTURE_3D, ...).
class Texture : public detail::GlName<detail::deleteTexture> {
 public:
  Texture() = default;
  /// Generates a new texture for `target` (storage is the caller's: glTexStorage*/glTexImage*).
  Texture(const Gl& gl, GLenum target);
  /// The target it was made for.
  GLenum target() const { return mTarget; }
  /// Makes `unit` active and binds it there.
  void bind(int unit) const;

 private:
  GLenum mTarget = 0;
};

/// A framebuffer object, optionally owning a float colour texture that it renders into.
class Framebuffer : public detail::GlName<detail::deleteFramebuffer> {
 public:
  Framebuffer() = default;
  /// Generates a new framebuffer with no attachments.
  explicit Framebuffer(const Gl& gl);
  /// A complete framebuffer with one width x height colour texture of `internalFormat` (GL_RGBA16F or GL_RGBA32F)
  /// at GL_COLOR_ATTACHMENT0; throws RenderInputError on a bad size or format, RenderError if it is incomplete.
  static Framebuffer withColor(const Gl& gl, int width, int height, GLenum internalFormat);
  /// Binds it as the draw and read framebuffer and sets the viewport to its size.
  void bind() const;
  /// Throws RenderError naming the status if it is not complete (binds it).
  void checkComplete(const char* what) const;
  /// Reads the colour attachment as RGBA floats, bottom row first (binds it).
  std::vector<float> readRgba() const;
  /// The same into `pixels`, resized to fit: a buffer kept from frame to frame is not faulted in again.
  void readRgba(std::vector<float>& pixels) const;
  /// The colour texture made by withColor (empty otherwise).
  const Texture& color() const { return mColor; }
  int width() const { return mWidth; }
  int height() const { return mHeight; }

 private:
  Texture mColor;
  int mWidth = 0;
  int mHeight = 0;
};

/// One stage of a program: its type (GL_VERTEX_SHADER, ...), a name for messages, and the GLSL body.
struct ShaderStage {
  GLenum type = 0;
  std::string name;
  std::string body;
};

/// A library of GLSL helpers that every stage of a program gets: a name for messages and its text.
struct ShaderLibrary {
  std::string name;
  std::string body;
};

/// What a Program is made of: the shared preamble, one "#define" line per feature, the libraries, then each stage's
/// body.
struct ProgramSources {
  std::string name;                           ///< for error messages
  std::string preamble;                       ///< starts with #version; shared by every stage
  std::vector<std::string> defines;           ///< "FEATURE" or "NAME value", each becomes one #define line
  std::vector<ShaderLibrary> libraries;       ///< after the defines, in order: source strings 2, 3, ... ; may be empty
  std::vector<ShaderStage> stages;            ///< at least one
  std::vector<std::string> feedbackVaryings;  ///< if not empty, captured interleaved by transform feedback

  /// Sources from the embedded shaders/ files: preamble.glsl and Bindings.h (the binding points C++ shares) as the
  /// preamble, the named stage files, and `libraryFile` (if not null) as the library.
  static ProgramSources fromFiles(std::string name, std::vector<std::pair<GLenum, std::string>> stageFiles,
                                  std::vector<std::string> defines = {}, const char* libraryFile = nullptr);
  /// The same with the libraries `libraryFiles`, in that order.
  static ProgramSources fromFiles(std::string name, std::vector<std::pair<GLenum, std::string>> stageFiles,
                                  std::vector<std::string> defines, const std::vector<std::string>& libraryFiles);
};

/// Milliseconds the calling thread has spent compiling and linking programs (every Program built on it, failed
/// builds included) since it started: a frame's one-time work on its context (RenderEngine: FrameStats::msWarmup).
double programBuildMsOnThisThread();

/// A linked GLSL program. Uniform setters use glProgramUniform*, so the program need not be in use.
class Program : public detail::GlName<detail::deleteProgram> {
 public:
  Program() = default;
  /// Compiles and links; throws RenderError with the program and stage names and the driver's info log.
  Program(const Gl& gl, const ProgramSources& sources);
  /// Makes it the current program.
  void use() const;
  /// glGetUniformLocation: -1 if the program has no active uniform of that name.
  GLint uniformLocation(const char* name) const;
  /// Like uniformLocation but throws RenderError naming the uniform when it is not active.
  GLint requireUniform(const char* name) const;
  /// Setters for one uniform; a location of -1 is ignored, as GL does.
  void set(GLint location, int value) const;
  void set(GLint location, float value) const;
  void set(GLint location, const glm::vec2& value) const;
  void set(GLint location, const glm::vec3& value) const;
  void set(GLint location, const glm::vec4& value) const;
  void set(GLint location, const glm::ivec4& value) const;
  void set(GLint location, const glm::mat4& value) const;
  void set(GLint location, std::span<const int> values) const;
  void set(GLint location, std::span<const float> values) const;
  /// The name it was built with.
  const std::string& name() const { return mName; }

 private:
  std::string mName;
};

/// A query object (GL_TIME_ELAPSED, GL_SAMPLES_PASSED, GL_PRIMITIVES_GENERATED, ...).
class Query : public detail::GlName<detail::deleteQuery> {
 public:
  Query() = default;
  /// Generates a new query object.
  explicit Query(const Gl& gl);
  /// The 64-bit result; waits for it.
  uint64_t result() const;
};

}  // namespace voxbrick::render
