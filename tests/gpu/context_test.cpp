// OpenGL plumbing: headless contexts, limits, and shader errors that name file and line.
#include "penumbra/gpu/context.h"
#include "penumbra/gpu/program.h"
#include "penumbra/raytrace/ray_engine_gl.h"
#include "support/test_util.h"

#include <gtest/gtest.h>

namespace penumbra {
namespace {

TEST(GlContext, HeadlessContextIsOpenGL45CoreWithUsableLimits) {
  PENUMBRA_GL_OR_SKIP();
  std::string why;
  const GlContext* ctx = test::glContext(why);
  const GlDeviceInfo& info = ctx->info();
  int major = 0, minor = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &major);
  glGetIntegerv(GL_MINOR_VERSION, &minor);
  EXPECT_GE(major * 10 + minor, 45) << info.version;
  GLint profile = 0;
  glGetIntegerv(GL_CONTEXT_PROFILE_MASK, &profile);
  EXPECT_TRUE(profile & GL_CONTEXT_CORE_PROFILE_BIT);
  EXPECT_FALSE(info.renderer.empty());
  EXPECT_GE(info.max_ssbo_bytes, int64_t(1) << 27);  // GL 4.5 minimum is 2^27
  EXPECT_GE(info.max_compute_invocations, 1024);
  EXPECT_GE(info.max_compute_group_count[0], 65535);
  EXPECT_GE(info.max_texture_size, 16384);
}

TEST(GlContext, ProbeListsTheContextThatWasMade) {
  PENUMBRA_GL_OR_SKIP();
  const GlProbe probe = probeGlDevices();
  ASSERT_FALSE(probe.devices.empty());
  std::string why;
  test::glContext(why)->makeCurrent();  // probing switched contexts
  bool found = false;
  for (const GlDeviceInfo& d : probe.devices) {
    found |= d.renderer == test::glContext(why)->info().renderer;
  }
  EXPECT_TRUE(found);
}

TEST(GlProgram, CompileErrorNamesShaderFileAndLine) {
  PENUMBRA_GL_OR_SKIP();
  const std::string source =
      "#version 450\n"
      "#include \"raytrace/layout.glsl\"\n"
      "layout(local_size_x = 1) in;\n"
      "void main() {\n"
      "  float x = undefined_name;\n"
      "}\n";
  Expected<gl::Program> p = gl::computeProgramFromSource("test/broken.comp", source);
  ASSERT_FALSE(p.ok());
  const std::string msg = p.error().describe();
  EXPECT_NE(msg.find("shaders/test/broken.comp:5"), std::string::npos) << msg;
  EXPECT_NE(msg.find("undefined_name"), std::string::npos) << msg;
}

TEST(GlProgram, EveryEmbeddedComputeShaderCompiles) {
  PENUMBRA_GL_OR_SKIP();
  Expected<gl::Program> p =
      gl::computeProgram("raytrace/bvh_intersect.comp", bvhIntersectDefines());
  EXPECT_TRUE(p.ok()) << p.error().describe();
}

TEST(GlProgram, InfoLogsAreMappedToFiles) {
  const std::vector<std::string> files = {"raytrace/a.comp", "common/b.glsl"};
  EXPECT_EQ(gl::mapInfoLog("1:7(3): error: bad thing\n", files),
            "shaders/common/b.glsl:7: error: bad thing");
  EXPECT_EQ(gl::mapInfoLog("0(12) : error C1008: undefined", files),
            "shaders/raytrace/a.comp:12: error C1008: undefined");
}

}  // namespace
}  // namespace penumbra
