// Every GPU buffer layout is written twice: once in C++ (the struct the host uploads, its byte size
// stated with static_asserts) and once in GLSL (the struct a shader reads). The static_asserts
// only pin the C++ side to the numbers its author had in mind; nothing else checks that the
// shader compiler lays the GLSL twin out the same way. These tests compile each GLSL struct in a
// small program, `layout(std430) buffer B { TheStruct items[]; }` with every member touched so
// that all are active, and read back through program introspection (GL_BUFFER_VARIABLE:
// GL_OFFSET, GL_TOP_LEVEL_ARRAY_STRIDE, GL_TYPE, GL_ARRAY_SIZE, GL_ARRAY_STRIDE) each member's
// offset and byte size and the array stride, then compare them with offsetof, sizeof of the
// member and sizeof of the C++ struct. A GLSL member missing from a table below fails too, so a
// member added on one side only cannot go unchecked. Every failure names the struct and member.
#include "penumbra/gpu/program.h"
#include "penumbra/radiosity/hemisphere_gl.h"
#include "penumbra/radiosity/jacobi_gl.h"
#include "penumbra/radiosity/progressive_gl.h"
#include "penumbra/radiosity/stochastic_gl.h"
#include "penumbra/raytrace/gpu_cutouts.h"
#include "penumbra/raytrace/gpu_layout.h"
#include "penumbra/raytrace/lights.h"
#include "penumbra/subsurface/sss_gl.h"
#include "support/test_util.h"

#include <gtest/gtest.h>

#include <cstddef>
#include <map>
#include <string>
#include <vector>

namespace penumbra {
namespace {

// One member as the C++ side has it, under its GLSL name.
struct Member {
  std::string glsl;  // the GLSL member's name
  size_t offset;     // offsetof in the C++ struct
  size_t bytes;      // sizeof of the C++ member
};

// A member whose name is the same on both sides.
#define LAYOUT_MEMBER(T, m)          \
  Member {                           \
#m, offsetof(T, m), sizeof(T::m) \
  }
// A member named differently in GLSL (none is today; this is how one would be mapped).
#define LAYOUT_RENAMED(T, glsl_name, m)     \
  Member {                                  \
    glsl_name, offsetof(T, m), sizeof(T::m) \
  }

enum class Block { kStd430Buffer, kStd140Uniform };

// A GLSL struct and its C++ mirror.
struct Mirror {
  std::string name;      // the GLSL struct's name (the C++ struct's too)
  std::string preamble;  // the #defines and #includes that declare it
  size_t bytes;          // sizeof of the C++ struct: the array stride the host uploads with
  std::vector<Member> members;
  Block block = Block::kStd430Buffer;
};

std::string lightsPreamble() {
  std::string s;
  for (const std::string& d : gpuLightDefines()) s += "#define " + d + "\n";
  // common/luminaire.glsl leaves the tables buffer's reader to its includer.
  return s + "#include \"common/lights.glsl\"\nfloat luminaireTable(uint index) { return 0.0; }\n";
}

// A compute program declaring an array of `m.name` and copying each listed member from one item
// to another, then whole items, which makes every member active (an unused member is dropped
// from introspection): a GLSL member the table does not list shows up too.
std::string mirrorSource(const Mirror& m) {
  std::string s = "#version 450\n" + m.preamble + "layout(local_size_x = 1) in;\n";
  if (m.block == Block::kStd430Buffer) {
    s += "layout(std430, binding = 0) buffer B { " + m.name + " items[]; };\n";
    s += "void main() {\n";
    for (const Member& x : m.members) s += "  items[1]." + x.glsl + " = items[0]." + x.glsl + ";\n";
    s += "  items[3] = items[2];\n";
  } else {
    // Two elements read, so the array stride can be measured between them.
    s += "layout(std140, binding = 0) uniform B { " + m.name + " items[2]; };\n";
    s += "layout(std430, binding = 0) writeonly buffer Sink { " + m.name + " sink[]; };\n";
    s += "void main() {\n";
    for (const Member& x : m.members) {
      for (const char* i : {"0", "1"}) {
        s += std::string("  sink[") + i + "]." + x.glsl + " = items[" + i + "]." + x.glsl + ";\n";
      }
    }
    s += "  sink[2] = items[0];\n  sink[3] = items[1];\n";
  }
  return s + "}\n";
}

// Bytes of one value of a GL_TYPE, 0 for a type these layouts do not use.
size_t glTypeBytes(GLenum type) {
  switch (type) {
    case GL_FLOAT:
    case GL_INT:
    case GL_UNSIGNED_INT:
    case GL_BOOL:
      return 4;
    case GL_FLOAT_VEC2:
    case GL_INT_VEC2:
    case GL_UNSIGNED_INT_VEC2:
      return 8;
    case GL_FLOAT_VEC3:
    case GL_INT_VEC3:
    case GL_UNSIGNED_INT_VEC3:
      return 12;
    case GL_FLOAT_VEC4:
    case GL_INT_VEC4:
    case GL_UNSIGNED_INT_VEC4:
      return 16;
    case GL_DOUBLE:
      return 8;
    case GL_DOUBLE_VEC2:
      return 16;
    case GL_DOUBLE_VEC3:
      return 24;
    case GL_DOUBLE_VEC4:
      return 32;
    default:
      return 0;
  }
}

// What introspection says of one GLSL member.
struct GlslMember {
  GLint offset = 0;
  GLint top_level_stride = 0;  // std430 buffers only
  size_t bytes = 0;            // 0: a type glTypeBytes does not know
};

std::string resourceName(GLuint program, GLenum interface, GLuint index) {
  char buffer[256];
  GLsizei length = 0;
  glGetProgramResourceName(program, interface, index, sizeof(buffer), &length, buffer);
  return std::string(buffer, size_t(length));
}

// The active members of block "B" of `program` by member name ("items[0].column[0]" is
// "column"); the item index `item` only, for a uniform block (whose array elements are listed
// one by one).
std::map<std::string, GlslMember> glslMembers(GLuint program, GLenum block_interface,
                                              GLenum member_interface, const std::string& item) {
  std::map<std::string, GlslMember> out;
  const GLuint block = glGetProgramResourceIndex(program, block_interface, "B");
  if (block == GL_INVALID_INDEX) return out;
  GLenum prop = GL_NUM_ACTIVE_VARIABLES;
  GLint count = 0;
  glGetProgramResourceiv(program, block_interface, block, 1, &prop, 1, nullptr, &count);
  std::vector<GLint> variables(size_t(count > 0 ? count : 0));
  prop = GL_ACTIVE_VARIABLES;
  glGetProgramResourceiv(program, block_interface, block, 1, &prop, count, nullptr,
                         variables.data());
  const std::string prefix = "items[" + item + "].";
  for (GLint v : variables) {
    std::string name = resourceName(program, member_interface, GLuint(v));
    if (name.rfind(prefix, 0) != 0) continue;
    name = name.substr(prefix.size());
    if (name.size() > 3 && name.ends_with("[0]")) name.resize(name.size() - 3);
    const bool buffer = member_interface == GL_BUFFER_VARIABLE;
    const GLenum props[] = {GL_OFFSET, GL_TYPE, GL_ARRAY_SIZE, GL_ARRAY_STRIDE,
                            GL_TOP_LEVEL_ARRAY_STRIDE};
    GLint values[5] = {};
    glGetProgramResourceiv(program, member_interface, GLuint(v), buffer ? 5 : 4, props,
                           buffer ? 5 : 4, nullptr, values);
    GlslMember m;
    m.offset = values[0];
    m.top_level_stride = values[4];
    const size_t one = glTypeBytes(GLenum(values[1]));
    const size_t array_size = size_t(values[2] > 1 ? values[2] : 1);
    m.bytes = one == 0 ? 0 : (array_size - 1) * size_t(values[3]) + one;
    out[name] = m;
  }
  return out;
}

// Every disagreement between `m`'s GLSL and C++ sides, each naming the struct and the member.
std::vector<std::string> layoutMismatches(const Mirror& m) {
  std::vector<std::string> problems;
  Expected<gl::Program> program =
      gl::computeProgramFromSource("test/layout_" + m.name + ".comp", mirrorSource(m));
  if (!program.ok()) return {m.name + ": does not compile: " + program.error().describe()};
  const GLuint id = program.value().id();
  const bool buffer = m.block == Block::kStd430Buffer;
  const GLenum block_interface = buffer ? GL_SHADER_STORAGE_BLOCK : GL_UNIFORM_BLOCK;
  const GLenum member_interface = buffer ? GL_BUFFER_VARIABLE : GL_UNIFORM;
  const std::map<std::string, GlslMember> glsl =
      glslMembers(id, block_interface, member_interface, "0");
  if (glsl.empty()) return {m.name + ": no active members found by introspection"};

  // The array stride: what the host's sizeof must equal for items[i] to line up.
  GLint stride = glsl.begin()->second.top_level_stride;
  if (!buffer) {
    const std::map<std::string, GlslMember> second =
        glslMembers(id, block_interface, member_interface, "1");
    const auto it = second.find(glsl.begin()->first);
    stride = it == second.end() ? 0 : it->second.offset - glsl.begin()->second.offset;
  }
  if (size_t(stride) != m.bytes) {
    problems.push_back(m.name + ": array stride " + std::to_string(stride) + " in GLSL, sizeof " +
                       std::to_string(m.bytes) + " in C++");
  }
  for (const Member& x : m.members) {
    const auto it = glsl.find(x.glsl);
    if (it == glsl.end()) {
      problems.push_back(m.name + "." + x.glsl + ": not an active GLSL member");
      continue;
    }
    if (size_t(it->second.offset) != x.offset) {
      problems.push_back(m.name + "." + x.glsl + ": offset " + std::to_string(it->second.offset) +
                         " in GLSL, " + std::to_string(x.offset) + " in C++");
    }
    if (it->second.bytes != x.bytes) {
      problems.push_back(m.name + "." + x.glsl + ": " + std::to_string(it->second.bytes) +
                         " bytes in GLSL, " + std::to_string(x.bytes) + " in C++");
    }
  }
  for (const auto& [name, unused] : glsl) {
    bool listed = false;
    for (const Member& x : m.members) listed |= x.glsl == name;
    if (!listed) problems.push_back(m.name + "." + name + ": in GLSL, not in this test's table");
  }
  return problems;
}

void expectMirrored(const Mirror& m) {
  const std::vector<std::string> problems = layoutMismatches(m);
  std::string all;
  for (const std::string& p : problems) all += "\n  " + p;
  EXPECT_TRUE(problems.empty()) << "GLSL and C++ layouts of " << m.name << " differ:" << all;
}

const char* const kProgressive = "#include \"radiosity/progressive_layout.glsl\"\n";

Mirror progressiveElement() {
  using T = GpuProgressiveElement;
  return {"GpuProgressiveElement",
          kProgressive,
          sizeof(T),
          {LAYOUT_MEMBER(T, position), LAYOUT_MEMBER(T, area), LAYOUT_MEMBER(T, reflectance),
           LAYOUT_MEMBER(T, texel), LAYOUT_MEMBER(T, normal), LAYOUT_MEMBER(T, piece_count),
           LAYOUT_MEMBER(T, barycentric), LAYOUT_MEMBER(T, triangle), LAYOUT_MEMBER(T, piece_first),
           LAYOUT_MEMBER(T, shading_normal), LAYOUT_MEMBER(T, pad)}};
}

TEST(GpuLayout, ProgressiveRadiosityMatchesCpp) {
  PENUMBRA_GL_OR_SKIP();
  expectMirrored(progressiveElement());
  {
    using T = GpuProgressiveTriangle;
    expectMirrored(
        {"GpuProgressiveTriangle",
         kProgressive,
         sizeof(T),
         {LAYOUT_MEMBER(T, p0), LAYOUT_MEMBER(T, front_chart), LAYOUT_MEMBER(T, p1),
          LAYOUT_MEMBER(T, tessellation), LAYOUT_MEMBER(T, p2), LAYOUT_MEMBER(T, back_chart)}});
  }
  {
    using T = GpuShooter;
    expectMirrored({"GpuShooter",
                    kProgressive,
                    sizeof(T),
                    {LAYOUT_MEMBER(T, element_first), LAYOUT_MEMBER(T, element_count)}});
  }
  {
    using T = GpuShooterPoint;
    expectMirrored({"GpuShooterPoint",
                    kProgressive,
                    sizeof(T),
                    {LAYOUT_MEMBER(T, member_first), LAYOUT_MEMBER(T, member_count)}});
  }
  {
    using T = GpuSelection;
    expectMirrored({"GpuSelection",
                    kProgressive,
                    sizeof(T),
                    {LAYOUT_MEMBER(T, power), LAYOUT_MEMBER(T, shooter), LAYOUT_MEMBER(T, pad)}});
  }
  {
    using T = GpuResolveSums;
    expectMirrored(
        {"GpuResolveSums",
         kProgressive,
         sizeof(T),
         {LAYOUT_MEMBER(T, arrived), LAYOUT_MEMBER(T, absorbed), LAYOUT_MEMBER(T, reflected)}});
  }
}

TEST(GpuLayout, BatchPointUniformMatchesCpp) {
  PENUMBRA_GL_OR_SKIP();
  // std140, in the uniform block Batch; `pad` rounds the size up to the std140 array stride (a
  // multiple of dvec4's 32), which is checked.
  using T = GpuBatchPoint;
  expectMirrored({"GpuBatchPoint",
                  kProgressive,
                  sizeof(T),
                  {LAYOUT_MEMBER(T, position), LAYOUT_MEMBER(T, position_f),
                   LAYOUT_MEMBER(T, residual), LAYOUT_MEMBER(T, members), LAYOUT_MEMBER(T, eye),
                   LAYOUT_MEMBER(T, pieces), LAYOUT_MEMBER(T, pad)},
                  Block::kStd140Uniform});
}

TEST(GpuLayout, CutoutMatchesCpp) {
  PENUMBRA_GL_OR_SKIP();
  using T = GpuCutout;
  expectMirrored({"GpuCutout",
                  "#define CUTOUT_SSBO_FIRST 0\n#include \"common/cutout.glsl\"\n",
                  sizeof(T),
                  {LAYOUT_MEMBER(T, st), LAYOUT_MEMBER(T, factor), LAYOUT_MEMBER(T, cutoff),
                   LAYOUT_MEMBER(T, texture), LAYOUT_MEMBER(T, pad)}});
}

TEST(GpuLayout, LightMatchesCpp) {
  PENUMBRA_GL_OR_SKIP();
  using T = GpuLight;
  expectMirrored({"GpuLight",
                  lightsPreamble(),
                  sizeof(T),
                  {LAYOUT_MEMBER(T, position), LAYOUT_MEMBER(T, type), LAYOUT_MEMBER(T, direction),
                   LAYOUT_MEMBER(T, cos_outer), LAYOUT_MEMBER(T, value),
                   LAYOUT_MEMBER(T, spot_scale), LAYOUT_MEMBER(T, c0), LAYOUT_MEMBER(T, table)}});
}

TEST(GpuLayout, RayEngineMatchesCpp) {
  PENUMBRA_GL_OR_SKIP();
  const std::string layout = "#include \"raytrace/layout.glsl\"\n";
  {
    using T = BvhNode;
    expectMirrored({"BvhNode",
                    layout,
                    sizeof(T),
                    {LAYOUT_MEMBER(T, lo), LAYOUT_MEMBER(T, index), LAYOUT_MEMBER(T, hi),
                     LAYOUT_MEMBER(T, count)}});
  }
  {
    using T = GpuTriangle;
    expectMirrored({"GpuTriangle",
                    layout,
                    sizeof(T),
                    {LAYOUT_MEMBER(T, p0), LAYOUT_MEMBER(T, id), LAYOUT_MEMBER(T, p1),
                     LAYOUT_MEMBER(T, pad1), LAYOUT_MEMBER(T, p2), LAYOUT_MEMBER(T, pad2)}});
  }
  {
    using T = GpuRay;
    expectMirrored({"GpuRay",
                    layout,
                    sizeof(T),
                    {LAYOUT_MEMBER(T, org), LAYOUT_MEMBER(T, tmin), LAYOUT_MEMBER(T, dir),
                     LAYOUT_MEMBER(T, tmax)}});
  }
  {
    using T = GpuHit;
    expectMirrored({"GpuHit",
                    layout,
                    sizeof(T),
                    {LAYOUT_MEMBER(T, triangle), LAYOUT_MEMBER(T, t), LAYOUT_MEMBER(T, u),
                     LAYOUT_MEMBER(T, v)}});
  }
}

TEST(GpuLayout, SubsurfaceMatchesCpp) {
  PENUMBRA_GL_OR_SKIP();
  const std::string layout = "#include \"subsurface/sss_layout.glsl\"\n";
  {
    using T = GpuSssElement;
    expectMirrored(
        {"GpuSssElement",
         layout,
         sizeof(T),
         {LAYOUT_MEMBER(T, position), LAYOUT_MEMBER(T, eta), LAYOUT_MEMBER(T, normal),
          LAYOUT_MEMBER(T, lift), LAYOUT_MEMBER(T, shading_normal), LAYOUT_MEMBER(T, pad0),
          LAYOUT_MEMBER(T, static_irradiance), LAYOUT_MEMBER(T, pad1)}});
  }
  {
    using T = GpuSssNode;
    expectMirrored(
        {"GpuSssNode",
         layout,
         sizeof(T),
         {LAYOUT_MEMBER(T, position), LAYOUT_MEMBER(T, area), LAYOUT_MEMBER(T, child_first),
          LAYOUT_MEMBER(T, child_count), LAYOUT_MEMBER(T, pad0), LAYOUT_MEMBER(T, pad1)}});
  }
  {
    // C++ float column[3][4], GLSL vec4 column[3]: the same 48 bytes.
    using T = GpuMat3;
    expectMirrored({"GpuMat3", layout, sizeof(T), {LAYOUT_MEMBER(T, column)}});
  }
  {
    using T = GpuSssLink;
    expectMirrored({"GpuSssLink",
                    layout,
                    sizeof(T),
                    {LAYOUT_MEMBER(T, factor), LAYOUT_MEMBER(T, node), LAYOUT_MEMBER(T, offset),
                     LAYOUT_MEMBER(T, pad)}});
  }
}

TEST(GpuLayout, JacobiMatchesCpp) {
  PENUMBRA_GL_OR_SKIP();
  const std::string layout = "#include \"radiosity/jacobi_layout.glsl\"\n";
  {
    using T = GpuRgb;
    expectMirrored({"GpuRgb", layout, sizeof(T), {LAYOUT_MEMBER(T, rgb), LAYOUT_MEMBER(T, pad)}});
  }
  {
    using T = GpuJacobiElement;
    expectMirrored({"GpuJacobiElement",
                    layout,
                    sizeof(T),
                    {LAYOUT_MEMBER(T, reflectance), LAYOUT_MEMBER(T, self_form_factor),
                     LAYOUT_MEMBER(T, emission), LAYOUT_MEMBER(T, pad)}});
  }
}

TEST(GpuLayout, StochasticSelectionMatchesCpp) {
  PENUMBRA_GL_OR_SKIP();
  using T = GpuStochasticSelection;
  expectMirrored(
      {"GpuStochasticSelection",
       "#include \"radiosity/stochastic_layout.glsl\"\n",
       sizeof(T),
       {LAYOUT_MEMBER(T, element), LAYOUT_MEMBER(T, found), LAYOUT_MEMBER(T, probability),
        LAYOUT_MEMBER(T, power), LAYOUT_MEMBER(T, pad), LAYOUT_MEMBER(T, value)}});
}

// The check itself can fail: a GLSL copy of GpuProgressiveElement with `position` and
// `reflectance` swapped is reported, naming the struct and each member that moved.
TEST(GpuLayout, ASwappedMemberIsReported) {
  PENUMBRA_GL_OR_SKIP();
  Mirror m = progressiveElement();
  m.preamble =
      "struct GpuProgressiveElement {\n"
      "  vec3 reflectance; float area; vec3 position; uint texel;\n"
      "  vec3 normal; uint piece_count; vec2 barycentric; uint triangle; uint piece_first;\n"
      "  vec3 shading_normal; uint pad;\n"
      "};\n";
  const std::vector<std::string> problems = layoutMismatches(m);
  std::string all;
  for (const std::string& p : problems) all += p + "\n";
  EXPECT_NE(all.find("GpuProgressiveElement.position: offset 16 in GLSL, 0 in C++"),
            std::string::npos)
      << all;
  EXPECT_NE(all.find("GpuProgressiveElement.reflectance: offset 0 in GLSL, 16 in C++"),
            std::string::npos)
      << all;
}

}  // namespace
}  // namespace penumbra
