// The room of scenes/room.json as users bring it from other tools, through the loaders, with
// every radiosity method against the path tracer:
//  - as a glTF file as Blender writes it: one mesh per material, `doubleSided` materials, the
//    panel's emission as emissiveFactor x KHR_materials_emissive_strength, the point light as
//    KHR_lights_punctual (candela), the wall wound outwards kept;
//  - as a millimetre OBJ with an MTL and no unit scale: the same light in the same picture as
//    the room in metres (nothing in the methods may depend on the unit).
#include "penumbra/io/scene_io.h"
#include "penumbra/radiosity/matrix_radiosity.h"
#include "penumbra/radiosity/progressive.h"
#include "penumbra/radiosity/stochastic.h"
#include "support/image_compare.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <utility>

namespace penumbra {
namespace {

using nlohmann::json;
using test::TempDir;

constexpr int kWidth = 64, kHeight = 48;

Scene roomScene() {
  Expected<Scene> room = loadScene(std::string(PENUMBRA_TEST_DATA) + "/../../scenes/room.json");
  EXPECT_TRUE(room.ok()) << room.error().describe();
  return std::move(*room);
}

// The room's triangles (transforms applied), one glTF mesh per material.
std::string writeRoomGltf(const TempDir& dir, const Scene& room) {
  const FlatTriangles flat = flattenScene(room);
  std::string bin;
  json doc = {{"asset", {{"version", "2.0"}, {"generator", "penumbra tests"}}},
              {"extensionsUsed", {"KHR_lights_punctual", "KHR_materials_emissive_strength"}},
              {"scene", 0},
              {"scenes", {{{"nodes", json::array()}}}},
              {"nodes", json::array()},
              {"meshes", json::array()},
              {"materials", json::array()},
              {"accessors", json::array()},
              {"bufferViews", json::array()}};
  auto view = [&](const std::string& bytes, int target) {
    while (bin.size() % 4) bin.push_back('\0');
    doc["bufferViews"].push_back({{"buffer", 0},
                                  {"byteOffset", bin.size()},
                                  {"byteLength", bytes.size()},
                                  {"target", target}});
    bin += bytes;
    return int(doc["bufferViews"].size()) - 1;
  };
  for (size_t m = 0; m < room.materials.size(); ++m) {
    const Material& mat = room.materials[m];
    json jm = {
        {"name", mat.name},
        {"doubleSided", true},
        {"pbrMetallicRoughness",
         {{"baseColorFactor", {mat.reflectance.x, mat.reflectance.y, mat.reflectance.z, 1.0}},
          {"metallicFactor", 0.0},
          {"roughnessFactor", 1.0}}}};
    const float peak = std::max({mat.emission.x, mat.emission.y, mat.emission.z});
    if (peak > 0.0f) {
      const glm::vec3 f = mat.emission / peak;
      jm["emissiveFactor"] = {f.x, f.y, f.z};
      jm["extensions"] = {{"KHR_materials_emissive_strength", {{"emissiveStrength", peak}}}};
    }
    doc["materials"].push_back(jm);
    // This material's triangles, vertices unshared.
    std::string positions, indices;
    glm::vec3 lo(1e30f), hi(-1e30f);
    uint32_t count = 0;
    for (size_t t = 0; t < flat.triangles.size(); ++t) {
      if (flat.material_ids[t] != m) continue;
      for (int k = 0; k < 3; ++k) {
        const glm::vec3 p = flat.positions[flat.triangles[t][k]];
        positions.append(reinterpret_cast<const char*>(&p), sizeof(p));
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
        indices.append(reinterpret_cast<const char*>(&count), 4);
        ++count;
      }
    }
    if (count == 0) continue;
    const int pv = view(positions, 34962), iv = view(indices, 34963);
    doc["accessors"].push_back({{"bufferView", pv},
                                {"componentType", 5126},
                                {"count", count},
                                {"type", "VEC3"},
                                {"min", {lo.x, lo.y, lo.z}},
                                {"max", {hi.x, hi.y, hi.z}}});
    doc["accessors"].push_back(
        {{"bufferView", iv}, {"componentType", 5125}, {"count", count}, {"type", "SCALAR"}});
    const int a = int(doc["accessors"].size());
    json primitive = {{"attributes", {{"POSITION", a - 2}}}, {"indices", a - 1}, {"material", m}};
    json mesh = {{"name", mat.name}};
    mesh["primitives"] = json::array({primitive});
    doc["meshes"].push_back(mesh);
    doc["nodes"].push_back({{"mesh", doc["meshes"].size() - 1}});
    doc["scenes"][0]["nodes"].push_back(doc["nodes"].size() - 1);
  }
  // The point light: intensity in candela (683 lm/W), colour normalised.
  json lights = json::array();
  for (const Light& l : room.lights) {
    const PointLight& p = std::get<PointLight>(l);
    const float peak = std::max({p.intensity.x, p.intensity.y, p.intensity.z});
    const glm::vec3 c = p.intensity / peak;
    lights.push_back({{"type", "point"}, {"color", {c.x, c.y, c.z}}, {"intensity", peak * 683.0}});
    doc["nodes"].push_back(
        {{"translation", {p.position.x, p.position.y, p.position.z}},
         {"extensions", {{"KHR_lights_punctual", {{"light", lights.size() - 1}}}}}});
    doc["scenes"][0]["nodes"].push_back(doc["nodes"].size() - 1);
  }
  doc["extensions"] = {{"KHR_lights_punctual", {{"lights", lights}}}};
  doc["buffers"] = {{{"byteLength", bin.size()},
                     {"uri", "data:application/octet-stream;base64," + test::base64(bin)}}};
  const std::string path = dir.file("room.gltf");
  std::ofstream(path) << doc.dump();
  return path;
}

Image matrixView(const Scene& scene, const Camera& camera, uint32_t clusters) {
  MatrixRadiosityOptions o;
  o.elements = clusters;
  Expected<MatrixRadiosity> mr = buildMatrixRadiosity(scene, o);
  EXPECT_TRUE(mr.ok()) << mr.error().describe();
  SolveOptions so;
  so.tolerance = 1e-8;
  EXPECT_TRUE(mr->solve(so).converged);
  return test::lightmapView(mr->surface.flat, mr->surface.atlas, mr->radianceImage(), camera,
                            kWidth, kHeight, 16);
}

TEST(RealScenes, GltfRoomFromBlenderAgreesWithThePathTracerWithEveryRadiosityMethod) {
  const Scene room = roomScene();
  TempDir dir;
  Expected<Scene> scene = loadScene(writeRoomGltf(dir, room));
  ASSERT_TRUE(scene.ok()) << scene.error().describe();
  ASSERT_EQ(scene->lights.size(), 1u);
  for (const Material& m : scene->materials) EXPECT_TRUE(m.two_sided) << m.name;
  const Camera camera = *room.camera;
  const Image& reference =
      test::pathTracedReference("gltf-room", *scene, camera, kWidth, kHeight, 2048);

  ProgressiveOptions po;
  po.atlas.texel_density = texelDensityFor(*scene, 20000);
  po.convergence = 1e-3;
  po.max_iterations = 2000;
  Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(*scene, po);
  ASSERT_TRUE(pr.ok()) << pr.error().describe();
  ASSERT_TRUE(pr->solve().converged);
  const Image progressive = test::lightmapView(pr->triangles(), pr->atlas(), pr->radianceImage(),
                                               camera, kWidth, kHeight, 16);
  const Image matrix = matrixView(*scene, camera, 3000);
  StochasticOptions so;
  so.atlas.texel_density = po.atlas.texel_density;
  so.iterations = 5000;
  Expected<StochasticRadiosity> sr = StochasticRadiosity::build(*scene, so);
  ASSERT_TRUE(sr.ok()) << sr.error().describe();
  sr->solve();
  const Image stochastic = test::lightmapView(sr->triangles(), sr->atlas(), sr->radianceImage(),
                                              camera, kWidth, kHeight, 16);
  for (const auto& [name, image] : std::map<std::string, const Image*>{
           {"progressive", &progressive}, {"matrix", &matrix}, {"stochastic", &stochastic}}) {
    const test::BlockComparison b = test::compareBlocks(*image, reference, 4, 3.0);
    std::printf("glTF room, %s: mean / path tracer's (%.4f %.4f %.4f), block RMS %.4f\n",
                name.c_str(), b.mean_ratio.x, b.mean_ratio.y, b.mean_ratio.z, b.block_rms);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(b.mean_ratio[c], 1.0, 0.02) << name;
    EXPECT_LE(b.block_rms, 0.05) << name;
  }
  const EnergyBalance& books = pr->balance();
  EXPECT_LE(std::abs(books.escaped.x) / books.emitted.x, 1e-6);
}

// Progressive radiosity with adaptive subdivision (Wallner sec. 4) on `texels` texels, viewed.
Image adaptiveView(const Scene& scene, const Camera& camera, uint32_t texels) {
  ProgressiveOptions o;
  o.atlas.texel_density = texelDensityFor(scene, texels);
  o.adaptive = true;
  o.convergence = 1e-3;
  o.max_iterations = 2000;
  Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(scene, o);
  EXPECT_TRUE(pr.ok()) << pr.error().describe();
  EXPECT_TRUE(pr->solve().converged);
  return test::lightmapView(pr->triangles(), pr->atlas(), pr->radianceImage(), camera, kWidth,
                            kHeight, 16);
}

// Stochastic radiosity, `iterations` from `seed` on `texels` texels, viewed.
Image stochasticView(const Scene& scene, const Camera& camera, uint32_t texels, int iterations,
                     uint64_t seed) {
  StochasticOptions o;
  o.atlas.texel_density = texelDensityFor(scene, texels);
  o.iterations = iterations;
  o.seed = seed;
  Expected<StochasticRadiosity> sr = StochasticRadiosity::build(scene, o);
  EXPECT_TRUE(sr.ok()) << sr.error().describe();
  sr->solve();
  return test::lightmapView(sr->triangles(), sr->atlas(), sr->radianceImage(), camera, kWidth,
                            kHeight, 16);
}

// The room in millimetres as a CAD export writes it (an OBJ with its MTL, no scale), against the
// room in metres: the point light's intensity scaled by 1000^2 keeps the irradiance, so the
// pictures must match, with every radiosity method. The two atlases differ by rounding (4,511
// and 4,505 texels), so stochastic radiosity's runs part after a few iterations: its millimetre
// picture must be as near the metre one as another seed's metre picture is (the noise of 3,000
// iterations, 5% over 4 x 4 blocks).
TEST(RealScenes, MillimetreObjGivesTheMetrePicture) {
  Scene room = roomScene();
  const FlatTriangles flat = flattenScene(room);
  TempDir dir;
  {
    std::ofstream mtl(dir.file("room.mtl"));
    for (const Material& m : room.materials) {
      mtl << "newmtl " << m.name << "\nKd " << m.reflectance.x << " " << m.reflectance.y << " "
          << m.reflectance.z << "\nKe " << m.emission.x << " " << m.emission.y << " "
          << m.emission.z << "\n";
    }
    std::ofstream obj(dir.file("room.obj"));
    obj << "mtllib room.mtl\n";
    for (const glm::vec3& p : flat.positions) {
      obj << "v " << p.x * 1000.0f << " " << p.y * 1000.0f << " " << p.z * 1000.0f << "\n";
    }
    for (size_t m = 0; m < room.materials.size(); ++m) {
      obj << "usemtl " << room.materials[m].name << "\n";
      for (size_t t = 0; t < flat.triangles.size(); ++t) {
        if (flat.material_ids[t] != m) continue;
        const glm::uvec3 tri = flat.triangles[t] + 1u;
        obj << "f " << tri.x << " " << tri.y << " " << tri.z << "\n";
      }
    }
  }
  Expected<Scene> mm = loadScene(dir.file("room.obj"));
  ASSERT_TRUE(mm.ok()) << mm.error().describe();
  for (const Light& l : room.lights) {
    PointLight p = std::get<PointLight>(l);
    p.position *= 1000.0f;
    p.intensity *= 1e6f;
    mm->lights.push_back(p);
  }
  Camera camera_mm = *room.camera;
  camera_mm.position *= 1000.0f;
  camera_mm.look_at *= 1000.0f;
  const std::pair<Image, Image> views[] = {
      {matrixView(room, *room.camera, 1000), matrixView(*mm, camera_mm, 1000)},
      {adaptiveView(room, *room.camera, 8000), adaptiveView(*mm, camera_mm, 8000)},
      {stochasticView(room, *room.camera, 4000, 3000, 1),
       stochasticView(*mm, camera_mm, 4000, 3000, 1)}};
  const char* names[] = {"matrix", "progressive, adaptive", "stochastic"};
  const test::BlockComparison noise = test::compareBlocks(
      stochasticView(room, *room.camera, 4000, 3000, 2), views[2].first, 4, 3.0);
  std::printf("metres, stochastic seed 2 vs seed 1: block RMS %.5f\n", noise.block_rms);
  for (int k = 0; k < 3; ++k) {
    const test::BlockComparison b = test::compareBlocks(views[k].second, views[k].first, 4, 3.0);
    std::printf("millimetre OBJ vs metres (%s): mean ratio %.5f %.5f %.5f, block RMS %.5f\n",
                names[k], b.mean_ratio.x, b.mean_ratio.y, b.mean_ratio.z, b.block_rms);
    // Stochastic radiosity's random walk diverges between the two scales once any decision
    // rounds differently (a texel's anchor, radiosity/texel_footprint.h, tested by rays at
    // grazing angles on the scan): the two are then independent runs, whose RMS is about the
    // seed-to-seed noise; a unit error would be far beyond twice that.
    const bool noisy = k == 2;
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(b.mean_ratio[c], 1.0, noisy ? 0.02 : 0.005) << names[k];
    EXPECT_LE(b.block_rms, noisy ? 1.5 * noise.block_rms : 0.01) << names[k];
  }
}

}  // namespace
}  // namespace penumbra
