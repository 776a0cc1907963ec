// Tests of the headless GL contexts and objects: every backend opens and names itself, limits are sane, an FBO
// clear reads back exactly, compile errors are readable, GL objects are RAII, and contexts work side by side.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <thread>
#include <type_traits>
#include <vector>

#include "render/core/RenderErrors.h"
#include "render/gl/GlContext.h"
#include "render/gl/GlFixtures.h"
#include "render/gl/GlObjects.h"
#include "render/gl/Shaders.h"

namespace voxbrick::render {
namespace {

const std::vector<Backend> kBackends = {Backend::Auto, Backend::Egl, Backend::OsMesa};

// Clears a fresh width x height FBO of `format` to `colour` and returns the first mismatch, or "" if every texel
// reads back exactly.
std::string clearAndCompare(const GlContext& context, GLenum format, const float (&colour)[4], int width = 37,
                            int height = 23) {
  const Gl& gl = context.gl();
  Framebuffer fb = Framebuffer::withColor(gl, width, height, format);
  fb.bind();
  gl.glClearColor(colour[0], colour[1], colour[2], colour[3]);
  gl.glClear(GL_COLOR_BUFFER_BIT);
  const std::vector<float> pixels = fb.readRgba();
  checkGlError(gl, "clearAndCompare");
  for (size_t i = 0; i < pixels.size(); ++i) {
    if (pixels[i] != colour[i % 4]) {
      return "texel " + std::to_string(i / 4) + " channel " + std::to_string(i % 4) + " reads " +
             std::to_string(pixels[i]) + ", cleared to " + std::to_string(colour[i % 4]) + " on " + context.describe();
    }
  }
  return {};
}

TEST(Context, EveryBackendOpensAndNamesItself) {
  for (Backend backend : kBackends) {
    if (!test::backendExists(backend)) continue;
    std::unique_ptr<GlContext> context = createContext(backend);  // a failure to open throws: a test failure
    ASSERT_NE(context, nullptr);
    std::printf("[ info ] %s: %s\n", backendName(backend), context->describe().c_str());
    EXPECT_NE(context->backend(), Backend::Auto);
    if (backend != Backend::Auto) {
      EXPECT_EQ(context->backend(), backend);
    }
    const std::string description = context->describe();
    EXPECT_NE(description.find(context->renderer()), std::string::npos) << description;
    EXPECT_NE(description.find(context->version()), std::string::npos) << description;
    if (context->backend() == Backend::OsMesa) {
      EXPECT_EQ(description.rfind("OSMesa", 0), 0u) << description;
    } else {
      EXPECT_EQ(description.rfind("EGL ", 0), 0u) << description;
      // Software rendering through EGL goes through Mesa's surfaceless platform; the device platform is for GPUs.
      if (context->renderer().find("llvmpipe") != std::string::npos) {
        EXPECT_EQ(description.rfind("EGL surfaceless", 0), 0u) << description;
      }
    }
  }
  test::skipMissingBackends();
}

TEST(Context, LimitsAreQueriedAndSane) {
  for (Backend backend : {Backend::Egl, Backend::OsMesa}) {
    if (!test::backendExists(backend)) continue;
    std::unique_ptr<GlContext> context = createContext(backend);
    const GlLimits& limits = context->limits();
    const std::string where = context->describe();
    EXPECT_GE(limits.versionMajor * 10 + limits.versionMinor, 43) << where;
    EXPECT_GE(limits.max3DTextureSize, 2048) << where;  // the GL 4.3 minimum
    EXPECT_GE(limits.maxTextureSize, 16384) << where;
    EXPECT_GE(limits.maxTextureUnits, 48) << where;
    EXPECT_GE(limits.maxRenderbufferSize, 16384) << where;
    EXPECT_GE(limits.maxViewportWidth, 16384) << where;
    EXPECT_GE(limits.maxViewportHeight, 16384) << where;
    EXPECT_GE(limits.maxVertexAttribs, 16) << where;
    EXPECT_GE(limits.maxUniformBlockSize, 16384) << where;
    EXPECT_GE(limits.maxColorAttachments, 8) << where;
    EXPECT_GE(limits.maxFeedbackComponents, 64) << where;
  }
  test::skipMissingBackends();
}

TEST(Context, FramebufferClearReadsBackExactly) {
  for (Backend backend : {Backend::Egl, Backend::OsMesa}) {
    if (!test::backendExists(backend)) continue;
    std::unique_ptr<GlContext> context = createContext(backend);
    const float halfExact[4] = {0.25f, 0.5f, 0.75f, 1.0f};
    EXPECT_EQ(clearAndCompare(*context, GL_RGBA16F, halfExact), "");
    EXPECT_EQ(clearAndCompare(*context, GL_RGBA32F, halfExact), "");
    // Not representable in half floats: only the 32-bit target keeps it exactly.
    const float floatExact[4] = {0.1f, 1e-7f, 3.0f, -2.5f};
    EXPECT_EQ(clearAndCompare(*context, GL_RGBA32F, floatExact), "");
  }
  test::skipMissingBackends();
}

TEST(Context, FramebufferRejectsBadRequests) {
  std::unique_ptr<GlContext> context = createContext(Backend::Auto);
  EXPECT_THROW(Framebuffer::withColor(context->gl(), 0, 4, GL_RGBA32F), RenderInputError);
  EXPECT_THROW(Framebuffer::withColor(context->gl(), 4, 4, GL_RGBA8), RenderInputError);
  const int tooBig = context->limits().maxTextureSize * 2;
  EXPECT_THROW(Framebuffer::withColor(context->gl(), tooBig, 4, GL_RGBA32F), RenderError);
}

TEST(Context, ProgramErrorsNameTheShaderAndCarryTheLog) {
  std::unique_ptr<GlContext> context = createContext(Backend::Auto);
  ProgramSources sources = ProgramSources::fromFiles("probe", {});
  sources.stages.push_back({GL_VERTEX_SHADER, "broken.vert.glsl",
                            "// line 1\n// line 2\n// line 3\n// line 4\n// line 5\n"
                            "void main() {\n  gl_Position = undefinedThing;\n}\n"});
  try {
    Program program(context->gl(), sources);
    FAIL() << "a broken shader compiled";
  } catch (const RenderError& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("probe"), std::string::npos) << message;
    EXPECT_NE(message.find("broken.vert.glsl"), std::string::npos) << message;
    EXPECT_NE(message.find("undefinedThing"), std::string::npos) << message;
    // The error is on line 7 of the stage's own file ("#line 1 1" hides the preamble and the #defines); Mesa
    // writes "0:7(16)", NVIDIA "1(7)".
    EXPECT_TRUE(message.find(":7(") != std::string::npos || message.find("(7)") != std::string::npos) << message;
  }
  // An error in the library names it, with its own line numbers (source string 2): Mesa "2:2(", NVIDIA "2(2)".
  sources.stages.back().body = "void main() { gl_Position = vec4(helper()); }\n";
  sources.libraries = {{"helpers.glsl", "// line 1\nfloat helper() { return undefinedInLibrary; }\n"}};
  try {
    Program program(context->gl(), sources);
    FAIL() << "a broken library compiled";
  } catch (const RenderError& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("2 helpers.glsl"), std::string::npos) << message;
    EXPECT_NE(message.find("undefinedInLibrary"), std::string::npos) << message;
    EXPECT_TRUE(message.find("2:2(") != std::string::npos || message.find("2(2)") != std::string::npos) << message;
  }
  // A second library is source string 3, after the first.
  sources.libraries = {{"helpers.glsl", "float helper() { return 1.0; }\n"},
                       {"more.glsl", "// line 1\nfloat more() { return helper() + undefinedInMore; }\n"}};
  try {
    Program program(context->gl(), sources);
    FAIL() << "a broken second library compiled";
  } catch (const RenderError& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("2 helpers.glsl, 3 more.glsl"), std::string::npos) << message;
    EXPECT_TRUE(message.find("3:2(") != std::string::npos || message.find("3(2)") != std::string::npos) << message;
  }
  // The same program with a valid body links, with its library's helpers available (the slicers').
  sources.libraries = {{"slicer.glsl", std::string(shaderSource("slicer.glsl"))}};
  sources.stages.back().body = "void main() { gl_Position = vec4(unitCorner(gl_VertexID), 1.0); }\n";
  sources.defines = {"VOXBRICK_TEST_FEATURE", "VOXBRICK_TEST_VALUE 3"};
  Program program(context->gl(), sources);
  EXPECT_NE(program.id(), 0u);
  EXPECT_THROW(program.requireUniform("uNoSuchUniform"), RenderError);
  EXPECT_EQ(program.uniformLocation("uNoSuchUniform"), -1);
}

TEST(Context, GlObjectsAreMoveOnlyAndConstructibleEmpty) {
  static_assert(!std::is_copy_constructible_v<Buffer> && !std::is_copy_assignable_v<Buffer>);
  static_assert(std::is_nothrow_move_constructible_v<Program> && std::is_nothrow_move_assignable_v<Texture>);
  Buffer empty;
  EXPECT_EQ(empty.id(), 0u);
  EXPECT_FALSE(empty);
  std::unique_ptr<GlContext> context = createContext(Backend::Auto);
  Buffer first(context->gl());
  const GLuint id = first.id();
  EXPECT_NE(id, 0u);
  Buffer second = std::move(first);
  EXPECT_EQ(first.id(), 0u);  // NOLINT(bugprone-use-after-move): moved-from objects are empty by contract
  EXPECT_EQ(second.id(), id);
  const int data[4] = {1, 2, 3, 4};
  second.allocate(GL_ARRAY_BUFFER, sizeof(data), data, GL_STATIC_DRAW);
  int back[4] = {};
  second.read(0, sizeof(back), back);
  EXPECT_EQ(back[3], 4);
  second = Buffer(context->gl());  // deletes the old buffer, takes the new one
  EXPECT_NE(second.id(), 0u);
  second.reset();
  EXPECT_EQ(second.id(), 0u);
  Query query(context->gl());
  VertexArray vao(context->gl());
  Texture texture(context->gl(), GL_TEXTURE_3D);
  EXPECT_EQ(texture.target(), GLenum(GL_TEXTURE_3D));
  EXPECT_TRUE(query && vao && texture);
  checkGlError(context->gl(), "GlObjectsAreMoveOnlyAndConstructibleEmpty");
}

TEST(Context, ContextsCanBeCreatedRepeatedlyAndSideBySide) {
  for (Backend backend : {Backend::Egl, Backend::OsMesa}) {
    if (!test::backendExists(backend)) continue;
    for (int round = 0; round < 3; ++round) {
      std::unique_ptr<GlContext> first = createContext(backend);
      std::unique_ptr<GlContext> second = createContext(backend);  // now current instead of first
      const float red[4] = {1, 0, 0, 1}, green[4] = {0, 1, 0, 1};
      EXPECT_EQ(clearAndCompare(*second, GL_RGBA32F, green), "");
      first->makeCurrent();
      EXPECT_EQ(clearAndCompare(*first, GL_RGBA32F, red), "");
      // Destroying one context must leave the other (on the same EGL display) working.
      first.reset();
      second->makeCurrent();
      EXPECT_EQ(clearAndCompare(*second, GL_RGBA16F, red), "") << backendName(backend) << " round " << round;
    }
  }
  test::skipMissingBackends();
}

TEST(Context, TwoContextsInTwoThreads) {
  // One context per render thread, as the server runs them; each thread checks its own clear colour repeatedly.
  auto work = [](Backend backend, float shade, std::string* failure) {
    try {
      for (int round = 0; round < 3 && failure->empty(); ++round) {
        std::unique_ptr<GlContext> context = createContext(backend);
        for (int frame = 0; frame < 10 && failure->empty(); ++frame) {
          const float colour[4] = {shade, 0.125f * float(frame % 8), 0.5f, 1.0f};
          *failure = clearAndCompare(*context, GL_RGBA16F, colour, 64, 64);
        }
      }
    } catch (const std::exception& error) {
      *failure = error.what();
    }
  };
  for (auto [backendA, backendB] : {std::pair{Backend::Egl, Backend::Egl}, std::pair{Backend::OsMesa, Backend::OsMesa},
                                    std::pair{Backend::Egl, Backend::OsMesa}}) {
    if (!test::backendExists(backendA) || !test::backendExists(backendB)) continue;
    std::string failureA, failureB;
    std::thread a(work, backendA, 0.25f, &failureA);
    std::thread b(work, backendB, 0.75f, &failureB);
    a.join();
    b.join();
    EXPECT_EQ(failureA, "") << backendName(backendA) << " beside " << backendName(backendB);
    EXPECT_EQ(failureB, "") << backendName(backendB) << " beside " << backendName(backendA);
  }
  test::skipMissingBackends();
}

TEST(Context, BackendNamesParse) {
  for (Backend backend : kBackends) EXPECT_EQ(parseBackend(backendName(backend)), backend);
  EXPECT_THROW(parseBackend("vulkan"), RenderInputError);
}

}  // namespace
}  // namespace voxbrick::render
