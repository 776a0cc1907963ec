// Creation, deletion and the few helpers of the RAII GL objects; program compilation with readable errors.
#include "render/gl/GlObjects.h"

#include <algorithm>
#include <cctype>
#include <chrono>

#include <glm/gtc/type_ptr.hpp>

#include "render/core/FrameStats.h"
#include "render/core/RenderErrors.h"
#include "render/gl/Shaders.h"

namespace voxbrick::render {

namespace detail {

void deleteBuffer(const Gl& gl, GLuint id) { gl.glDeleteBuffers(1, &id); }
void deleteVertexArray(const Gl& gl, GLuint id) { gl.glDeleteVertexArrays(1, &id); }
void deleteTexture(const Gl& gl, GLuint id) { gl.glDeleteTextures(1, &id); }
void deleteFramebuffer(const Gl& gl, GLuint id) { gl.glDeleteFramebuffers(1, &id); }
void deleteProgram(const Gl& gl, GLuint id) { gl.glDeleteProgram(id); }
void deleteQuery(const Gl& gl, GLuint id) { gl.glDeleteQueries(1, &id); }

}  // namespace detail

namespace {

template <void (*Gen)(const Gl&, GLuint*)>
GLuint generate(const Gl& gl, const char* what) {
  GLuint id = 0;
  Gen(gl, &id);
  if (id == 0) throw RenderError(std::string(what) + ": the driver returned no object name");
  return id;
}

void genBuffer(const Gl& gl, GLuint* id) { gl.glGenBuffers(1, id); }
void genVertexArray(const Gl& gl, GLuint* id) { gl.glGenVertexArrays(1, id); }
void genTexture(const Gl& gl, GLuint* id) { gl.glGenTextures(1, id); }
void genFramebuffer(const Gl& gl, GLuint* id) { gl.glGenFramebuffers(1, id); }
void genQuery(const Gl& gl, GLuint* id) { gl.glGenQueries(1, id); }

std::string framebufferStatusName(GLenum status) {
  switch (status) {
    case GL_FRAMEBUFFER_UNDEFINED: return "GL_FRAMEBUFFER_UNDEFINED";
    case GL_FRAMEBUFFER_INCOMPLETE_ATTACHMENT: return "GL_FRAMEBUFFER_INCOMPLETE_ATTACHMENT";
    case GL_FRAMEBUFFER_INCOMPLETE_MISSING_ATTACHMENT: return "GL_FRAMEBUFFER_INCOMPLETE_MISSING_ATTACHMENT";
    case GL_FRAMEBUFFER_UNSUPPORTED: return "GL_FRAMEBUFFER_UNSUPPORTED";
    case GL_FRAMEBUFFER_INCOMPLETE_MULTISAMPLE: return "GL_FRAMEBUFFER_INCOMPLETE_MULTISAMPLE";
    default: return "status 0x" + std::to_string(status);
  }
}

std::string stageName(GLenum type) {
  switch (type) {
    case GL_VERTEX_SHADER: return "vertex";
    case GL_FRAGMENT_SHADER: return "fragment";
    case GL_GEOMETRY_SHADER: return "geometry";
    case GL_COMPUTE_SHADER: return "compute";
    default: return "stage 0x" + std::to_string(type);
  }
}

// Deletes the shader objects when compilation or linking leaves the scope, however it leaves.
struct ShaderList {
  const Gl& gl;
  std::vector<GLuint> ids;
  ~ShaderList() {
    for (GLuint id : ids) gl.glDeleteShader(id);
  }
};

/// Milliseconds this thread spent building programs (Program's constructor), for programBuildMsOnThisThread.
thread_local double tProgramBuildMs = 0;

/// Adds the time from its construction to its destruction to tProgramBuildMs, however the build ends.
struct ProgramBuildTimer {
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
  ~ProgramBuildTimer() {
    tProgramBuildMs += msSince(start);
  }
};

}  // namespace

double programBuildMsOnThisThread() { return tProgramBuildMs; }

Buffer::Buffer(const Gl& gl) : GlName(gl, generate<genBuffer>(gl, "Buffer")) {}

void Buffer::allocate(GLenum target, size_t bytes, const void* data, GLenum usage) {
  gl()->glBindBuffer(target, id());
  gl()->glBufferData(target, GLsizeiptr(bytes), data, usage);
  checkGlError(*gl(), ("Buffer::allocate(" + std::to_string(bytes) + " bytes)").c_str());
}

void Buffer::bind(GLenum target) const { gl()->glBindBuffer(target, id()); }

void Buffer::read(size_t offset, size_t bytes, void* out) const {
  gl()->glBindBuffer(GL_COPY_READ_BUFFER, id());
  gl()->glGetBufferSubData(GL_COPY_READ_BUFFER, GLintptr(offset), GLsizeiptr(bytes), out);
  checkGlError(*gl(), "Buffer::read");
}

VertexArray::VertexArray(const Gl& gl) : GlName(gl, generate<genVertexArray>(gl, "VertexArray")) {}

void VertexArray::bind() const { gl()->glBindVertexArray(id()); }

Texture::Texture(const Gl& gl, GLenum target) : GlName(gl, generate<genTexture>(gl, "Texture")), mTarget(target) {}

void Texture::bind(int unit) const {
  gl()->glActiveTexture(GLenum(GL_TEXTURE0 + unit));
  gl()->glBindTexture(mTarget, id());
}

Framebuffer::Framebuffer(const Gl& gl) : GlName(gl, generate<genFramebuffer>(gl, "Framebuffer")) {}

Framebuffer Framebuffer::withColor(const Gl& gl, int width, int height, GLenum internalFormat) {
  if (width <= 0 || height <= 0) {
    throw RenderInputError("Framebuffer::withColor: bad size " + std::to_string(width) + "x" + std::to_string(height));
  }
  if (internalFormat != GL_RGBA16F && internalFormat != GL_RGBA32F) {
    throw RenderInputError("Framebuffer::withColor: format 0x" + std::to_string(internalFormat) +
                           " is neither GL_RGBA16F nor GL_RGBA32F");
  }
  Framebuffer fb(gl);
  fb.mWidth = width;
  fb.mHeight = height;
  fb.mColor = Texture(gl, GL_TEXTURE_2D);
  gl.glBindTexture(GL_TEXTURE_2D, fb.mColor.id());
  gl.glTexStorage2D(GL_TEXTURE_2D, 1, internalFormat, width, height);
  gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  checkGlError(
      gl, ("Framebuffer::withColor: colour texture " + std::to_string(width) + "x" + std::to_string(height)).c_str());
  gl.glBindFramebuffer(GL_FRAMEBUFFER, fb.id());
  gl.glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, fb.mColor.id(), 0);
  const GLenum drawBuffer = GL_COLOR_ATTACHMENT0;
  gl.glDrawBuffers(1, &drawBuffer);
  gl.glReadBuffer(GL_COLOR_ATTACHMENT0);
  fb.checkComplete("Framebuffer::withColor");
  return fb;
}

void Framebuffer::bind() const {
  gl()->glBindFramebuffer(GL_FRAMEBUFFER, id());
  gl()->glViewport(0, 0, mWidth, mHeight);
}

void Framebuffer::checkComplete(const char* what) const {
  gl()->glBindFramebuffer(GL_FRAMEBUFFER, id());
  const GLenum status = gl()->glCheckFramebufferStatus(GL_FRAMEBUFFER);
  if (status != GL_FRAMEBUFFER_COMPLETE) {
    throw RenderError(std::string(what) + ": framebuffer incomplete (" + framebufferStatusName(status) + ")");
  }
}

std::vector<float> Framebuffer::readRgba() const {
  std::vector<float> pixels;
  readRgba(pixels);
  return pixels;
}

void Framebuffer::readRgba(std::vector<float>& pixels) const {
  pixels.resize(size_t(mWidth) * size_t(mHeight) * 4);
  gl()->glBindFramebuffer(GL_FRAMEBUFFER, id());
  gl()->glReadBuffer(GL_COLOR_ATTACHMENT0);
  gl()->glPixelStorei(GL_PACK_ALIGNMENT, 4);
  gl()->glReadPixels(0, 0, mWidth, mHeight, GL_RGBA, GL_FLOAT, pixels.data());
  checkGlError(*gl(), "Framebuffer::readRgba");
}

ProgramSources ProgramSources::fromFiles(std::string name, std::vector<std::pair<GLenum, std::string>> stageFiles,
                                         std::vector<std::string> defines, const char* libraryFile) {
  std::vector<std::string> libraryFiles;
  if (libraryFile != nullptr) libraryFiles.emplace_back(libraryFile);
  return fromFiles(std::move(name), std::move(stageFiles), std::move(defines), libraryFiles);
}

ProgramSources ProgramSources::fromFiles(std::string name, std::vector<std::pair<GLenum, std::string>> stageFiles,
                                         std::vector<std::string> defines,
                                         const std::vector<std::string>& libraryFiles) {
  ProgramSources sources;
  sources.name = std::move(name);
  sources.preamble = std::string(shaderSource("preamble.glsl")) + "\n" + std::string(shaderSource("Bindings.h"));
  sources.defines = std::move(defines);
  for (const std::string& file : libraryFiles) sources.libraries.push_back({file, std::string(shaderSource(file))});
  for (auto& [type, file] : stageFiles) sources.stages.push_back({type, file, std::string(shaderSource(file))});
  return sources;
}

Program::Program(const Gl& gl, const ProgramSources& sources) : GlName(gl, gl.glCreateProgram()), mName(sources.name) {
  const ProgramBuildTimer timer;
  if (id() == 0) throw RenderError("Program " + mName + ": glCreateProgram failed");
  if (sources.stages.empty()) throw RenderInputError("Program " + mName + ": no shader stages");
  // What every stage has before its own file: the defines, then the libraries as source strings 2, 3, ..., so that
  // the info log's line numbers are those of their files.
  std::string head;
  for (const std::string& define : sources.defines) head += "#define " + define + "\n";
  std::string sourceNumbers = "source 0 is the preamble";
  for (size_t i = 0; i < sources.libraries.size(); ++i) {
    const std::string number = std::to_string(i + 2);
    head += "#line 1 " + number + "\n" + sources.libraries[i].body + "\n";
    sourceNumbers += ", " + number + " " + sources.libraries[i].name;
  }
  ShaderList shaders{gl, {}};
  for (const ShaderStage& stage : sources.stages) {
    const GLuint shader = gl.glCreateShader(stage.type);
    if (shader == 0) throw RenderError("Program " + mName + ": glCreateShader(" + stageName(stage.type) + ") failed");
    shaders.ids.push_back(shader);
    // "#line 1 1" restarts counting so that the info log's line numbers are those of the stage's own file (source
    // string 1, where the driver reports it; the preamble is source 0).
    // Each stage also knows which it is (VERTEX_STAGE, GEOMETRY_STAGE, ...), so that a library can declare what only
    // one stage may (a vertex program's attributes).
    std::string stageMacro = stageName(stage.type);
    for (char& c : stageMacro) c = char(std::toupper(static_cast<unsigned char>(c)));
    const std::string body = "#define " + stageMacro + "_STAGE\n" + head + "#line 1 1\n" + stage.body;
    const char* strings[] = {sources.preamble.c_str(), "\n", body.c_str()};
    gl.glShaderSource(shader, 3, strings, nullptr);
    gl.glCompileShader(shader);
    GLint ok = GL_FALSE;
    gl.glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
    if (ok != GL_TRUE) {
      GLint length = 0;
      gl.glGetShaderiv(shader, GL_INFO_LOG_LENGTH, &length);
      std::string log(size_t(std::max(length, 1)), '\0');
      gl.glGetShaderInfoLog(shader, GLsizei(log.size()), nullptr, log.data());
      throw RenderError("Program " + mName + ": " + stageName(stage.type) + " shader " + stage.name +
                        " does not compile (lines of " + stage.name + "; " + sourceNumbers + "):\n" + log.c_str());
    }
    gl.glAttachShader(id(), shader);
  }
  if (!sources.feedbackVaryings.empty()) {
    std::vector<const char*> names;
    for (const std::string& varying : sources.feedbackVaryings) names.push_back(varying.c_str());
    gl.glTransformFeedbackVaryings(id(), GLsizei(names.size()), names.data(), GL_INTERLEAVED_ATTRIBS);
  }
  gl.glLinkProgram(id());
  for (GLuint shader : shaders.ids) gl.glDetachShader(id(), shader);
  GLint ok = GL_FALSE;
  gl.glGetProgramiv(id(), GL_LINK_STATUS, &ok);
  if (ok != GL_TRUE) {
    GLint length = 0;
    gl.glGetProgramiv(id(), GL_INFO_LOG_LENGTH, &length);
    std::string log(size_t(std::max(length, 1)), '\0');
    gl.glGetProgramInfoLog(id(), GLsizei(log.size()), nullptr, log.data());
    throw RenderError("Program " + mName + ": does not link:\n" + log.c_str());
  }
}

void Program::use() const { gl()->glUseProgram(id()); }

GLint Program::uniformLocation(const char* name) const { return gl()->glGetUniformLocation(id(), name); }

GLint Program::requireUniform(const char* name) const {
  const GLint location = uniformLocation(name);
  if (location < 0) throw RenderError("Program " + mName + ": no active uniform " + name);
  return location;
}

void Program::set(GLint location, int value) const { gl()->glProgramUniform1i(id(), location, value); }
void Program::set(GLint location, float value) const { gl()->glProgramUniform1f(id(), location, value); }
void Program::set(GLint location, const glm::vec2& value) const {
  gl()->glProgramUniform2f(id(), location, value.x, value.y);
}
void Program::set(GLint location, const glm::vec3& value) const {
  gl()->glProgramUniform3f(id(), location, value.x, value.y, value.z);
}
void Program::set(GLint location, const glm::vec4& value) const {
  gl()->glProgramUniform4f(id(), location, value.x, value.y, value.z, value.w);
}
void Program::set(GLint location, const glm::ivec4& value) const {
  gl()->glProgramUniform4i(id(), location, value.x, value.y, value.z, value.w);
}
void Program::set(GLint location, const glm::mat4& value) const {
  gl()->glProgramUniformMatrix4fv(id(), location, 1, GL_FALSE, glm::value_ptr(value));
}
void Program::set(GLint location, std::span<const int> values) const {
  gl()->glProgramUniform1iv(id(), location, GLsizei(values.size()), values.data());
}
void Program::set(GLint location, std::span<const float> values) const {
  gl()->glProgramUniform1fv(id(), location, GLsizei(values.size()), values.data());
}

Query::Query(const Gl& gl) : GlName(gl, generate<genQuery>(gl, "Query")) {}

uint64_t Query::result() const {
  GLuint64 value = 0;
  gl()->glGetQueryObjectui64v(id(), GL_QUERY_RESULT, &value);
  return value;
}

}  // namespace voxbrick::render
