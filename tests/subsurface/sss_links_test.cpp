// Hierarchical subsurface links (Carr, Hall, Hart 2003, sec. 4.2.1) against independent answers:
// a large flat slab lit uniformly gives the dipole's closed-form total reflectance, and on the
// bunny scan the links agree with the brute-force all-pairs gather of eq. 9 on the same atlas,
// closer as L grows.
#include "penumbra/subsurface/sss_links.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/scene/media.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/vec4.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

namespace penumbra {
namespace {

Scene translucentScene(Mesh mesh, const char* preset) {
  Scene s;
  s.source = "test";
  Material m;
  m.name = preset;
  m.subsurface = subsurfacePreset(preset);
  m.two_sided = false;
  s.materials.push_back(m);
  s.meshes.push_back(std::move(mesh));
  return s;
}

RadiositySurface surfaceAt(const Scene& scene, double density) {
  ChartAtlasOptions o;
  o.texel_density = density;
  Expected<RadiositySurface> s = RadiositySurface::build(scene, o, false);
  EXPECT_TRUE(s.ok()) << s.error().describe();
  return std::move(*s);
}

TEST(SssLinks, UniformlyLitSlabScattersTheDipolesTotalReflectance) {
  // A 20 x 20 mm slab, 4 mm thick, of Jensen's skin1 three times as dense (diffusion lengths 1.2,
  // 0.5 and 0.2 mm), at 4 texels per mm. Irradiance 1 on its top face: away from the edges every
  // element gathers the whole plane's worth, int R_d(r) 2 pi r dr = R_d (Jensen eq. 5); 7 mm
  // from the edges the dipole's tail beyond holds less than 1e-4 of it.
  Scene scene = translucentScene(test::boxMesh(0.02, 0.004, 0.02), "skin1");
  scene.materials[0].subsurface->sigma_s_prime *= 3.0;
  scene.materials[0].subsurface->sigma_a *= 3.0;
  const RadiositySurface surface = surfaceAt(scene, 4000.0);
  const SssTree tree = buildSssTree(surface, scene.materials);
  ASSERT_EQ(tree.objectCount(), 1u);
  const std::vector<Dipole> media = objectMedia(tree, scene.materials);
  std::vector<glm::vec3> e(surface.elementCount(), glm::vec3(0.0f));
  for (size_t i = 0; i < e.size(); ++i) {
    if (surface.atlas.element_normal[i].y > 0.99) e[i] = glm::vec3(1.0f);
  }
  const glm::dvec3 closed = media[0].totalReflectance();
  for (int links : {16, 64}) {
    SssLinkOptions o;
    o.links = links;
    const SssLinks l = buildSssLinks(tree, media, o);
    std::vector<glm::vec3> b(e.size());
    gatherScattered(l, mipMapIrradiance(tree, e), b);
    // The top face's elements within 3 mm of its centre.
    glm::dvec3 sum(0.0);
    int count = 0;
    for (size_t i = 0; i < e.size(); ++i) {
      const glm::dvec3 p = surface.atlas.element_position[i];
      if (e[i].x > 0.0f && std::abs(p.x - 0.01) < 0.003 && std::abs(p.z - 0.01) < 0.003) {
        sum += glm::dvec3(b[i]);
        ++count;
      }
    }
    ASSERT_GT(count, 100);
    const glm::dvec3 mean = sum / double(count);
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(mean[c] / closed[c], 1.0, 0.02) << "L " << links << " channel " << c;
    }
    std::printf("slab, L = %d: B / R_d = %.4f %.4f %.4f (%zu elements, links in %.2f s)\n", links,
                mean.x / closed.x, mean.y / closed.y, mean.z / closed.z, e.size(), l.seconds);
  }
}

TEST(SssLinks, AgreeWithTheAllPairsGatherCloserAsLinksGrow) {
  // The bunny scan in marble at about 3,000 elements, lit by a directional light from the side:
  // E = cos, the links' B against eq. 9 summed over every pair.
  Expected<Scene> loaded = loadScene(test::dataPath("bunny.ply"));
  ASSERT_TRUE(loaded.ok());
  Scene scene = translucentScene(loaded->meshes[0], "marble");
  // Texels of about 4 mm; marble's diffusion lengths are 8.5, 5.6 and 4 mm: light crosses a few
  // texels and the hierarchy carries the rest. PENUMBRA_TEST_SSS_ELEMENTS asks for another
  // resolution (the all-pairs gather is quadratic: 20000 takes a minute and a half).
  const char* asked = std::getenv("PENUMBRA_TEST_SSS_ELEMENTS");
  const uint32_t elements = asked ? uint32_t(std::strtoul(asked, nullptr, 10)) : 3000u;
  const RadiositySurface surface = surfaceAt(scene, texelDensityFor(scene, elements));
  const SssTree tree = buildSssTree(surface, scene.materials);
  const std::vector<Dipole> media = objectMedia(tree, scene.materials);
  const glm::dvec3 light = glm::normalize(glm::dvec3(1, 0.3, 0.2));
  std::vector<glm::vec3> e(surface.elementCount());
  for (size_t i = 0; i < e.size(); ++i) {
    e[i] = glm::vec3(float(std::max(0.0, glm::dot(surface.atlas.element_normal[i], light))));
  }
  const std::vector<glm::vec3> reference = gatherAllPairs(tree, media, e);
  double mean_ref = 0.0;
  for (const glm::vec3& r : reference) mean_ref += double(r.x + r.y + r.z) / 3.0;
  mean_ref /= double(reference.size());
  // RMS of the links' B against the all-pairs gather, relative to its mean.
  auto rmsError = [&](const SssLinks& l) {
    std::vector<glm::vec3> b(e.size());
    gatherScattered(l, mipMapIrradiance(tree, e), b);
    double se = 0.0;
    for (size_t i = 0; i < b.size(); ++i) {
      const glm::dvec3 d = glm::dvec3(b[i]) - glm::dvec3(reference[i]);
      se += glm::dot(d, d) / 3.0;
    }
    return std::sqrt(se / double(b.size())) / mean_ref;
  };
  std::vector<double> errors;
  for (int links : {4, 8, 16, 32, 64}) {
    SssLinkOptions o;
    o.links = links;
    const SssLinks l = buildSssLinks(tree, media, o);
    errors.push_back(rmsError(l));
    std::printf("bunny, %zu elements, L = %2d: RMS error %.2f%% of the mean (links %.2f s)\n",
                e.size(), links, 100.0 * errors.back(), l.seconds);
  }
  // More links, less error; at L = 16 within 5% of the all-pairs gather, at L = 64 within 2%.
  for (size_t k = 1; k < errors.size(); ++k) EXPECT_LT(errors[k], errors[k - 1]);
  EXPECT_LT(errors[2], 0.05);
  EXPECT_LT(errors.back(), 0.02);
  // The non-adaptive scheme (every node of one level) needs many more links for less: the
  // adaptive links at L = 64 beat it with about a tenth of its links.
  SssLinkOptions fixed;
  fixed.level = 2;
  const SssLinks l = buildSssLinks(tree, media, fixed);
  const double fixed_error = rmsError(l);
  std::printf("bunny, non-adaptive level 2: %u links per element, RMS error %.2f%%\n",
              l.per_element, 100.0 * fixed_error);
  EXPECT_GT(l.per_element, 5u * 64u);
  EXPECT_GT(fixed_error, errors.back());
}

TEST(SssLinks, TreeCoversEveryElementOnceAndMeansAreAreaWeighted) {
  const Scene scene = translucentScene(test::boxMesh(0.02, 0.01, 0.015), "marble");
  const RadiositySurface surface = surfaceAt(scene, 1000.0);
  const SssTree tree = buildSssTree(surface, scene.materials);
  ASSERT_EQ(tree.objectCount(), 1u);
  // Walking down from the root reaches every element exactly once.
  std::vector<int> seen(tree.elementCount(), 0);
  std::vector<uint32_t> stack = {tree.object_root[0]};
  while (!stack.empty()) {
    const uint32_t n = stack.back();
    stack.pop_back();
    if (n < tree.elementCount()) ++seen[n];
    for (uint32_t c : tree.children(n)) stack.push_back(c);
  }
  for (int s : seen) ASSERT_EQ(s, 1);
  // The root's area is the surface's; its mean of a constant is the constant, of the elements'
  // heights their area-weighted mean.
  double area = 0.0, weighted = 0.0;
  std::vector<glm::vec3> v(tree.elementCount());
  for (size_t i = 0; i < v.size(); ++i) {
    area += tree.area[i];
    weighted += tree.area[i] * tree.position[i].y;
    v[i] = glm::vec3(1.0f, float(tree.position[i].y), 0.0f);
  }
  EXPECT_NEAR(tree.area[tree.object_root[0]] / area, 1.0, 1e-12);
  const std::vector<glm::vec3> m = nodeMeans(tree, v);
  EXPECT_NEAR(m[tree.object_root[0]].x, 1.0f, 1e-5f);
  EXPECT_NEAR(m[tree.object_root[0]].y, weighted / area, 1e-6);
  // The box's six faces: 2 (20 x 10) + 2 (20 x 15) + 2 (10 x 15) mm^2 = 1300 mm^2.
  EXPECT_NEAR(area, 1.3e-3, 1e-9);
}

}  // namespace
}  // namespace penumbra
