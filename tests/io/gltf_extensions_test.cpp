// glTF as exporters write it, beyond the core: meshopt streams of both versions and every filter,
// Draco streams, KHR_mesh_quantization, sparse accessors, morph targets with default weights,
// skins posed by their joints, several scenes; and the malformed streams (cut short, lying about
// their counts, a quantized accessor with a bad normalized flag) refused with one line.
#include "penumbra/core/file_util.h"
#include "penumbra/io/gltf/gltf_meshopt.h"
#include "penumbra/io/scene_io.h"
#include "support/test_util.h"

#include <draco/compression/encode.h>
#include <draco/mesh/triangle_soup_mesh_builder.h>
#include <gtest/gtest.h>
#include <meshoptimizer.h>
#include <nlohmann/json.hpp>

#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace penumbra {
namespace {

using nlohmann::json;
using test::TempDir;

// The whole file (empty when it cannot be read: the caller's check fails then).
std::string readBytes(const std::string& path) {
  Expected<std::string> bytes = readFile(path);
  return bytes ? std::move(*bytes) : std::string();
}

uint32_t le32(const std::string& b, size_t at) {
  uint32_t v;
  std::memcpy(&v, b.data() + at, 4);
  return v;
}

// Streams meshoptimizer's own encoder wrote in the version-1 format (tests/data/meshopt), decoded
// here as its own decoder does: exactly, and the COLOR filter within one unit in the last place
// (the extension's Appendix B).
TEST(Meshopt, VersionOneStreamsDecodeAsTheReferenceDecoderDoes) {
  const std::pair<const char*, MeshoptView::Filter> cases[] = {
      {"v1_floats", MeshoptView::Filter::kNone},
      {"v1_shorts", MeshoptView::Filter::kNone},
      {"v1_bytes", MeshoptView::Filter::kNone},
      {"v1_color4", MeshoptView::Filter::kColor},
      {"v1_color8", MeshoptView::Filter::kColor}};
  for (const auto& [name, filter] : cases) {
    SCOPED_TRACE(name);
    const std::string b = readBytes(test::dataPath(std::string("meshopt/") + name + ".bin"));
    ASSERT_GE(b.size(), 16u);
    MeshoptView v;
    v.count = le32(b, 0);
    v.byte_stride = le32(b, 4);
    v.mode = MeshoptView::Mode::kAttributes;
    v.filter = filter;
    const std::string_view encoded(b.data() + 16, le32(b, 8));
    const std::string reference = b.substr(16 + le32(b, 8), le32(b, 12));
    ASSERT_EQ(uint8_t(encoded[0]), 0xa1);
    Expected<std::string> decoded = decodeMeshoptView(v, encoded, "f", "p");
    ASSERT_TRUE(decoded.ok()) << decoded.error().describe();
    ASSERT_EQ(decoded->size(), reference.size());
    if (filter == MeshoptView::Filter::kNone) {
      EXPECT_EQ(*decoded, reference);
      continue;
    }
    const size_t component = v.byte_stride / 4;
    for (size_t i = 0; i < reference.size(); i += component) {
      int64_t a = 0, r = 0;
      std::memcpy(&a, decoded->data() + i, component);
      std::memcpy(&r, reference.data() + i, component);
      ASSERT_LE(std::abs(a - r), 1) << "byte " << i;
    }
    // Cut short by one byte, the stream is refused, not read past its end.
    MeshoptView cut = v;
    EXPECT_FALSE(decodeMeshoptView(cut, encoded.substr(0, encoded.size() - 1), "f", "p").ok());
  }
}

// The library's own encoders (version 0) through the same path: round trips, and malformed
// streams refused.
TEST(Meshopt, VersionZeroAndIndexStreamsRoundTripAndLiesAreRefused) {
  std::vector<float> vertices;
  for (int i = 0; i < 300; ++i) vertices.insert(vertices.end(), {float(i), float(i % 7), 0.5f});
  std::vector<unsigned char> encoded(meshopt_encodeVertexBufferBound(300, 12));
  encoded.resize(
      meshopt_encodeVertexBuffer(encoded.data(), encoded.size(), vertices.data(), 300, 12));
  MeshoptView v;
  v.count = 300;
  v.byte_stride = 12;
  const std::string_view bytes(reinterpret_cast<const char*>(encoded.data()), encoded.size());
  Expected<std::string> decoded = decodeMeshoptView(v, bytes, "f", "p");
  ASSERT_TRUE(decoded.ok()) << decoded.error().describe();
  EXPECT_EQ(std::memcmp(decoded->data(), vertices.data(), vertices.size() * 4), 0);
  EXPECT_FALSE(decodeMeshoptView(v, bytes.substr(0, bytes.size() / 2), "f", "p").ok());
  MeshoptView more = v;
  more.count = 400;  // more elements than the stream holds
  EXPECT_FALSE(decodeMeshoptView(more, bytes, "f", "p").ok());

  std::vector<unsigned> indices;
  for (unsigned i = 0; i + 2 < 300; ++i) indices.insert(indices.end(), {i, i + 1, i + 2});
  std::vector<unsigned char> ib(meshopt_encodeIndexBufferBound(indices.size(), 300));
  ib.resize(meshopt_encodeIndexBuffer(ib.data(), ib.size(), indices.data(), indices.size()));
  MeshoptView t;
  t.mode = MeshoptView::Mode::kTriangles;
  t.count = indices.size();
  t.byte_stride = 4;
  Expected<std::string> tris = decodeMeshoptView(
      t, std::string_view(reinterpret_cast<const char*>(ib.data()), ib.size()), "f", "p");
  ASSERT_TRUE(tris.ok()) << tris.error().describe();
  // The codec keeps the triangles and their order and winding, not which corner comes first.
  for (size_t t = 0; t < indices.size(); t += 3) {
    uint32_t got[3];
    std::memcpy(got, tris->data() + 4 * t, 12);
    bool same = false;
    for (int r = 0; r < 3; ++r) {
      same = same || (got[r] == indices[t] && got[(r + 1) % 3] == indices[t + 1] &&
                      got[(r + 2) % 3] == indices[t + 2]);
    }
    ASSERT_TRUE(same) << "triangle " << t / 3;
  }
  EXPECT_FALSE(
      decodeMeshoptView(
          t, std::string_view(reinterpret_cast<const char*>(ib.data()), ib.size() / 2), "f", "p")
          .ok());
  // The extension's own layout rules.
  const json bad = {
      {"buffer", 0}, {"byteLength", 10}, {"byteStride", 6}, {"count", 5}, {"mode", "ATTRIBUTES"}};
  EXPECT_FALSE(readMeshoptView(bad, false, 30, "f", "p").ok());
  const json color = {{"buffer", 0}, {"byteLength", 10},     {"byteStride", 4},
                      {"count", 5},  {"mode", "ATTRIBUTES"}, {"filter", "COLOR"}};
  EXPECT_TRUE(readMeshoptView(color, true, 20, "f", "p").ok());
  EXPECT_FALSE(readMeshoptView(color, false, 20, "f", "p").ok());  // EXT has no COLOR filter
}

// A quad in a file of its own: `positions` accessor as given, with `extra` merged into the
// document.
std::string quadFile(const TempDir& dir, const std::string& name, const json& position_accessor,
                     const std::string& position_bytes, const json& extra = json::object()) {
  std::string bin = position_bytes;
  while (bin.size() % 4) bin.push_back('\0');
  const size_t index_offset = bin.size();
  for (uint16_t i : {0, 1, 2, 0, 2, 3}) bin.append(reinterpret_cast<const char*>(&i), 2);
  json doc = {{"asset", {{"version", "2.0"}}},
              {"scenes", {{{"nodes", {0}}}}},
              {"nodes", {{{"mesh", 0}}}},
              {"meshes", {{{"primitives", {{{"attributes", {{"POSITION", 0}}}, {"indices", 1}}}}}}},
              {"buffers",
               {{{"byteLength", bin.size()},
                 {"uri", "data:application/octet-stream;base64," + test::base64(bin)}}}},
              {"bufferViews",
               {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", position_bytes.size()}},
                {{"buffer", 0}, {"byteOffset", index_offset}, {"byteLength", 12}}}},
              {"accessors",
               {position_accessor,
                {{"bufferView", 1}, {"componentType", 5123}, {"count", 6}, {"type", "SCALAR"}}}}};
  doc.merge_patch(extra);
  return dir.write(name, doc.dump());
}

TEST(GltfQuantization, IntegerPositionsAreScaledByTheirNodeAndBadFlagsRefused) {
  TempDir dir;
  std::string bytes;
  for (int16_t v : {0, 0, 0, 0, 32767, 0, 0, 0, 32767, 32767, 0, 0, 0, 32767, 0, 0}) {
    bytes.append(reinterpret_cast<const char*>(&v), 2);
  }
  const json normalized = {{"bufferView", 0}, {"componentType", 5122}, {"normalized", true},
                           {"count", 4},      {"type", "VEC3"},        {"byteStride", 8}};
  json a = normalized;
  a.erase("byteStride");
  const json quantized = {{"extensionsUsed", {"KHR_mesh_quantization"}},
                          {"extensionsRequired", {"KHR_mesh_quantization"}},
                          {"bufferViews",
                           {{{"buffer", 0}, {"byteLength", 32}, {"byteStride", 8}},
                            {{"buffer", 0}, {"byteOffset", 32}, {"byteLength", 12}}}},
                          {"nodes", {{{"mesh", 0}, {"scale", {2.0, 2.0, 2.0}}}}}};
  const std::string p = quadFile(dir, "q.gltf", a, bytes, quantized);
  Expected<Scene> s = loadGltf(p);
  ASSERT_TRUE(s.ok()) << s.error().describe();
  EXPECT_NEAR(s->meshes[0].positions[2].x, 2.0f, 1e-6f);  // 32767 / 32767 x the node's 2
  EXPECT_NEAR(s->meshes[0].positions[2].y, 2.0f, 1e-6f);
  // Without the extension the same storage is refused by name; so is a NORMAL that is not
  // normalized.
  const std::string plain =
      quadFile(dir, "plain.gltf", a, bytes, {{"bufferViews", quantized["bufferViews"]}});
  EXPECT_TRUE(test::errorNames(loadGltf(plain), plain, "needs KHR_mesh_quantization"));
  json doc = json::parse(readBytes(p));
  doc["accessors"].push_back(a);
  doc["accessors"].back()["normalized"] = false;
  doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = 2;
  const std::string normal = dir.write("normal.gltf", doc.dump());
  EXPECT_TRUE(test::errorNames(loadGltf(normal), normal, "SHORT is not a storage NORMAL takes"));
}

TEST(GltfSparse, SparseValuesReplaceTheBaseAndBadIndicesAreRefused) {
  TempDir dir;
  std::string bytes;
  for (float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 1.f, 1.f, 0.f, 0.f, 1.f, 0.f}) {
    bytes.append(reinterpret_cast<const char*>(&v), 4);
  }
  // Sparse values: vertex 2 raised to z = 5, stored after the indices (offset 60).
  std::string sparse;
  const uint16_t index = 2;
  sparse.append(reinterpret_cast<const char*>(&index), 2);
  sparse.append(2, '\0');
  for (float v : {1.f, 1.f, 5.f}) sparse.append(reinterpret_cast<const char*>(&v), 4);
  const json accessor = {{"bufferView", 0},
                         {"componentType", 5126},
                         {"count", 4},
                         {"type", "VEC3"},
                         {"sparse",
                          {{"count", 1},
                           {"indices", {{"bufferView", 2}, {"componentType", 5123}}},
                           {"values", {{"bufferView", 2}, {"byteOffset", 4}}}}}};
  json extra = {{"bufferViews",
                 {{{"buffer", 0}, {"byteLength", 48}},
                  {{"buffer", 0}, {"byteOffset", 48}, {"byteLength", 12}},
                  {{"buffer", 0}, {"byteOffset", 60}, {"byteLength", 16}}}}};
  // quadFile puts the indices right after the positions, the sparse block follows them.
  const std::string p = [&] {
    json doc = json::parse(readBytes(quadFile(dir, "tmp.gltf", accessor, bytes)));
    std::string b = bytes;
    for (uint16_t i : {0, 1, 2, 0, 2, 3}) b.append(reinterpret_cast<const char*>(&i), 2);
    b += sparse;
    doc["buffers"][0] = {{"byteLength", b.size()},
                         {"uri", "data:application/octet-stream;base64," + test::base64(b)}};
    doc.merge_patch(extra);
    return dir.write("sparse.gltf", doc.dump());
  }();
  Expected<Scene> s = loadGltf(p);
  ASSERT_TRUE(s.ok()) << s.error().describe();
  EXPECT_FLOAT_EQ(s->meshes[0].positions[2].z, 5.0f);
  EXPECT_FLOAT_EQ(s->meshes[0].positions[1].z, 0.0f);
  // An index past the accessor's count.
  json doc = json::parse(readBytes(p));
  doc["accessors"][0]["count"] = 2;
  doc["accessors"][0]["sparse"]["count"] = 1;
  const std::string bad = dir.write("bad.gltf", doc.dump());
  EXPECT_FALSE(loadGltf(bad).ok());
}

// A Draco stream of a quad, encoded here with the library.
std::string dracoQuad(bool cut) {
  draco::TriangleSoupMeshBuilder builder;
  builder.Start(2);
  const int pos = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
  const float p[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  builder.SetAttributeValuesForFace(pos, draco::FaceIndex(0), p[0], p[1], p[2]);
  builder.SetAttributeValuesForFace(pos, draco::FaceIndex(1), p[0], p[2], p[3]);
  std::unique_ptr<draco::Mesh> mesh = builder.Finalize();
  draco::Encoder encoder;
  encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION, 14);
  draco::EncoderBuffer out;
  EXPECT_TRUE(encoder.EncodeMeshToBuffer(*mesh, &out).ok());
  std::string s(out.data(), out.size());
  if (cut) s.resize(s.size() / 2);
  return s;
}

TEST(GltfDraco, AStreamDecodesAndOneCutShortOrLyingIsRefused) {
  TempDir dir;
  for (const bool cut : {false, true}) {
    const std::string stream = dracoQuad(cut);
    std::string bin = stream;
    json doc = {{"asset", {{"version", "2.0"}}},
                {"extensionsUsed", {"KHR_draco_mesh_compression"}},
                {"extensionsRequired", {"KHR_draco_mesh_compression"}},
                {"scenes", {{{"nodes", {0}}}}},
                {"nodes", {{{"mesh", 0}}}},
                {"meshes",
                 {{{"primitives",
                    {{{"attributes", {{"POSITION", 0}}},
                      {"indices", 1},
                      {"extensions",
                       {{"KHR_draco_mesh_compression",
                         {{"bufferView", 0}, {"attributes", {{"POSITION", 0}}}}}}}}}}}}},
                {"buffers",
                 {{{"byteLength", bin.size()},
                   {"uri", "data:application/octet-stream;base64," + test::base64(bin)}}}},
                {"bufferViews", {{{"buffer", 0}, {"byteLength", bin.size()}}}},
                {"accessors",
                 {{{"componentType", 5126}, {"count", 4}, {"type", "VEC3"}},
                  {{"componentType", 5123}, {"count", 6}, {"type", "SCALAR"}}}}};
    const std::string p = dir.write(cut ? "cut.gltf" : "draco.gltf", doc.dump());
    Expected<Scene> s = loadGltf(p);
    if (cut) {
      EXPECT_TRUE(test::errorNames(s, p, "KHR_draco_mesh_compression"));
      continue;
    }
    ASSERT_TRUE(s.ok()) << s.error().describe();
    ASSERT_EQ(s->meshes[0].triangles.size(), 2u);
    // A stream that decodes 4 points whose accessor claims 5.
    doc["accessors"][0]["count"] = 5;
    const std::string lie = dir.write("lie.gltf", doc.dump());
    EXPECT_TRUE(test::errorNames(loadGltf(lie), lie, "decodes 4 points, its accessor claims 5"));
  }
}

TEST(GltfCorpusFeatures, MorphWeightsSkinsAndScenesAreApplied) {
  const std::string corpus = std::string(PENUMBRA_TEST_DATA) + "/gltf-corpus/features/";
  // SimpleMorph: the base triangle plus 0.5 x each target's displacement.
  Expected<Scene> morph = loadGltf(corpus + "SimpleMorph/SimpleMorph.gltf");
  ASSERT_TRUE(morph.ok()) << morph.error().describe();
  const json doc = json::parse(readBytes(corpus + "SimpleMorph/SimpleMorph.gltf"));
  EXPECT_EQ(doc["meshes"][0]["weights"], json({0.5, 0.5}));
  float top = -1e9f;
  for (const glm::vec3& p : morph->meshes[0].positions) top = std::max(top, p.y);
  EXPECT_GT(top, 0.5f + 1e-3f);  // the base triangle's apex is at 0.5; the targets raise it
  // MultipleScenes: the default scene (1) holds the quad, 2 triangles; scene 0 the triangle.
  Expected<Scene> scenes = loadGltf(corpus + "MultipleScenes/MultipleScenes.gltf");
  ASSERT_TRUE(scenes.ok());
  EXPECT_EQ(scenes->triangleCount(), 2u);
  SceneLoadOptions first;
  first.gltf_scene = 0;
  Expected<Scene> zero = loadGltf(corpus + "MultipleScenes/MultipleScenes.gltf", first);
  ASSERT_TRUE(zero.ok());
  EXPECT_EQ(zero->triangleCount(), 1u);
  // RiggedSimple: posed by its joints, the cylinder stands where its joints put it (no NaN, the
  // same size as the bind pose within its bones' bend).
  Expected<Scene> rig = loadGltf(corpus + "RiggedSimple/RiggedSimple.gltf");
  ASSERT_TRUE(rig.ok()) << rig.error().describe();
  glm::vec3 lo(1e9f), hi(-1e9f);
  for (const glm::vec3& p : rig->meshes[0].positions) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  EXPECT_GT(hi.z - lo.z + hi.y - lo.y + hi.x - lo.x, 1.0f);
}

}  // namespace
}  // namespace penumbra
