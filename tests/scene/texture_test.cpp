// Textures (scene/texture.h, scene/surface_textures.h): decoding every format a file may carry
// (8- and 16-bit PNG, JPEG, WebP, grey and grey-alpha), the sRGB decode, pyramids that keep the
// mean, wrap modes, nearest and bilinear lookups at known points, KHR_texture_transform in the
// direction Blender and the sample model use, and the means over parts of triangles that the
// radiosity elements take (a chequer's mean, a mask's covered fraction).
#include "penumbra/scene/texture.h"
#include "penumbra/io/image_io.h"
#include "penumbra/scene/surface_textures.h"
#include "support/image_files.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

namespace penumbra {
namespace {

double srgbToLinear(double v) {
  return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

std::shared_ptr<const Texture> textureOf(const std::string& bytes, bool colour,
                                         const std::string& name = "t.png") {
  Expected<TextureTexels> t = decodeTextureImage(name, bytes);
  EXPECT_TRUE(t.ok()) << (t.ok() ? "" : t.error().describe());
  if (!t.ok()) return nullptr;
  if (t->sixteen_bit) {
    return std::make_shared<const Texture>(
        Texture::fromRgba16(name, t->width, t->height, t->rgba16, colour, t->channels));
  }
  return std::make_shared<const Texture>(
      Texture::fromRgba8(name, t->width, t->height, std::move(t->rgba8), colour, t->channels));
}

const uint8_t kRed[4] = {255, 0, 0, 255};
const uint8_t kBlue[4] = {0, 0, 255, 128};

TEST(Texture, EveryFormatDecodesToTheSameTexels) {
  const test::Rgba8Image img = test::chequer(8, 4, 2, kRed, kBlue);
  for (const auto& [name, bytes] :
       {std::pair<std::string, std::string>{"a.png", test::pngBytes(img)},
        {"a.webp", test::webpBytes(img)}}) {
    const auto t = textureOf(bytes, true, name);
    ASSERT_TRUE(t) << name;
    EXPECT_EQ(t->width(), 8);
    EXPECT_EQ(t->height(), 4);
    EXPECT_TRUE(t->hasAlpha()) << name;
    // Texel (0, 0) red, (4, 0) blue at half alpha.
    EXPECT_EQ(t->fetch(0, 0, 0), glm::vec4(1, 0, 0, 1)) << name;
    EXPECT_NEAR(t->fetch(0, 4, 0).z, 1.0f, 1e-6f) << name;
    EXPECT_NEAR(t->fetch(0, 4, 0).w, 128.0f / 255.0f, 1e-6f) << name;
  }
  // JPEG: lossy, no alpha; the flat cells come back within a few codes.
  const auto jpeg = textureOf(test::jpegBytes(test::chequer(16, 16, 2, kRed, kRed)), true, "a.jpg");
  ASSERT_TRUE(jpeg);
  EXPECT_EQ(jpeg->fileChannels(), 3);
  EXPECT_FALSE(jpeg->hasAlpha());
  EXPECT_NEAR(jpeg->fetch(0, 3, 3).x, 1.0f, 0.03f);
  EXPECT_NEAR(jpeg->fetch(0, 3, 3).y, 0.0f, 0.01f);
  // Grey and grey-alpha PNGs: grey to all three channels; alpha where the file has it.
  const auto grey = textureOf(test::pngBytes(img, 2), false);
  ASSERT_TRUE(grey);
  EXPECT_EQ(grey->fileChannels(), 2);
  EXPECT_EQ(grey->fetch(0, 0, 0), glm::vec4(1, 1, 1, 1));
  EXPECT_NEAR(grey->fetch(0, 4, 0).w, 128.0f / 255.0f, 1e-6f);
}

TEST(Texture, SixteenBitPngKeepsItsPrecision) {
  // Linear data (not colour): the values as stored over 65535.
  std::vector<uint16_t> texels = {1, 2, 65535, 65535, 30000, 40000, 50000, 65535};
  const auto t = textureOf(test::png16Bytes(2, 1, texels), false);
  ASSERT_TRUE(t);
  EXPECT_EQ(t->encoding(), TexelEncoding::kLinear16);
  EXPECT_NEAR(t->fetch(0, 0, 0).x, 1.0 / 65535.0, 1e-9);
  EXPECT_NEAR(t->fetch(0, 1, 0).y, 40000.0 / 65535.0, 1e-7);
  // Colour: decoded from sRGB once, at 16 bits.
  const auto c = textureOf(test::png16Bytes(2, 1, texels), true);
  ASSERT_TRUE(c);
  EXPECT_NEAR(c->fetch(0, 1, 0).x, srgbToLinear(30000.0 / 65535.0), 2e-5);
  EXPECT_NEAR(c->fetch(0, 1, 0).w, 1.0, 1e-9);  // alpha stays linear
}

TEST(Texture, SrgbDecodingFollowsTheStandard) {
  for (int v : {0, 1, 10, 11, 128, 200, 255}) {
    EXPECT_NEAR(srgb8ToLinear(uint8_t(v)), srgbToLinear(v / 255.0), 1e-7) << v;
  }
}

TEST(Texture, PyramidLevelsKeepTheMean) {
  // Odd sizes included: 7 x 5 goes to 3 x 2, 1 x 1.
  test::Rgba8Image img;
  img.width = 7;
  img.height = 5;
  for (int i = 0; i < 35; ++i) {
    const uint8_t v = uint8_t((i * 37) % 256);
    img.texels.insert(img.texels.end(), {v, uint8_t(255 - v), uint8_t(v / 2), 255});
  }
  const auto t = textureOf(test::pngBytes(img), false);
  ASSERT_TRUE(t);
  ASSERT_EQ(t->levelCount(), 3);
  EXPECT_EQ(t->level(1).width, 3);
  EXPECT_EQ(t->level(1).height, 2);
  // Level 1's texels each average a 2 x 2 block, or the 3-wide block at the odd edge.
  glm::dvec4 block(0.0);
  for (int y = 0; y < 2; ++y) {
    for (int x = 4; x < 7; ++x) block += glm::dvec4(t->fetch(0, x, y)) / 6.0;
  }
  EXPECT_NEAR(t->fetch(1, 2, 0).x, block.x, 0.5 / 255.0);
  // Every level, its texels weighted by the level-0 texels under them, has the image's mean;
  // the top level is the mean (within the rounding of two 8-bit steps).
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(t->fetch(2, 0, 0)[c], t->mean()[c], 1.0 / 255.0) << c;
}

TEST(Texture, WrapModesAndFilters) {
  // A 4 x 1 ramp of grey levels 0, 85, 170, 255 (data).
  test::Rgba8Image img;
  img.width = 4;
  img.height = 1;
  for (uint8_t v : {0, 85, 170, 255}) img.texels.insert(img.texels.end(), {v, v, v, 255});
  const auto t = textureOf(test::pngBytes(img), false);
  ASSERT_TRUE(t);
  TextureSampler s;
  // Texel centres reproduce the texels; halfway between two the mean.
  EXPECT_NEAR(sampleTexture(*t, s, {0.375f, 0.5f}).x, 85.0f / 255.0f, 1e-6f);
  EXPECT_NEAR(sampleTexture(*t, s, {0.5f, 0.5f}).x, 127.5f / 255.0f, 1e-6f);
  // Repeat: s = 1.375 is s = 0.375; at the seam texel 3 meets texel 0.
  EXPECT_NEAR(sampleTexture(*t, s, {1.375f, 0.5f}).x, 85.0f / 255.0f, 1e-5f);
  EXPECT_NEAR(sampleTexture(*t, s, {1.0f, 0.5f}).x, 0.5f, 1e-5f);
  // Clamp: beyond the edge the edge texel.
  s.wrap_s = TextureWrap::kClampToEdge;
  EXPECT_NEAR(sampleTexture(*t, s, {1.0f, 0.5f}).x, 1.0f, 1e-6f);
  EXPECT_NEAR(sampleTexture(*t, s, {-3.0f, 0.5f}).x, 0.0f, 1e-6f);
  // Mirrored repeat: s = 1.125 reads s = 0.875 (texel 3), s = -0.125 reads 0.125 (texel 0).
  s.wrap_s = TextureWrap::kMirroredRepeat;
  EXPECT_NEAR(sampleTexture(*t, s, {1.125f, 0.5f}).x, 1.0f, 1e-5f);
  EXPECT_NEAR(sampleTexture(*t, s, {-0.125f, 0.5f}).x, 0.0f, 1e-5f);
  // Nearest: the texel holding the point.
  s.wrap_s = TextureWrap::kRepeat;
  s.nearest = true;
  EXPECT_NEAR(sampleTexture(*t, s, {0.49f, 0.5f}).x, 85.0f / 255.0f, 1e-6f);
  EXPECT_NEAR(sampleTexture(*t, s, {0.51f, 0.5f}).x, 170.0f / 255.0f, 1e-6f);
  // Huge coordinates wrap without overflow.
  EXPECT_TRUE(std::isfinite(sampleTexture(*t, s, {3e9f, -7e12f}).x));
}

TEST(Texture, KhrTextureTransformRotatesAsBlenderAndTheSampleModel) {
  // KHR_texture_transform with rotation pi/2 (glTF issue #1563: u' = cos u + sin v,
  // v' = -sin u + cos v), offset (0.5, 0) and scale (2, 1): uv (1, 0) -> (0.5 + 0, -2).
  TextureBinding b;
  b.setTransform({0.5f, 0.0f}, float(M_PI / 2), {2.0f, 1.0f});
  const glm::vec2 st = b.imageCoordinates({1.0f, 0.0f}, true);
  EXPECT_NEAR(st.x, 0.5f, 1e-6f);
  EXPECT_NEAR(st.y, -2.0f, 1e-6f);
  const glm::vec2 st2 = b.imageCoordinates({0.0f, 1.0f}, true);
  EXPECT_NEAR(st2.x, 1.5f, 1e-6f);
  EXPECT_NEAR(st2.y, 0.0f, 1e-6f);
  // A mesh whose v grows up the image (OBJ) reads t = 1 - v'.
  TextureBinding plain;
  EXPECT_NEAR(plain.imageCoordinates({0.25f, 0.25f}, false).y, 0.75f, 1e-6f);
}

TEST(Texture, RejectsWhatIsNotAnImage) {
  EXPECT_FALSE(decodeTextureImage("x.png", "hello").ok());
  EXPECT_FALSE(decodeTextureImage("x.png", std::string("\x89PNG\r\n\x1a\n", 8) + "garbage").ok());
  const Expected<TextureTexels> t = decodeTextureImage("x.webp", "RIFF\x10\0\0\0WEBPVP8 junk");
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.error().describe().find("x.webp"), std::string::npos);
  // A PNG header that claims far more pixels than its bytes can hold.
  std::string png = test::pngBytes(test::chequer(2, 2, 1, kRed, kRed));
  png[16] = '\x7f';  // width's top byte
  EXPECT_FALSE(decodeTextureImage("big.png", png).ok());
}

// One textured quad [0,1]^2 in the z = 0 plane, UVs = (x, y), v up the image (an OBJ mesh).
Scene texturedQuad(std::shared_ptr<const Texture> t, AlphaMode mode = AlphaMode::kOpaque) {
  Scene s;
  s.source = "quad";
  Material m;
  m.name = "textured";
  m.reflectance = glm::vec3(1.0f);
  m.reflectance_texture = TextureBinding{};
  m.reflectance_texture->texture = std::move(t);
  m.alpha_mode = mode;
  s.materials.push_back(m);
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  mesh.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
  mesh.material_ids = {0, 0};
  s.meshes.push_back(mesh);
  EXPECT_TRUE(validateScene(s).ok());
  return s;
}

TEST(SurfaceTextures, MeansOverPartsOfATriangleAreTheTexturesMeans) {
  // A 64 x 64 chequer of 8 x 8 cells: red and blue (alpha 1/2).
  const auto t = textureOf(test::pngBytes(test::chequer(64, 64, 8, kRed, kBlue)), true);
  ASSERT_TRUE(t);
  const SurfaceTextures st(texturedQuad(t));
  EXPECT_TRUE(st.any());
  EXPECT_FALSE(st.hasCutouts());  // opaque: alpha is ignored
  // The whole quad (its two triangles, of equal areas): the chequer's mean, 1/2 red and 1/2
  // blue.
  const SurfaceTextures::Mean a = st.triangleMean(0), b = st.triangleMean(1);
  EXPECT_NEAR(0.5 * (a.reflectance.x + b.reflectance.x), 0.5, 0.005);
  EXPECT_NEAR(0.5 * (a.reflectance.z + b.reflectance.z), 0.5, 0.005);
  EXPECT_NEAR(a.coverage, 1.0, 1e-12);
  // A piece inside the bottom-left cell (the quad's point (x, y) is image (x, 1 - y), in cell
  // column 0, row 7: blue). On triangle 0 the point (x, y) has barycentrics (x - y, y).
  const glm::vec2 piece[3] = {{0.01f, 0.01f}, {0.10f, 0.01f}, {0.01f, 0.10f}};
  const SurfaceTextures::Mean m = st.mean(0, piece);
  EXPECT_NEAR(m.reflectance.z, 1.0, 1e-3);
  EXPECT_NEAR(m.reflectance.x, 0.0, 1e-3);
  // At a point: the texel there.
  EXPECT_NEAR(st.reflectance(0, {0.05f, 0.02f}).z, 1.0f, 1e-6f);
}

TEST(SurfaceTextures, AMaskCoversItsShareAndStopsRaysWhereCovered) {
  // Alpha 1 (red) and 1/2 (blue) cells; cutoff 0.6: the blue half is a hole.
  const auto t = textureOf(test::pngBytes(test::chequer(64, 64, 8, kRed, kBlue)), true);
  ASSERT_TRUE(t);
  Scene s = texturedQuad(t, AlphaMode::kMask);
  s.materials[0].alpha_cutoff = 0.6f;
  const SurfaceTextures st(s);
  EXPECT_TRUE(st.hasCutouts());
  EXPECT_TRUE(st.isCutout(0));
  const SurfaceTextures::Mean m0 = st.triangleMean(0), m1 = st.triangleMean(1);
  EXPECT_NEAR(0.5 * (m0.coverage + m1.coverage), 0.5, 0.01);
  EXPECT_NEAR(0.5 * (m0.reflectance.x + m1.reflectance.x), 0.5, 0.01);  // the red half reflects
  EXPECT_NEAR(m0.reflectance.z, 0.0, 1e-6);
  EXPECT_TRUE(st.stops(0, {0.15f, 0.05f}, 0.5f));   // point (0.2, 0.05): a red cell
  EXPECT_FALSE(st.stops(0, {0.05f, 0.02f}, 0.0f));  // the blue cell at the bottom-left
  // Blend: coverage is alpha; a ray stops with probability alpha.
  s.materials[0].alpha_mode = AlphaMode::kBlend;
  const SurfaceTextures blend(s);
  EXPECT_NEAR(0.5 * (blend.triangleMean(0).coverage + blend.triangleMean(1).coverage),
              0.5 * (1.0 + 128.0 / 255.0), 0.005);
  EXPECT_TRUE(blend.stops(0, {0.05f, 0.02f}, 0.4f));
  EXPECT_FALSE(blend.stops(0, {0.05f, 0.02f}, 0.6f));
}

}  // namespace
}  // namespace penumbra
