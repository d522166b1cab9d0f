// Culling triangles outside a ray bucket (Carr et al. 2002, sec. 5.3; kernels/bucket_cull.h):
// the test is conservative (a triangle some ray of the bucket hits is never culled), it culls
// what lies behind or beside a coherent bucket, and its GLSL twin decides exactly as the C++.
#include "penumbra/kernels/bucket_cull.h"

#include "penumbra/core/rng.h"
#include "penumbra/gpu/program.h"
#include "penumbra/kernels/ray.h"
#include "penumbra/kernels/ray_triangle.h"
#include "penumbra/raytrace/ray_engine_gl.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/vec4.hpp>

#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace penumbra {
namespace {

using test::randomDirection;

struct BucketRay {
  glm::vec3 o, d;
  float tmin, far;
};

struct Box {
  glm::vec3 lo, hi;
};

using Tri = std::array<glm::vec3, 3>;

enum class Kind { kCoherent, kWideCone, kSphere, kAxisAligned, kPointSource, kShortSegments };
constexpr Kind kKinds[] = {Kind::kCoherent,    Kind::kWideCone,    Kind::kSphere,
                           Kind::kAxisAligned, Kind::kPointSource, Kind::kShortSegments};

float uniform(Rng& rng, float lo, float hi) {
  return lo + (hi - lo) * rng.uniform();
}

// A bucket of `n` rays of the given kind, around `center` at scale `scale`.
std::vector<BucketRay> makeBucket(Kind kind, size_t n, Rng& rng, glm::vec3 center, float scale) {
  const glm::vec3 axis = randomDirection(rng);
  const float spread = uniform(rng, 0.0f, 0.3f) * scale;
  const float cone = kind == Kind::kWideCone ? 0.9f : uniform(rng, 0.0f, 0.2f);
  const glm::vec3 source = center + scale * randomDirection(rng);
  std::vector<BucketRay> rays(n);
  for (BucketRay& r : rays) {
    r.o =
        center + spread * glm::vec3(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1));
    r.d = glm::normalize(axis + cone * randomDirection(rng));
    r.tmin = rng.uniform() < 0.3f ? uniform(rng, 0.0f, 0.5f) * scale : 0.0f;
    r.far = r.tmin + uniform(rng, 0.1f, 4.0f) * scale;
    switch (kind) {
      case Kind::kSphere:
        r.d = randomDirection(rng);
        break;
      case Kind::kAxisAligned: {
        // Exact zeros in the direction: slopes of exactly 0 and rays in a coordinate plane.
        const int a = int(rng.uniformInt(3));
        r.d = glm::vec3(0.0f);
        r.d[a] = rng.uniform() < 0.5f ? -1.0f : 1.0f;
        if (rng.uniform() < 0.3f) r.d[(a + 1) % 3] = uniform(rng, -0.1f, 0.1f);
        break;
      }
      case Kind::kPointSource:
        r.o = source;
        break;
      case Kind::kShortSegments:
        r.far = r.tmin + uniform(rng, 0.0f, 0.05f) * scale;
        r.d *= uniform(rng, 0.2f, 5.0f);  // not unit length: t is in units of |d|
        break;
      default:
        break;
    }
  }
  return rays;
}

// The bound as the kernel builds it: rays as its textures hold them, clipped to `clip`.
RayBucketBound boundOf(const std::vector<BucketRay>& rays, const Box& clip) {
  std::vector<glm::vec4> origins, directions;
  for (const BucketRay& r : rays) {
    origins.emplace_back(r.o, r.tmin);
    directions.emplace_back(r.d, r.far);
  }
  return boundRayBucket(origins, directions, clip.lo, clip.hi);
}

Box around(glm::vec3 c, float r) {
  return {c - glm::vec3(r), c + glm::vec3(r)};
}

Box boxOf(const Tri& p) {
  return {glm::min(glm::min(p[0], p[1]), p[2]), glm::max(glm::max(p[0], p[1]), p[2])};
}

bool hits(const BucketRay& r, const Tri& p) {
  float t, u, v;
  return intersectTriangle(makeWatertightRay(r.o, r.d), p[0], p[1], p[2], r.tmin, r.far, t, u, v);
}

// A triangle through the point at `t` on ray r: inside, on an edge or at a vertex.
void triangleThrough(const BucketRay& r, float t, float size, Rng& rng, Tri& p) {
  const glm::vec3 x = r.o + t * r.d;
  for (glm::vec3& q : p) q = size * randomDirection(rng);
  float b[3] = {rng.uniform(), rng.uniform(), rng.uniform()};
  const uint32_t where = rng.uniformInt(3);
  if (where == 1) b[rng.uniformInt(3)] = 0.0f;            // on an edge
  if (where == 2) b[0] = 1.0f, b[1] = 0.0f, b[2] = 0.0f;  // at a vertex
  const float sum = b[0] + b[1] + b[2];
  const glm::vec3 at = (b[0] * p[0] + b[1] * p[1] + b[2] * p[2]) / sum;
  for (glm::vec3& q : p) q += x - at;
}

// Each round: a bucket, 40 triangles (30 through points of its rays, at their ends half of the
// time, and inside, on an edge or at a vertex; 10 anywhere near), clipped as the kernel clips,
// to the box of the triangles, or to a loose box around them.
TEST(BucketCull, NeverCullsATriangleARayHits) {
  Rng rng(2024, 1);
  size_t checked = 0, culled_misses = 0, misses = 0;  // misses: of the triangles anywhere
  // Scenes at several scales and far from the origin, where rounding is coarsest.
  const glm::vec3 centers[] = {{0, 0, 0}, {1000, -2000, 500}, {0.3f, 0.1f, -0.2f}};
  const float scales[] = {1.0f, 1e-3f, 1e3f, 0.05f};
  for (int round = 0; round < 3000; ++round) {
    const Kind kind = kKinds[round % 6];
    const glm::vec3 center = centers[round % 3];
    const float scale = scales[(round / 3) % 4];
    const std::vector<BucketRay> rays =
        makeBucket(kind, 1 + rng.uniformInt(64), rng, center, scale);
    std::vector<Tri> tris(40);
    Box clip{glm::vec3(INFINITY), glm::vec3(-INFINITY)};
    for (size_t k = 0; k < tris.size(); ++k) {
      Tri& p = tris[k];
      if (k < 30) {
        const BucketRay& r = rays[rng.uniformInt(uint32_t(rays.size()))];
        const float u = rng.uniform();
        const float t = k % 4 == 0 ? r.tmin : k % 4 == 1 ? r.far : r.tmin + u * (r.far - r.tmin);
        const float size = scale * std::pow(10.0f, uniform(rng, -6.0f, 0.0f));
        triangleThrough(r, t, size, rng, p);
      } else {
        for (glm::vec3& q : p) {
          q = center + 3.0f * scale *
                           glm::vec3(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1));
        }
      }
      const Box box = boxOf(p);
      clip = {glm::min(clip.lo, box.lo), glm::max(clip.hi, box.hi)};
    }
    if (round % 2) clip = around(center, 20.0f * scale);
    const RayBucketBound bound = boundOf(rays, clip);
    ASSERT_NE(bound.mode, BucketCullMode::kKeepAll);
    for (size_t k = 0; k < tris.size(); ++k) {
      const Tri& p = tris[k];
      const Box box = boxOf(p);
      const bool keep = bucketMayReach(bound, box.lo, box.hi);
      bool hit = false;
      for (const BucketRay& r : rays) hit = hit || hits(r, p);
      if (hit) {
        ++checked;
        ASSERT_TRUE(keep) << "round " << round << " kind " << int(kind) << " triangle " << k;
      } else if (k >= 30) {
        ++misses;
        culled_misses += !keep;
      }
    }
  }
  EXPECT_GT(checked, 40000u);
  // And it is not vacuous: a good part of the triangles no ray hits are culled.
  EXPECT_GT(culled_misses, misses / 5) << culled_misses << " of " << misses;
}

TEST(BucketCull, CullsTrianglesBehindAndBesideACoherentBucket) {
  // Rays from a 0.2 x 0.2 patch of the z = 0 plane, up +z within slopes of 0.05, to t = 10, in
  // a scene box of +-20.
  std::vector<BucketRay> rays;
  Rng rng(3, 3);
  for (int i = 0; i < 64; ++i) {
    const glm::vec3 o(uniform(rng, -0.1f, 0.1f), uniform(rng, -0.1f, 0.1f), 0.0f);
    const glm::vec3 d(uniform(rng, -0.05f, 0.05f), uniform(rng, -0.05f, 0.05f), 1.0f);
    rays.push_back({o, d, 0.0f, 10.0f});
  }
  const RayBucketBound b = boundOf(rays, around(glm::vec3(0.0f), 20.0f));
  ASSERT_EQ(b.mode, BucketCullMode::kBeam);
  EXPECT_EQ(b.axis, 2);
  auto at = [&](glm::vec3 c, float r) {
    return bucketMayReach(b, c - glm::vec3(r), c + glm::vec3(r));
  };
  EXPECT_TRUE(at({0, 0, 5}, 0.01f));      // on the axis
  EXPECT_TRUE(at({0.3f, 0, 5}, 0.01f));   // inside the cone at z = 5 (|x| < 0.35)
  EXPECT_TRUE(at({0.07f, 0, 1}, 0.02f));  // and at z = 1 (|x| < 0.15)
  EXPECT_FALSE(at({0, 0, -1}, 0.5f));     // behind every origin
  EXPECT_FALSE(at({0, 0, 11}, 0.5f));     // beyond every tmax
  EXPECT_FALSE(at({3, 0, 5}, 0.5f));      // outside the reach box
  EXPECT_FALSE(at({0.5f, 0, 1}, 0.05f));  // inside the reach box, outside the cone
  EXPECT_FALSE(at({0, -0.5f, 1}, 0.05f));
  EXPECT_FALSE(at({0.2f, 0, 0.5f}, 0.01f));  // |x| < 0.125 at z = 0.5
  EXPECT_TRUE(at({0, 0, 0}, 100.0f));        // a box around everything
  // Clipped to a cell from z = 4 to 6, the reach box is the cone's section there.
  const RayBucketBound cell = boundOf(rays, Box{{-1, -1, 4}, {1, 1, 6}});
  EXPECT_NEAR(cell.reach_lo.z, 4.0f, 1e-3f);
  EXPECT_NEAR(cell.reach_hi.z, 6.0f, 1e-3f);
  EXPECT_LT(cell.reach_hi.x, 0.41f);
  EXPECT_TRUE(bucketMayReach(cell, {-0.3f, -0.3f, 4.5f}, {0.3f, 0.3f, 4.6f}));
  EXPECT_FALSE(bucketMayReach(cell, {0.5f, -0.3f, 4.5f}, {0.6f, 0.3f, 4.6f}));
  // The same bucket flipped to travel -z.
  for (BucketRay& r : rays) r.d.z = -1.0f;
  const RayBucketBound flipped = boundOf(rays, around(glm::vec3(0.0f), 20.0f));
  EXPECT_TRUE(bucketMayReach(flipped, {-0.01f, -0.01f, -5.01f}, {0.01f, 0.01f, -4.99f}));
  EXPECT_FALSE(bucketMayReach(flipped, {-0.01f, -0.01f, 4.99f}, {0.01f, 0.01f, 5.01f}));
}

// A pencil of parallel rays whose origins are spread along it (as rays that all entered one
// GPU cell from different distances): the beam is the pencil, not the origins' box swept.
TEST(BucketCull, APencilIsBoundedWhereverItsOriginsLie) {
  const glm::vec3 d = glm::normalize(glm::vec3(1, 1, 1));
  std::vector<BucketRay> rays;
  Rng rng(4, 4);
  for (int i = 0; i < 64; ++i) {
    const glm::vec3 offset(uniform(rng, -0.01f, 0.01f), uniform(rng, -0.01f, 0.01f), 0.0f);
    rays.push_back({offset + uniform(rng, -10.0f, -2.0f) * d, d, 0.0f, 100.0f});
  }
  const RayBucketBound b = boundOf(rays, Box{glm::vec3(-1.0f), glm::vec3(1.0f)});
  ASSERT_EQ(b.mode, BucketCullMode::kBeam);
  EXPECT_TRUE(bucketMayReach(b, glm::vec3(-0.02f), glm::vec3(0.02f)));  // the pencil's centre
  EXPECT_TRUE(bucketMayReach(b, glm::vec3(0.5f), glm::vec3(0.52f)));
  EXPECT_FALSE(bucketMayReach(b, {0.5f, -0.1f, 0.0f}, {0.52f, -0.08f, 0.02f}));  // beside it
  EXPECT_FALSE(bucketMayReach(b, {-0.5f, 0.5f, 0.0f}, {-0.4f, 0.6f, 0.1f}));
}

TEST(BucketCull, ModesForEmptyNonFiniteAndIncoherentBuckets) {
  const Box clip = around(glm::vec3(0.0f), 10.0f);
  const glm::vec3 lo(-1.0f), hi(1.0f);
  EXPECT_EQ(boundOf({}, clip).mode, BucketCullMode::kCullAll);
  EXPECT_FALSE(bucketMayReach(boundOf({}, clip), lo, hi));
  // Rays that can hit nothing (far bound below tmin, zero direction, missing the clip box)
  // leave the bucket empty.
  const std::vector<BucketRay> misses = {{glm::vec3(0.0f), {0, 0, 1}, 0.0f, -1.0f},
                                         {glm::vec3(0.0f), {0, 0, 0}, 0.0f, 1.0f},
                                         {{0, 0, 20}, {0, 0, 1}, 0.0f, 5.0f},
                                         {{0, 20, 0}, {1, 0, 0}, 0.0f, 5.0f}};
  EXPECT_EQ(boundOf(misses, clip).mode, BucketCullMode::kCullAll);
  // A non-finite ray switches culling off for its bucket.
  const std::vector<BucketRay> nan = {{glm::vec3(0.0f), {0, 0, 1}, 0.0f, 1.0f},
                                      {glm::vec3(std::nanf("")), {0, 0, 1}, 0.0f, 1.0f}};
  EXPECT_EQ(boundOf(nan, clip).mode, BucketCullMode::kKeepAll);
  EXPECT_TRUE(bucketMayReach(boundOf(nan, clip), glm::vec3(5.0f), glm::vec3(6.0f)));
  // Every axis perpendicular to some direction: the reach box only.
  const std::vector<BucketRay> axes = {{glm::vec3(0.0f), {1, 0, 0}, 0.0f, 1.0f},
                                       {glm::vec3(0.0f), {0, 1, 0}, 0.0f, 1.0f},
                                       {glm::vec3(0.0f), {0, 0, 1}, 0.0f, 1.0f}};
  const RayBucketBound box = boundOf(axes, clip);
  EXPECT_EQ(box.mode, BucketCullMode::kBox);
  EXPECT_TRUE(bucketMayReach(box, glm::vec3(0.5f), glm::vec3(0.6f)));  // between the rays
  EXPECT_FALSE(bucketMayReach(box, glm::vec3(1.5f), glm::vec3(1.6f)));
  // A negative tmin reaches behind the origin.
  const std::vector<BucketRay> behind = {{glm::vec3(0.0f), {0, 0, 1}, -1.0f, 1.0f}};
  EXPECT_TRUE(
      bucketMayReach(boundOf(behind, clip), {-0.01f, -0.01f, -0.6f}, {0.01f, 0.01f, -0.5f}));
  EXPECT_FALSE(
      bucketMayReach(boundOf(behind, clip), {-0.01f, -0.01f, -1.6f}, {0.01f, 0.01f, -1.5f}));
}

// The vertex shader's copy of the test (shaders/common/bucket_cull.glsl), run in a compute
// shader on the GPU, against the C++ on the same bounds and boxes.
TEST(BucketCull, GlslTwinAgreesWithCpp) {
  PENUMBRA_GL_OR_SKIP();
  const std::string source =
      "#version 450\n"
      "#include \"common/bucket_cull.glsl\"\n"
      "layout(local_size_x = 64) in;\n"
      "layout(std430, binding = 0) readonly buffer Boxes { vec4 boxes[]; };\n"
      "layout(std430, binding = 1) writeonly buffer Keep { uint keep[]; };\n"
      "uniform RayBucketBound bucket;\n"
      "uniform uint box_count;\n"
      "void main() {\n"
      "  uint i = gl_GlobalInvocationID.x;\n"
      "  if (i >= box_count) return;\n"
      "  keep[i] = bucketMayReach(bucket, boxes[2 * i].xyz, boxes[2 * i + 1].xyz) ? 1u : 0u;\n"
      "}\n";
  Expected<gl::Program> program = gl::computeProgramFromSource("test/bucket_cull.comp", source);
  ASSERT_TRUE(program.ok()) << program.error().describe();
  constexpr size_t kBoxes = 4096;
  gl::Buffer box_buf(kBoxes * 2 * sizeof(glm::vec4), nullptr);
  gl::Buffer keep_buf(kBoxes * sizeof(uint32_t), nullptr);
  Rng rng(8, 1);
  size_t kept = 0, culled = 0;
  for (int round = 0; round < 60; ++round) {
    const float scale = round % 2 ? 1.0f : 1e-3f;
    const glm::vec3 center = round % 3 ? glm::vec3(0.0f) : glm::vec3(100.0f, -50.0f, 20.0f);
    const std::vector<BucketRay> rays =
        makeBucket(kKinds[round % 6], 1 + rng.uniformInt(256), rng, center, scale);
    const RayBucketBound bound = boundOf(rays, around(center, 2.0f * scale));
    std::vector<glm::vec4> boxes(2 * kBoxes);
    for (size_t i = 0; i < kBoxes; ++i) {
      Tri p;
      if (i % 2) {
        const BucketRay& r = rays[rng.uniformInt(uint32_t(rays.size()))];
        triangleThrough(r, r.tmin + rng.uniform() * (r.far - r.tmin), 0.1f * scale, rng, p);
      } else {
        for (glm::vec3& q : p) {
          q = center + 2.0f * scale *
                           glm::vec3(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1));
        }
      }
      const Box box = boxOf(p);
      boxes[2 * i] = glm::vec4(box.lo, 0.0f);
      boxes[2 * i + 1] = glm::vec4(box.hi, 0.0f);
    }
    box_buf.upload(boxes.data(), boxes.size() * sizeof(glm::vec4));
    glUseProgram(program->id());
    setBucketBoundUniforms(program->id(), bound);
    glUniform1ui(glGetUniformLocation(program->id(), "box_count"), GLuint(kBoxes));
    box_buf.bindBase(GL_SHADER_STORAGE_BUFFER, 0);
    keep_buf.bindBase(GL_SHADER_STORAGE_BUFFER, 1);
    glDispatchCompute(GLuint(kBoxes / 64), 1, 1);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    std::vector<uint32_t> keep(kBoxes);
    keep_buf.download(keep.data(), kBoxes * sizeof(uint32_t));
    glUseProgram(0);
    ASSERT_EQ(glGetError(), GLenum(GL_NO_ERROR));
    for (size_t i = 0; i < kBoxes; ++i) {
      const bool cpp = bucketMayReach(bound, glm::vec3(boxes[2 * i]), glm::vec3(boxes[2 * i + 1]));
      ASSERT_EQ(keep[i] != 0, cpp) << "round " << round << " box " << i;
      kept += cpp;
      culled += !cpp;
    }
  }
  EXPECT_GT(kept, 10000u);
  EXPECT_GT(culled, 10000u);
}

}  // namespace
}  // namespace penumbra
