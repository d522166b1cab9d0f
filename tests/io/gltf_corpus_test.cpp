// glTF files as people download them (tests/data/gltf-corpus, its manifest and licences): every
// file of the corpus loads without a parser's message, with the triangles the Khronos validator
// counts (copies of instanced meshes expanded) and the textures its materials read; the one that
// needs a decoder no Debian library has is refused naming the extension; the Avocado's compressed
// variants (Draco, meshopt in both names, quantized, WebP, JPEG) give the plain file's picture;
// every PNG layout decodes to the same texels.
#include "penumbra/io/scene_io.h"
#include "penumbra/raytrace/path_tracer.h"
#include "penumbra/scene/scene.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace penumbra {
namespace {

const std::string kCorpus = std::string(PENUMBRA_TEST_DATA) + "/gltf-corpus/";

// The scene's triangles, and the texture slots its materials fill (base colour, emission, normal
// map), counting a slot once per material that the scene's meshes use.
struct Census {
  size_t triangles = 0;
  size_t texture_slots = 0;
};

Census census(const Scene& s) {
  Census c;
  std::set<uint32_t> used;
  for (const Mesh& m : s.meshes) {
    c.triangles += m.triangles.size();
    used.insert(m.material_ids.begin(), m.material_ids.end());
  }
  for (uint32_t id : used) {
    const Material& m = s.materials[id];
    c.texture_slots += (m.reflectance_texture ? 1 : 0) + (m.emission_texture ? 1 : 0) +
                       (m.coverage_texture ? 1 : 0) + (m.normal_map ? 1 : 0);
  }
  return c;
}

// What each file of the corpus holds once loaded (docs/scene-format.md, "glTF 2.0"): triangles
// of the default scene with every node's and every GPU instance's copy, and texture slots (a
// texture shared by several materials counts once per material).
struct FileExpectation {
  const char* path;
  size_t triangles;
  size_t texture_slots;
};

// The Avocado reads its base colour and normal map (roughness and metalness are specular, which
// a diffuse solution does not carry).
const FileExpectation kFiles[] = {
    {"avocado/Avocado.gltf", 682, 2},
    {"avocado/Avocado.glb", 682, 2},
    {"avocado/Avocado.draco.glb", 682, 2},
    {"avocado/Avocado.jpeg.glb", 682, 2},
    {"avocado/Avocado.khr-meshopt-quantized.glb", 682, 2},
    {"avocado/Avocado.khr-meshopt.glb", 682, 2},
    {"avocado/Avocado.ktx2-fallback.gltf", 682, 2},
    {"avocado/Avocado.meshopt-cf.glb", 682, 2},
    {"avocado/Avocado.meshopt-quantized.glb", 682, 2},
    {"avocado/Avocado.meshopt.glb", 682, 2},
    {"avocado/Avocado.quantized.glb", 682, 2},
    {"avocado/Avocado.webp.glb", 682, 2},
    {"features/Box With Spaces/Box With Spaces.gltf", 12, 1},
    {"features/BoxTextured-glTF-Embedded/BoxTextured.gltf", 12, 1},
    {"features/BoxTextured-pbrSpecularGlossiness/BoxTextured.gltf", 12, 1},
    {"features/CubeImageUriSpaces-tinygltf/CubeImageUriMultipleSpaces.gltf", 12, 1},
    {"features/CubeImageUriSpaces-tinygltf/CubeImageUriSpaces.gltf", 12, 1},
    {"features/EXT_texture_webp-gltf-pipeline/box-textured-separate.gltf", 12, 1},
    {"features/EXT_texture_webp-gltf-pipeline/box-textured-with-fallback.gltf", 12, 1},
    {"features/MeshPrimitiveModes-AssetGenerator/Mesh_PrimitiveMode_04.gltf", 2, 0},
    {"features/MeshPrimitiveModes-AssetGenerator/Mesh_PrimitiveMode_05.gltf", 2, 0},
    {"features/MeshPrimitiveModes-AssetGenerator/Mesh_PrimitiveMode_11.gltf", 2, 0},
    {"features/MeshPrimitiveModes-AssetGenerator/Mesh_PrimitiveMode_12.gltf", 2, 0},
    {"features/MeshPrimitiveModes-AssetGenerator/Mesh_PrimitiveMode_13.gltf", 2, 0},
    {"features/MultipleScenes/MultipleScenes.gltf", 2, 0},
    {"features/RiggedSimple/RiggedSimple.gltf", 188, 0},
    {"features/SimpleMeshes/SimpleMeshes.gltf", 2, 0},
    {"features/SimpleMorph/SimpleMorph.gltf", 1, 0},
    {"features/SimpleSparseAccessor/SimpleSparseAccessor.gltf", 12, 0},
    {"features/TextureCoordinateTest/TextureCoordinateTest.gltf", 10, 4},
    {"features/TextureSettingsTest/TextureSettingsTest.gltf", 72, 9},
    {"features/TextureTransformTest/TextureTransformTest.gltf", 24, 9},
    {"features/UnlitTest/UnlitTest.gltf", 88, 0},
    {"features/compression-gltf-transform-tests/BoxDraco.gltf", 12, 0},
    {"features/compression-gltf-transform-tests/BoxMeshopt.glb", 12, 0},
    {"features/compression-gltf-transform-tests/DracoSparseMesh.gltf", 102, 0},
    {"features/instancing-generated/SimpleMeshes.gltfpack-mi.gltf", 2, 0},
    {"features/instancing-generated/SimpleMeshes.gt-instance.gltf", 2, 0},
    {"features/meshopt-gltf-pipeline/EXT_meshopt_compression/meshopt-fallback/"
     "meshopt-fallback.gltf",
     60, 0},
    {"features/meshopt-gltf-pipeline/EXT_meshopt_compression/meshopt-no-fallback/"
     "meshopt-no-fallback.gltf",
     60, 0},
    {"features/meshopt-gltf-pipeline/KHR_meshopt_compression/meshopt-fallback/"
     "meshopt-fallback.gltf",
     60, 0},
    {"features/meshopt-gltf-pipeline/KHR_meshopt_compression/meshopt-no-fallback/"
     "meshopt-no-fallback.gltf",
     60, 0},
};

TEST(GltfCorpus, EveryFileLoadsWithItsTrianglesAndTextures) {
  for (const FileExpectation& e : kFiles) {
    SCOPED_TRACE(e.path);
    const Expected<Scene> s = loadGltf(kCorpus + e.path);
    ASSERT_TRUE(s.ok()) << s.error().describe();
    const Census c = census(*s);
    EXPECT_EQ(c.triangles, e.triangles);
    EXPECT_EQ(c.texture_slots, e.texture_slots);
    for (const std::string& w : s->warnings) {
      EXPECT_EQ(w.find("tinygltf"), std::string::npos) << w;
      EXPECT_EQ(w.find("not supported"), std::string::npos) << w;
    }
  }
}

// Every PNG layout: 16 x 16 texels in 4 x 4 blocks, block k = (x / 4 + y / 4) % n of the colours
// red, green, blue, white (greys 0, 85, 170, 255 for grey images; n = 2 for 1-bit ones).
TEST(GltfCorpus, EveryPngLayoutDecodesToItsTexels) {
  struct Layout {
    const char* name;
    int colours;
    bool grey;
    float white_alpha;  // the alpha of the last colour
  };
  const Layout layouts[] = {
      {"quad-rgba-8bit", 4, false, 1.0f},    {"quad-rgb-8bit-interlaced", 4, false, 1.0f},
      {"quad-rgb-16bit", 4, false, 1.0f},    {"quad-rgba-16bit", 4, false, 32896 / 65535.0f},
      {"quad-palette-1bit", 2, false, 1.0f}, {"quad-palette-2bit", 4, false, 1.0f},
      {"quad-palette-4bit", 4, false, 1.0f}, {"quad-palette-4bit-trns", 4, false, 0.0f},
      {"quad-palette-8bit", 4, false, 1.0f}, {"quad-grey-1bit", 2, true, 1.0f},
      {"quad-grey-2bit", 4, true, 1.0f},     {"quad-grey-4bit", 4, true, 1.0f},
      {"quad-grey-16bit", 4, true, 1.0f},    {"quad-greyalpha-16bit", 4, true, 0.0f},
  };
  const glm::vec3 rgb[4] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
  auto srgb = [](float v) {
    return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
  };
  for (const Layout& l : layouts) {
    SCOPED_TRACE(l.name);
    const Expected<Scene> s =
        loadGltf(kCorpus + "features/png-formats/" + std::string(l.name) + ".gltf");
    ASSERT_TRUE(s.ok()) << s.error().describe();
    ASSERT_EQ(s->meshes.size(), 1u);
    const Material& m = s->materials[s->meshes[0].material_ids[0]];
    ASSERT_TRUE(m.reflectance_texture.has_value());
    const Texture& t = *m.reflectance_texture->texture;
    ASSERT_EQ(t.width(), 16);
    ASSERT_EQ(t.height(), 16);
    for (int y = 0; y < 16; ++y) {
      for (int x = 0; x < 16; ++x) {
        const int k = (x / 4 + y / 4) % l.colours;
        // Two colours: red and green in a palette, black and white in grey.
        const int colour = l.colours == 2 && l.grey ? 3 * k : k;
        glm::vec3 want = rgb[colour];
        if (l.grey) want = glm::vec3(srgb(float(colour * 85) / 255.0f));
        const glm::vec4 got = t.fetch(0, x, y);
        for (int c = 0; c < 3; ++c) ASSERT_NEAR(got[c], want[c], 2e-3f) << x << "," << y;
        ASSERT_NEAR(got.w, colour == 3 ? l.white_alpha : 1.0f, 2e-3f) << x << "," << y;
      }
    }
  }
}

// The plain Avocado rendered under a uniform environment, and each variant the same way from
// the same camera: compression changes the bytes, not the picture. The path tracer shades with
// geometric normals, so the picture cannot see the decoded normals (Draco's, meshopt's
// octahedral filter, quantized bytes): they are compared directly, each variant vertex's normal
// with the plain file's at the same place (the best of coincident vertices, for seams), and
// mirrored normals, as a wrong octahedral decoding would give, fail that comparison.
TEST(GltfCorpus, CompressedVariantsGiveThePlainFilesPicture) {
  auto load = [](const std::string& file) {
    Expected<Scene> s = loadGltf(kCorpus + "avocado/" + file);
    EXPECT_TRUE(s.ok()) << s.error().describe();
    return s.ok() ? std::move(*s) : Scene();
  };
  auto render = [](Scene s, const Camera& camera) {
    s.environment = glm::vec3(1.0f);
    PathTracerSettings settings;
    settings.width = 48;
    settings.height = 48;
    settings.spp = 16;
    settings.max_depth = 3;
    return PathTracer(s).render(camera, settings);
  };
  const Scene plain = load("Avocado.gltf");
  ASSERT_FALSE(plain.meshes.empty());
  const Camera camera = defaultCamera(plain);
  const Image reference = render(plain, camera);
  double mean = 0.0;
  for (const glm::vec3& p : reference.pixels) mean += (p.x + p.y + p.z) / 3.0;
  mean /= double(reference.pixels.size());
  ASSERT_GT(mean, 0.05);
  auto relativeRms = [&](const Image& image) {
    double sq = 0.0;
    for (size_t i = 0; i < image.pixels.size(); ++i) {
      const glm::vec3 d = image.pixels[i] - reference.pixels[i];
      sq += double(glm::dot(d, d)) / 3.0;
    }
    return std::sqrt(sq / double(image.pixels.size())) / mean;
  };
  // The smallest, over a variant's vertices, of the best cosine between its normal and the
  // plain file's normals within 1e-3 of the model's size of it.
  glm::vec3 lo(1e30f), hi(-1e30f);
  for (const Mesh& m : plain.meshes) {
    for (const glm::vec3& p : m.positions) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
  }
  const float near = 1e-3f * glm::length(hi - lo);
  auto worstNormal = [&](const Scene& s) {
    double worst = 1.0;
    for (const Mesh& m : s.meshes) {
      for (size_t v = 0; v < m.positions.size(); ++v) {
        double best = -1.0;
        for (const Mesh& pm : plain.meshes) {
          for (size_t w = 0; w < pm.positions.size(); ++w) {
            if (glm::length(pm.positions[w] - m.positions[v]) > near) continue;
            best = std::max(best, double(glm::dot(pm.normals[w], m.normals[v])));
          }
        }
        worst = std::min(worst, best);
      }
    }
    return worst;
  };
  Scene mirrored = plain;
  for (Mesh& m : mirrored.meshes) {
    for (glm::vec3& n : m.normals) n.x = -n.x;
  }
  EXPECT_LT(worstNormal(mirrored), 0.9);
  const std::pair<const char*, double> variants[] = {
      {"Avocado.glb", 1e-6},
      {"Avocado.draco.glb", 0.03},
      {"Avocado.meshopt.glb", 1e-6},
      {"Avocado.meshopt-cf.glb", 1e-6},
      {"Avocado.khr-meshopt.glb", 1e-6},
      {"Avocado.quantized.glb", 0.03},
      {"Avocado.meshopt-quantized.glb", 0.03},
      {"Avocado.khr-meshopt-quantized.glb", 0.03},
      {"Avocado.ktx2-fallback.gltf", 1e-6},
      {"Avocado.webp.glb", 0.05},
      {"Avocado.jpeg.glb", 0.05},
  };
  for (const auto& [file, tolerance] : variants) {
    SCOPED_TRACE(file);
    const Scene variant = load(file);
    const Image image = render(variant, camera);
    ASSERT_EQ(image.pixels.size(), reference.pixels.size());
    EXPECT_LE(relativeRms(image), tolerance);
    // Normals: exact where the geometry is lossless; octahedral and 8-bit quantized normals
    // within a few degrees.
    EXPECT_GT(worstNormal(variant), tolerance < 1e-3 ? 0.9999 : 0.99);
  }
}

TEST(GltfCorpus, AKtx2TextureWithoutFallbackIsRefusedNamingTheExtensionAndMaterial) {
  const std::string path = kCorpus + "avocado/Avocado.ktx2-nofallback.gltf";
  const Expected<Scene> s = loadGltf(path);
  ASSERT_FALSE(s.ok());
  const std::string message = s.error().describe();
  EXPECT_NE(message.find("KHR_texture_basisu"), std::string::npos) << message;
  EXPECT_NE(message.find("material 0"), std::string::npos) << message;
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
}

// Blender's export of a field of instanced objects (EXT_mesh_gpu_instancing): every copy, 7.66
// million triangles from a 161 KB file.
TEST(GltfCorpus, GpuInstancesAreEveryCopy) {
  const Expected<Scene> s =
      loadGltf(kCorpus + "features/gpu-instancing-blender/24_gpu_instancing.gltf");
  ASSERT_TRUE(s.ok()) << s.error().describe();
  EXPECT_EQ(census(*s).triangles, 7656770u);
}

}  // namespace
}  // namespace penumbra
