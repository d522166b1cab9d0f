// The GPU twins of the subsurface method against the CPU: the dipole and Fresnel functions of
// shaders/common/dipole.glsl against kernels/dipole.h, and passes 1 and 2 on the device
// (subsurface/sss_gl.h) against SssSolver's on the bunny with a point, a spot and a directional
// light.
#include "penumbra/subsurface/sss_gl.h"
#include "penumbra/core/rng.h"
#include "penumbra/gpu/program.h"
#include "penumbra/io/image_io.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/kernels/dipole.h"
#include "penumbra/raytrace/lights.h"
#include "penumbra/scene/media.h"
#include "penumbra/subsurface/sss.h"
#include "support/test_util.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/vec4.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <vector>

namespace penumbra {
namespace {

TEST(Dipole, GlslTwinAgreesWithCpp) {
  PENUMBRA_GL_OR_SKIP();
  const std::string source =
      "#version 450\n"
      "#include \"common/dipole.glsl\"\n"
      "layout(local_size_x = 64) in;\n"
      "layout(std430, binding = 0) readonly buffer In { vec4 cases[]; };\n"
      "layout(std430, binding = 1) readonly buffer Channels { vec4 channels[]; };\n"
      "layout(std430, binding = 2) writeonly buffer Out { vec2 results[]; };\n"
      "uniform uint count;\n"
      "void main() {\n"
      "  uint i = gl_GlobalInvocationID.x;\n"
      "  if (i >= count) return;\n"
      "  vec4 c = cases[i];  // eta, cos, r, channel\n"
      "  results[i] = vec2(fresnelTransmittance(c.x, c.y),\n"
      "                    dipoleReflectance(channels[uint(c.w)], c.z));\n"
      "}\n";
  Expected<gl::Program> program = gl::computeProgramFromSource("test/dipole.comp", source);
  ASSERT_TRUE(program.ok()) << program.error().describe();
  // Every preset's channels (lengths in mm, so that R_d stays in float's range), at distances
  // from 0 to 20 diffusion lengths, with indices 1 to 2 and every angle.
  std::vector<DipoleChannel> channels;
  for (const char* name : subsurfacePresetNames()) {
    const Subsurface s = *subsurfacePreset(name);
    const Dipole d(s.sigma_s_prime * 1e-3, s.sigma_a * 1e-3, s.eta);
    for (const DipoleChannel& c : d.channel) channels.push_back(c);
  }
  std::vector<glm::vec4> channel_data;
  for (const DipoleChannel& c : channels) {
    channel_data.emplace_back(float(c.alpha), float(c.sigma_tr), float(c.z_r), float(c.z_v));
  }
  std::vector<glm::vec4> cases;
  for (size_t k = 0; k < channels.size(); ++k) {
    for (int i = 0; i < 64; ++i) {
      const double eta = 1.0 + (i % 8) / 7.0;
      const double cos_t = (i % 16) / 15.0;
      const double length =
          channels[k].sigma_tr > 0.0 ? 1.0 / channels[k].sigma_tr : 100.0 * channels[k].z_r;
      const double r = 20.0 * length * (i / 63.0) * (i / 63.0);
      cases.emplace_back(float(eta), float(cos_t), float(r), float(k));
    }
  }
  gl::Buffer in(cases.size() * 16, cases.data());
  gl::Buffer ch(channel_data.size() * 16, channel_data.data());
  gl::Buffer out(cases.size() * 8, nullptr);
  glUseProgram(program->id());
  glUniform1ui(gl::uniformLocation(program->id(), "count"), GLuint(cases.size()));
  in.bindBase(GL_SHADER_STORAGE_BUFFER, 0);
  ch.bindBase(GL_SHADER_STORAGE_BUFFER, 1);
  out.bindBase(GL_SHADER_STORAGE_BUFFER, 2);
  glDispatchCompute(GLuint((cases.size() + 63) / 64), 1, 1);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  std::vector<glm::vec2> results(cases.size());
  out.download(results.data(), results.size() * 8);
  glUseProgram(0);
  ASSERT_EQ(glGetError(), GLenum(GL_NO_ERROR));
  for (size_t i = 0; i < cases.size(); ++i) {
    const glm::vec4 c = cases[i];
    // The GPU reads the float inputs; the CPU gets the same floats, in double.
    const double ft = fresnelTransmittance(double(c.x), double(c.y));
    const DipoleChannel& ch_cpu = channels[size_t(c.w)];
    DipoleChannel f;  // the channel as the GPU has it
    f.alpha = double(channel_data[size_t(c.w)].x);
    f.sigma_tr = double(channel_data[size_t(c.w)].y);
    f.z_r = double(channel_data[size_t(c.w)].z);
    f.z_v = double(channel_data[size_t(c.w)].w);
    const double rd = f.reflectance(double(c.z));
    EXPECT_NEAR(results[i].x, ft, 2e-6) << "eta " << c.x << " cos " << c.y;
    // exp and the cubes in float: about 1e-6 relative, 20 diffusion lengths out included.
    EXPECT_NEAR(results[i].y / rd, 1.0, 2e-5) << "r " << c.z << " channel " << c.w;
    EXPECT_NEAR(rd / ch_cpu.reflectance(double(c.z)), 1.0, 1e-5);
  }
}

TEST(Lights, GlslTwinAgreesWithCpp) {
  // shaders/common/lights.glsl's sampleLight against raytrace/lights.h's, for point, spot and
  // directional lights and a luminaire (its light distribution texture, common/luminaire.glsl)
  // at random points, normals facing towards and away from them.
  PENUMBRA_GL_OR_SKIP();
  std::string defines;
  for (const std::string& d : gpuLightDefines()) defines += "#define " + d + "\n";
  const std::string source =
      "#version 450\n" + defines +
      "#include \"common/lights.glsl\"\n"
      "layout(local_size_x = 64) in;\n"
      "layout(std430, binding = 0) readonly buffer Lights { GpuLight lights[]; };\n"
      "layout(std430, binding = 1) readonly buffer Points { vec4 points[]; };\n"
      "layout(std430, binding = 2) writeonly buffer Out { vec4 results[]; };\n"
      "layout(std430, binding = 3) readonly buffer Tables { float tables[]; };\n"
      "float luminaireTable(uint index) { return tables[index]; }\n"
      "uniform uint count;\n"
      "void main() {\n"
      "  uint i = gl_GlobalInvocationID.x;\n"
      "  if (i >= count) return;\n"
      "  vec3 p = points[3u * i].xyz, ng = points[3u * i + 1u].xyz, ns = points[3u * i + 2u].xyz;\n"
      "  LightSample s = sampleLight(lights[i % 4u], p, ng, ns);\n"
      "  results[2u * i] = vec4(s.irradiance, s.distance);\n"
      "  results[2u * i + 1u] = vec4(s.direction, 0.0);\n"
      "}\n";
  Expected<gl::Program> program = gl::computeProgramFromSource("test/lights.comp", source);
  ASSERT_TRUE(program.ok()) << program.error().describe();
  const std::vector<Light> lights = {
      PointLight{glm::vec3(0.3f, 1.2f, -0.4f), glm::vec3(2.0f, 1.5f, 1.0f)},
      SpotLight{glm::vec3(-0.5f, 1.0f, 0.2f), glm::normalize(glm::vec3(0.3f, -1.0f, 0.1f)),
                glm::vec3(3.0f), 0.2f, 0.7f},
      DirectionalLight{glm::normalize(glm::vec3(0.2f, -1.0f, -0.3f)), glm::vec3(0.8f)},
      test::testLuminaire()};
  std::vector<float> tables;
  const std::vector<GpuLight> gpu_lights = gpuLights(lights, tables);
  constexpr size_t kCount = 4 * 2048;
  Rng rng(5, 2);
  std::vector<glm::vec4> points;
  for (size_t i = 0; i < kCount; ++i) {
    const glm::vec3 p(2.0f * rng.uniform() - 1.0f, 0.5f * rng.uniform(),
                      2.0f * rng.uniform() - 1.0f);
    const glm::vec3 ng =
        glm::normalize(glm::vec3(rng.uniform() - 0.5f, rng.uniform() - 0.3f, rng.uniform() - 0.5f));
    const glm::vec3 ns =
        glm::normalize(ng + 0.2f * glm::vec3(rng.uniform() - 0.5f, 0.0f, rng.uniform() - 0.5f));
    points.emplace_back(p, 0.0f);
    points.emplace_back(ng, 0.0f);
    points.emplace_back(ns, 0.0f);
  }
  gl::Buffer light_buf(gpu_lights.size() * sizeof(GpuLight), gpu_lights.data());
  gl::Buffer point_buf(points.size() * 16, points.data());
  gl::Buffer out(kCount * 32, nullptr);
  gl::Buffer table_buf(tables.size() * sizeof(float), tables.data());
  table_buf.bindBase(GL_SHADER_STORAGE_BUFFER, 3);
  glUseProgram(program->id());
  glUniform1ui(gl::uniformLocation(program->id(), "count"), GLuint(kCount));
  light_buf.bindBase(GL_SHADER_STORAGE_BUFFER, 0);
  point_buf.bindBase(GL_SHADER_STORAGE_BUFFER, 1);
  out.bindBase(GL_SHADER_STORAGE_BUFFER, 2);
  glDispatchCompute(GLuint(kCount / 64), 1, 1);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  std::vector<glm::vec4> results(2 * kCount);
  out.download(results.data(), results.size() * 16);
  glUseProgram(0);
  ASSERT_EQ(glGetError(), GLenum(GL_NO_ERROR));
  size_t lit = 0;
  double worst_luminaire = 0.0;
  for (size_t i = 0; i < kCount; ++i) {
    const LightSample cpu =
        sampleLight(lights[i % 4], glm::dvec3(points[3 * i]), glm::dvec3(points[3 * i + 1]),
                    glm::dvec3(points[3 * i + 2]));
    const glm::vec3 e(results[2 * i]);
    const double scale =
        std::max(1e-6, std::max({cpu.irradiance.x, cpu.irradiance.y, cpu.irradiance.z}));
    // Single against double precision; a point at a cone's or a face's edge may fall either
    // side, so those cases are told apart by the value itself (zero on one side). The
    // luminaire's LDT coordinates come from acos and atan, whose GLSL 4.50 precision is 4096 ulp
    // (about 2.4e-4 relative; llvmpipe's reach about 1.6e-4 of the value here): 5e-4.
    const double tolerance = i % 4 == 3 ? 5e-4 : 1e-4;
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(double(e[c]), cpu.irradiance[c], tolerance * scale + 1e-6) << "case " << i;
      if (i % 4 == 3)
        worst_luminaire = std::max(worst_luminaire, std::abs(e[c] - cpu.irradiance[c]) / scale);
    }
    if (cpu.irradiance != glm::dvec3(0.0)) {
      ++lit;
      EXPECT_NEAR(glm::length(glm::dvec3(glm::vec3(results[2 * i + 1])) - cpu.direction), 0.0,
                  1e-5);
      if (i % 4 == 2) {
        EXPECT_LT(results[2 * i].w, 0.0f);  // directional: infinitely far
      } else {
        EXPECT_NEAR(double(results[2 * i].w), cpu.distance, 1e-5 * cpu.distance);
      }
    }
  }
  EXPECT_GT(lit, kCount / 4);  // the cases exercise lit points, not only the early outs
  std::printf("luminaire: worst difference %.2e of the value\n", worst_luminaire);
}

TEST(SssGl, PassesAgreeWithTheCpu) {
  PENUMBRA_GL_OR_SKIP();
  Expected<Scene> scene = loadScene("sss");
  ASSERT_TRUE(scene.ok()) << scene.error().describe();
  // Every kind of light: the scene's, a spot and a directional light.
  scene->lights.push_back(SpotLight{glm::vec3(0.0f, 0.4f, 0.3f), glm::vec3(0.0f, -0.6f, -0.8f),
                                    glm::vec3(0.2f, 0.3f, 0.4f), 0.3f, 0.6f});
  scene->lights.push_back(
      DirectionalLight{glm::normalize(glm::vec3(-0.3f, -1.0f, 0.2f)), glm::vec3(1.0f, 0.9f, 0.8f)});
  SssOptions o;
  o.resolution = LightmapResolution{std::nullopt, 128};
  Expected<SssSolver> solver = SssSolver::build(*scene, o);
  ASSERT_TRUE(solver.ok()) << solver.error().describe();
  Expected<GlSss> gpu = GlSss::create(*solver);
  ASSERT_TRUE(gpu.ok()) << gpu.error().describe();
  for (float angle : {0.0f, 2.0f}) {
    const std::vector<Light> lights =
        orbitLights(scene->lights, sceneCentre(solver->scene()), angle);
    const std::vector<glm::vec3> e_cpu = solver->transmittedIrradiance(lights);
    const std::vector<glm::vec3> b_cpu = solver->scatter(e_cpu);
    std::vector<glm::vec3> b_gpu, e_gpu;
    SssPassTimes times;
    ASSERT_TRUE(gpu->frame(lights, b_gpu, &times).ok());
    ASSERT_TRUE(gpu->downloadIrradiance(e_gpu).ok());
    ASSERT_EQ(b_gpu.size(), b_cpu.size());
    // Pass 1: the same light samples in float; a shadow ray that grazes an edge may decide
    // otherwise on the two devices, so a few elements may differ by a light's share.
    double e_mean = 0.0, b_mean = 0.0;
    for (size_t i = 0; i < e_cpu.size(); ++i) {
      e_mean += double(e_cpu[i].x + e_cpu[i].y + e_cpu[i].z) / 3.0;
      b_mean += double(b_cpu[i].x + b_cpu[i].y + b_cpu[i].z) / 3.0;
    }
    e_mean /= double(e_cpu.size());
    b_mean /= double(b_cpu.size());
    ASSERT_GT(e_mean, 0.0);
    size_t e_off = 0;
    double b_se = 0.0, b_worst = 0.0;
    for (size_t i = 0; i < e_cpu.size(); ++i) {
      const glm::vec3 de = glm::abs(e_gpu[i] - e_cpu[i]);
      const float e_tol = 1e-4f * std::max(float(e_mean), std::max(e_cpu[i].x, e_cpu[i].z));
      if (std::max({de.x, de.y, de.z}) > e_tol) ++e_off;
      const glm::dvec3 db = glm::dvec3(b_gpu[i]) - glm::dvec3(b_cpu[i]);
      b_se += glm::dot(db, db) / 3.0;
      b_worst = std::max(b_worst, std::abs(db.x) + std::abs(db.y) + std::abs(db.z));
    }
    const double b_rms = std::sqrt(b_se / double(b_cpu.size())) / b_mean;
    std::printf(
        "angle %.1f: %zu elements, E differs at %zu, B RMS %.2e of the mean, worst "
        "%.2e; pass 1 %.1f ms, pass 2 %.1f ms (llvmpipe)\n",
        double(angle), e_cpu.size(), e_off, b_rms, b_worst / b_mean, 1e3 * times.irradiance,
        1e3 * times.gather);
    EXPECT_LE(e_off, e_cpu.size() / 500) << "angle " << angle;
    EXPECT_LT(b_rms, 1e-3) << "angle " << angle;
  }
}

TEST(SssGl, RenderOnTheGpuShowsTheCpusImage) {
  PENUMBRA_GL_OR_SKIP();
  // `render --method sss --device gpu` against --device cpu: the same view, passes 1 and 2 on
  // the device; a moving light (two frames of an orbit), the links from one cache.
  test::TempDir dir;
  const std::string env = "PENUMBRA_CACHE_DIR=" + (dir.path() / "cache").string();
  const std::string common =
      "render sss --method sss --lightmap-size 128 --width 64 --height 64 --spp 2 --frames 2 ";
  for (const char* device : {"cpu", "gpu"}) {
    const test::CliResult r = test::runCli(
        common + "--device " + device + " -o " + dir.file(std::string(device) + ".exr") +
            " --stats " + dir.file(std::string(device) + ".json"),
        env);
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  for (int f = 0; f < 2; ++f) {
    Expected<Image> cpu = readImage(dir.file(fmt::format("cpu_{:04d}.exr", f)));
    Expected<Image> gpu = readImage(dir.file(fmt::format("gpu_{:04d}.exr", f)));
    ASSERT_TRUE(cpu.ok() && gpu.ok());
    double sum = 0.0, diff = 0.0;
    for (size_t i = 0; i < cpu->pixels.size(); ++i) {
      const glm::vec3 d = glm::abs(cpu->pixels[i] - gpu->pixels[i]);
      sum += double(cpu->pixels[i].x + cpu->pixels[i].y + cpu->pixels[i].z);
      diff += double(d.x + d.y + d.z);
    }
    ASSERT_GT(sum, 0.0);
    EXPECT_LT(diff / sum, 1e-4) << "frame " << f;
  }
  std::ifstream in(dir.file("gpu.json"));
  EXPECT_EQ(nlohmann::json::parse(in)["device"], "gpu");
}

}  // namespace
}  // namespace penumbra
