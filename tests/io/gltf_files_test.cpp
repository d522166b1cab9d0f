// The files a glTF asset names, read by Penumbra itself (io/asset_files.h, io/gltf/gltf_asset.h):
// the reproducers of a hostile-input campaign and the valid cases next to them.
//   - only images a texture reads are read; URIs resolve against the asset's folder only,
//     percent-decoded ('+' is a plus), never from the current directory, never out of the folder
//     unless allowed; a FIFO is refused without blocking;
//   - every buffer view is checked against its buffer before a pointer is taken;
//   - values of the wrong type or range (a string wrapS, a texCoord of 2^32 + 1) are refused;
//   - data URIs of every image type decode.
#include "penumbra/io/asset_files.h"
#include "penumbra/io/scene_io.h"
#include "support/image_files.h"
#include "support/test_util.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace penumbra {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::TempDir;

template <typename T>
void append(std::string& buf, std::initializer_list<T> values) {
  for (T v : values) buf.append(reinterpret_cast<const char*>(&v), sizeof(T));
}

// A textured unit quad: positions, UVs and indices in buffer 0 (a data URI), a material whose
// base colour texture reads image 0.
struct Quad {
  json doc;
  std::string bin;
};

Quad texturedQuad(const std::string& image_uri) {
  Quad q;
  append<float>(q.bin, {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0});
  append<float>(q.bin, {0, 1, 1, 1, 1, 0, 0, 0});
  append<uint16_t>(q.bin, {0, 1, 2, 0, 2, 3});
  q.doc = {
      {"asset", {{"version", "2.0"}}},
      {"scene", 0},
      {"scenes", {{{"nodes", {0}}}}},
      {"nodes", {{{"mesh", 0}}}},
      {"meshes",
       {{{"primitives",
          {{{"attributes", {{"POSITION", 0}, {"TEXCOORD_0", 1}}},
            {"indices", 2},
            {"material", 0}}}}}}},
      {"materials",
       {{{"name", "painted"}, {"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}}}},
      {"textures", {{{"source", 0}}}},
      {"images", {{{"uri", image_uri}}}},
      {"buffers", {{{"byteLength", 92}}}},
      {"bufferViews",
       {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 48}},
        {{"buffer", 0}, {"byteOffset", 48}, {"byteLength", 32}},
        {{"buffer", 0}, {"byteOffset", 80}, {"byteLength", 12}}}},
      {"accessors",
       {{{"bufferView", 0}, {"componentType", 5126}, {"count", 4}, {"type", "VEC3"}},
        {{"bufferView", 1}, {"componentType", 5126}, {"count", 4}, {"type", "VEC2"}},
        {{"bufferView", 2}, {"componentType", 5123}, {"count", 6}, {"type", "SCALAR"}}}}};
  return q;
}

std::string png2x2() {
  const uint8_t red[4] = {255, 0, 0, 255}, white[4] = {255, 255, 255, 255};
  return test::pngBytes(test::chequer(2, 2, 2, red, white));
}

std::string writeQuad(const std::filesystem::path& dir, const std::string& name, Quad q) {
  q.doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + test::base64(q.bin);
  std::filesystem::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path, std::ios::binary) << q.doc.dump(1);
  return path;
}

void writeFile(const std::filesystem::path& path, const std::string& bytes) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << bytes;
}

// A bake embeds the scene's texture images in its .bin; glTF takes PNG, JPEG and WebP there, so
// a TGA or BMP texture (which Penumbra reads) is written as a PNG of its texels, and the baked
// asset opens again with the same texels (it was stored as image/png holding TGA bytes, and
// refused on reopening).
TEST(GltfFiles, ABakeWritesATgaTextureAsAPng) {
  TempDir dir;
  // 2 x 2, 24-bit, bottom-up: blue, red / green, white (BGR bytes).
  std::string tga = {0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2, 0, 2, 0, 24, 0};
  for (int v : {255, 0, 0, 0, 0, 255, 0, 255, 0, 255, 255, 255}) tga.push_back(char(v));
  writeFile(dir.path() / "in" / "t.tga", tga);
  Quad q = texturedQuad("t.tga");
  q.doc["materials"][0]["doubleSided"] = true;
  const std::string path = writeQuad(dir.path() / "in", "quad.gltf", q);
  Expected<Scene> before = loadGltf(path);
  ASSERT_TRUE(before.ok()) << before.error().describe();
  const std::string out = (dir.path() / "out").string();
  const auto r =
      test::runCli("bake " + path + " -o " + out + " --method matrix --environment 1,1,1 --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const json baked = test::readJson(out + "/quad.gltf");
  EXPECT_EQ(baked["images"][0]["mimeType"], "image/png");
  Expected<Scene> after = loadGltf(out + "/quad.gltf");
  ASSERT_TRUE(after.ok()) << after.error().describe();
  const Texture& a = *before->materials[0].reflectance_texture->texture;
  const Texture& b = *after->materials[0].reflectance_texture->texture;
  ASSERT_EQ(b.width(), 2);
  ASSERT_EQ(b.height(), 2);
  for (int y = 0; y < 2; ++y) {
    for (int x = 0; x < 2; ++x) EXPECT_EQ(a.fetch(0, x, y), b.fetch(0, x, y)) << x << "," << y;
  }
}

TEST(AssetFiles, PercentDecodingIsRfc3986AndPlusIsAPlus) {
  Expected<std::string> d = percentDecode("a%20b+c%2Bd%25", "f", "p");
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(*d, "a b+c+d%");
  EXPECT_FALSE(percentDecode("bad%2", "f", "p").ok());
  EXPECT_FALSE(percentDecode("bad%zz", "f", "p").ok());
  // A NUL decodes (it is data in a data URI); a file name holding one is refused.
  Expected<std::string> nul = percentDecode("nul%00", "f", "p");
  ASSERT_TRUE(nul.ok());
  EXPECT_EQ(*nul, std::string("nul\0", 4));
  EXPECT_TRUE(test::errorNames(resolveAssetFile("f.gltf", "nul%00.png", true, {}, "images[0]"),
                               "f.gltf", "NUL"));
  EXPECT_EQ(percentEncodePath("room #1/a+b?.png"), "room%20%231/a%2Bb%3F.png");
  // What is encoded reads back as itself.
  Expected<std::string> back = percentDecode(percentEncodePath("x %+#?\\\xc3\xa9.png"), "f", "p");
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(*back, "x %+#?\\\xc3\xa9.png");
}

TEST(AssetFiles, DataUrisDecodeAndLiesAreRefused) {
  Expected<DataUri> d = decodeDataUri("data:image/webp;base64,QUJD", 100, "f", "p");
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(d->media_type, "image/webp");
  EXPECT_EQ(d->bytes, "ABC");
  EXPECT_FALSE(decodeDataUri("data:image/png;base64,QU!D", 100, "f", "p").ok());
  EXPECT_FALSE(decodeDataUri("data:image/png;base64", 100, "f", "p").ok());
  EXPECT_FALSE(decodeDataUri("data:;base64,QUJDQUJDQUJD", 3, "f", "p").ok());
  Expected<DataUri> plain = decodeDataUri("data:,a%20b", 100, "f", "p");
  ASSERT_TRUE(plain.ok());
  EXPECT_EQ(plain->bytes, "a b");
  // Percent-encoded bytes are measured decoded: 3 bytes in 9 characters fit a limit of 3, NULs
  // included; 4 do not.
  Expected<DataUri> bytes = decodeDataUri("data:,%00%01%FF", 3, "f", "p");
  ASSERT_TRUE(bytes.ok()) << bytes.error().describe();
  EXPECT_EQ(bytes->bytes, std::string("\0\1\xff", 3));
  EXPECT_FALSE(decodeDataUri("data:,%41%42%43%44", 3, "f", "p").ok());
}

TEST(GltfFiles, UrisResolveInTheAssetsFolderPercentDecoded) {
  TempDir dir;
  writeFile(dir.path() / "asset" / "my tex+1.png", png2x2());
  // "%20" is a space, '+' a plus.
  const std::string path =
      writeQuad(dir.path() / "asset", "q.gltf", texturedQuad("my%20tex+1.png"));
  Expected<Scene> s = loadGltf(path);
  ASSERT_TRUE(s.ok()) << s.error().describe();
  ASSERT_TRUE(s->materials[0].reflectance_texture.has_value());
  EXPECT_EQ(s->materials[0].reflectance_texture->texture->width(), 2);
  // A query or fragment is not part of the file name.
  Expected<Scene> q =
      loadGltf(writeQuad(dir.path() / "asset", "q2.gltf", texturedQuad("my%20tex+1.png?v=2#x")));
  EXPECT_TRUE(q.ok()) << q.error().describe();
}

TEST(GltfFiles, FilesOutsideTheAssetsFolderAreNotReadUnlessAllowed) {
  TempDir dir;
  writeFile(dir.path() / "secret.png", png2x2());
  const std::string up = writeQuad(dir.path() / "asset", "up.gltf", texturedQuad("../secret.png"));
  EXPECT_TRUE(test::errorNames(loadGltf(up), up, "climbs out of the asset's folder"));
  EXPECT_TRUE(test::errorNames(loadGltf(up), up, "--allow-outside-files"));
  SceneLoadOptions allow;
  allow.files.allow_outside = true;
  EXPECT_TRUE(loadGltf(up, allow).ok());
  // Percent-encoded dots climb the same way.
  const std::string encoded =
      writeQuad(dir.path() / "asset", "enc.gltf", texturedQuad("%2e%2e/secret.png"));
  EXPECT_TRUE(test::errorNames(loadGltf(encoded), encoded, "climbs out of the asset's folder"));
  const std::string absolute = writeQuad(dir.path() / "asset", "abs.gltf",
                                         texturedQuad((dir.path() / "secret.png").string()));
  EXPECT_TRUE(test::errorNames(loadGltf(absolute), absolute, "outside the asset's folder"));
  // An absolute path inside the folder, or an asset named by its absolute path, is fine.
  const std::string inside = writeQuad(dir.path() / "asset", "inside.gltf",
                                       texturedQuad((dir.path() / "asset" / "tex.png").string()));
  writeFile(dir.path() / "asset" / "tex.png", png2x2());
  EXPECT_TRUE(loadGltf(inside).ok());
  const std::string by_absolute =
      writeQuad(fs::absolute(dir.path()) / "asset", "abs-asset.gltf", texturedQuad("tex.png"));
  EXPECT_TRUE(loadGltf(by_absolute).ok());
  // A link inside the folder that points out of it.
  std::filesystem::create_symlink(dir.path() / "secret.png", dir.path() / "asset" / "link.png");
  const std::string link = writeQuad(dir.path() / "asset", "link.gltf", texturedQuad("link.png"));
  EXPECT_TRUE(test::errorNames(loadGltf(link), link, "is a link"));
  // URLs fetch nothing.
  const std::string url =
      writeQuad(dir.path() / "asset", "url.gltf", texturedQuad("http://example.com/a.png"));
  EXPECT_TRUE(test::errorNames(loadGltf(url), url, "not fetched"));
}

TEST(GltfFiles, TheCurrentDirectoryIsNeverSearched) {
  TempDir dir;
  writeFile(dir.path() / "cwd" / "only-here.png", png2x2());
  const std::string path = writeQuad(dir.path() / "asset", "q.gltf", texturedQuad("only-here.png"));
  const std::filesystem::path before = std::filesystem::current_path();
  std::filesystem::current_path(dir.path() / "cwd");
  const Expected<Scene> s = loadGltf(path);
  std::filesystem::current_path(before);
  EXPECT_TRUE(test::errorNames(s, path, "no such file"));
  EXPECT_TRUE(test::errorNames(s, path, "'painted'"));
}

// A scene named by a relative path that climbs ('../asset/q.gltf', from a sibling folder) reads
// the files beside it: they are inside its folder, whatever the path's spelling.
TEST(GltfFiles, AnAssetNamedThroughDotDotReadsItsOwnFiles) {
  TempDir dir;
  writeFile(dir.path() / "asset" / "tex.png", png2x2());
  writeQuad(dir.path() / "asset", "q.gltf", texturedQuad("tex.png"));
  std::filesystem::create_directories(dir.path() / "work");
  const std::filesystem::path before = std::filesystem::current_path();
  std::filesystem::current_path(dir.path() / "work");
  const Expected<Scene> s = loadGltf("../asset/q.gltf");
  const Expected<Scene> up = loadGltf("../asset/../asset/q.gltf");
  std::filesystem::current_path(before);
  ASSERT_TRUE(s.ok()) << s.error().describe();
  ASSERT_TRUE(s->materials[0].reflectance_texture.has_value());
  EXPECT_EQ(s->materials[0].reflectance_texture->texture->width(), 2);
  EXPECT_TRUE(up.ok()) << up.error().describe();
}

TEST(GltfFiles, ImagesNoTextureReadsAreNotRead) {
  TempDir dir;
  Quad q = texturedQuad("tex.png");
  writeFile(dir.path() / "asset" / "tex.png", png2x2());
  // A host file, a FIFO, a missing file and a terabyte (sparse) named by images nothing uses.
  mkfifo((dir.path() / "asset" / "fifo.png").c_str(), 0600);
  { std::ofstream(dir.path() / "asset" / "huge.png"); }
  std::filesystem::resize_file(dir.path() / "asset" / "huge.png", uint64_t(1) << 40);
  for (const char* uri : {"../../../../etc/passwd", "/etc/passwd", "fif%6F.png", "missing.png"}) {
    q.doc["images"].push_back({{"uri", uri}});
  }
  for (int i = 0; i < 100; ++i) q.doc["images"].push_back({{"uri", "huge.png"}});
  const std::string path = writeQuad(dir.path() / "asset", "q.gltf", q);
  Expected<Scene> s = loadGltf(path);
  ASSERT_TRUE(s.ok()) << s.error().describe();
  // The same FIFO used by a texture is refused without blocking.
  Quad used = texturedQuad("fif%6F.png");
  const std::string fifo = writeQuad(dir.path() / "asset", "fifo.gltf", used);
  EXPECT_TRUE(test::errorNames(loadGltf(fifo), fifo, "not a regular file"));
  // And the terabyte used by a texture is refused before it is read.
  const std::string huge = writeQuad(dir.path() / "asset", "huge.gltf", texturedQuad("huge.png"));
  EXPECT_FALSE(loadGltf(huge).ok());
}

TEST(GltfFiles, BufferViewsAreCheckedBeforeAnyPointerIsTaken) {
  TempDir dir;
  for (const uint64_t length : {uint64_t(100), uint64_t(1) << 40}) {
    Quad q = texturedQuad("unused.png");
    q.doc["images"][0] = {{"bufferView", 3}, {"mimeType", "image/png"}};
    q.doc["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", 80}, {"byteLength", length}});
    const std::string gltf = writeQuad(dir.path(), "overrun.gltf", q);
    EXPECT_TRUE(test::errorNames(loadGltf(gltf), gltf, "outside buffer 0"));
    q.doc["buffers"][0].erase("uri");
    const std::string glb = dir.write("overrun.glb", test::glbBytes(q.doc, q.bin));
    EXPECT_TRUE(test::errorNames(loadGltf(glb), glb, "outside buffer 0"));
  }
}

TEST(GltfFiles, ValuesTakenOnTrustAreRefused) {
  TempDir dir;
  {
    Quad q = texturedQuad("tex.png");
    q.doc["samplers"] = {{{"wrapS", "REPEAT"}}};
    q.doc["textures"][0]["sampler"] = 0;
    const std::string p = writeQuad(dir.path(), "wrap.gltf", q);
    EXPECT_TRUE(test::errorNames(loadGltf(p), p, "samplers[0].wrapS"));
  }
  {
    Quad q = texturedQuad("tex.png");
    q.doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["texCoord"] = 4294967297ull;
    const std::string p = writeQuad(dir.path(), "set.gltf", q);
    EXPECT_TRUE(test::errorNames(loadGltf(p), p, "texCoord"));
  }
}

TEST(GltfFiles, ImagesInDataUrisOfEveryTypeDecode) {
  TempDir dir;
  const uint8_t red[4] = {255, 0, 0, 255}, white[4] = {255, 255, 255, 255};
  const test::Rgba8Image image = test::chequer(4, 4, 2, red, white);
  const std::pair<const char*, std::string> kinds[] = {{"image/png", test::pngBytes(image)},
                                                       {"image/jpeg", test::jpegBytes(image)},
                                                       {"image/webp", test::webpBytes(image)}};
  for (const auto& [mime, bytes] : kinds) {
    SCOPED_TRACE(mime);
    const std::string uri = std::string("data:") + mime + ";base64," + test::base64(bytes);
    Quad q = texturedQuad(uri);
    q.doc["extensionsUsed"] = {"EXT_texture_webp"};
    const std::string p = writeQuad(dir.path(), "data.gltf", q);
    Expected<Scene> s = loadGltf(p);
    ASSERT_TRUE(s.ok()) << s.error().describe();
    EXPECT_EQ(s->materials[0].reflectance_texture->texture->width(), 4);
  }
}

}  // namespace
}  // namespace penumbra
