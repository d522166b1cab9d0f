// PLY loading: the Stanford bunny and the teapot (real data) keep the file's vertex and face
// order; polygons are fan-triangulated; truncated files, NaN coordinates and out-of-range indices
// are errors that name the file and the vertex or face.
#include "penumbra/io/scene_io.h"
#include "support/test_util.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

namespace penumbra {
namespace {

using test::dataPath;
using test::TempDir;

std::string readAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

using test::errorNames;

// The bunny's layout, read independently of the loader: a binary little-endian header with
// "element vertex N" of float x y z and "element face M" of "list uchar int vertex_indices".
struct BunnyFile {
  size_t vertices = 0, faces = 0;
  float first_vertex[3] = {};
  int32_t first_face[3] = {};
};

BunnyFile readBunnyByHand(const std::string& bytes) {
  BunnyFile b;
  const std::string end = "end_header\n";
  const size_t body = bytes.find(end) + end.size();
  std::istringstream header(bytes.substr(0, body));
  std::string line;
  size_t vertex_properties = 0;
  bool in_vertex = false;
  while (std::getline(header, line)) {
    std::istringstream w(line);
    std::string key, a, b2;
    w >> key >> a >> b2;
    if (key == "element") {
      in_vertex = a == "vertex";
      (in_vertex ? b.vertices : b.faces) = std::stoul(b2);
    } else if (key == "property" && in_vertex) {
      EXPECT_EQ(a, "float");
      ++vertex_properties;
    } else if (key == "property") {
      EXPECT_EQ(line, "property list uchar int vertex_indices");
    }
  }
  EXPECT_EQ(vertex_properties, 3u);
  std::memcpy(b.first_vertex, bytes.data() + body, 12);
  const size_t face0 = body + b.vertices * 12;
  EXPECT_EQ(static_cast<unsigned char>(bytes[face0]), 3u);
  std::memcpy(b.first_face, bytes.data() + face0 + 1, 12);
  return b;
}

TEST(PlyLoad, BunnyKeepsFileOrder) {
  const std::string path = dataPath("bunny.ply");
  const BunnyFile file = readBunnyByHand(readAll(path));
  ASSERT_EQ(file.vertices, 35947u);
  ASSERT_EQ(file.faces, 69451u);

  Expected<Scene> s = loadPly(path);
  ASSERT_TRUE(s.ok()) << s.error().describe();
  EXPECT_EQ(s->triangleCount(), 69451u);
  EXPECT_EQ(s->vertexCount(), 35947u);
  ASSERT_EQ(s->meshes.size(), 1u);
  const Mesh& m = s->meshes[0];
  EXPECT_EQ(m.name, "bunny");
  EXPECT_EQ(m.triangles[0], glm::uvec3(file.first_face[0], file.first_face[1], file.first_face[2]));
  EXPECT_EQ(m.positions[0],
            glm::vec3(file.first_vertex[0], file.first_vertex[1], file.first_vertex[2]));
  ASSERT_EQ(s->materials.size(), 1u);
  EXPECT_EQ(s->materials[0].name, "default");
}

TEST(PlyLoad, Teapot) {
  Expected<Scene> s = loadPly(dataPath("teapot.ply"));
  ASSERT_TRUE(s.ok()) << s.error().describe();
  EXPECT_EQ(s->triangleCount(), 2256u);
  EXPECT_EQ(s->vertexCount(), 1177u);
}

std::string asciiPly(const std::string& vertices, const std::string& faces, int nv, int nf) {
  return "ply\nformat ascii 1.0\ncomment test\nelement vertex " + std::to_string(nv) +
         "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
         std::to_string(nf) + "\nproperty list uchar int vertex_indices\nend_header\n" + vertices +
         faces;
}

const char* const kFiveVertices = "0 0 0\n1 0 0\n2 1 0\n1 2 0\n0 1 0\n";

TEST(PlyLoad, AsciiPolygonsAreFanTriangulated) {
  TempDir dir;
  const std::string path =
      dir.write("poly.ply", asciiPly(kFiveVertices, "5 0 1 2 3 4\n2 0 1\n3 4 3 2\n1 0\n", 5, 4));
  Expected<Scene> s = loadPly(path);
  ASSERT_TRUE(s.ok()) << s.error().describe();
  const Mesh& m = s->meshes[0];
  ASSERT_EQ(m.triangles.size(), 4u);
  EXPECT_EQ(m.triangles[0], glm::uvec3(0, 1, 2));
  EXPECT_EQ(m.triangles[1], glm::uvec3(0, 2, 3));
  EXPECT_EQ(m.triangles[2], glm::uvec3(0, 3, 4));
  EXPECT_EQ(m.triangles[3], glm::uvec3(4, 3, 2));
  EXPECT_EQ(m.positions[2], glm::vec3(2, 1, 0));
  ASSERT_EQ(s->warnings.size(), 1u);  // the line and the point are skipped
  EXPECT_NE(s->warnings[0].find("2 point or line"), std::string::npos) << s->warnings[0];
}

// Big-endian binary with mixed types: double positions, float normals between them, uchar colours,
// s/t texture coordinates, an unrelated element between vertices and faces, and a face element
// with a property after its index list. Written byte by byte here, read back value by value.
class BigEndianWriter {
 public:
  template <typename T>
  void put(T v) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    for (size_t i = sizeof(T); i-- > 0;) bytes_.push_back(static_cast<char>(b[i]));
  }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
};

TEST(PlyLoad, BinaryBigEndianReadsNormalsUvsAndSkipsOtherProperties) {
  const std::string header =
      "ply\nformat binary_big_endian 1.0\nelement vertex 4\nproperty double x\n"
      "property float nx\nproperty float ny\nproperty float nz\nproperty double y\n"
      "property uchar red\nproperty double z\nproperty float s\nproperty float t\n"
      "element material 2\nproperty list uchar float weights\nproperty int id\n"
      "element face 2\nproperty list uint ushort vertex_indices\nproperty int flags\n"
      "end_header\n";
  BigEndianWriter w;
  const double xyz[4][3] = {{0, 0, 0}, {1.5, 0, 0}, {1.5, 2.25, 0}, {0, 2.25, -1}};
  for (int v = 0; v < 4; ++v) {
    w.put(xyz[v][0]);
    w.put(0.0f), w.put(0.0f), w.put(1.0f);
    w.put(xyz[v][1]);
    w.put(static_cast<uint8_t>(200));
    w.put(xyz[v][2]);
    w.put(0.25f * v), w.put(1.0f - 0.25f * v);
  }
  for (int m = 0; m < 2; ++m) {
    w.put(static_cast<uint8_t>(m + 1));
    for (int k = 0; k <= m; ++k) w.put(0.5f);
    w.put(int32_t{7});
  }
  w.put(uint32_t{4});
  for (uint16_t i : {3, 0, 1, 2}) w.put(i);
  w.put(int32_t{-1});
  w.put(uint32_t{3});
  for (uint16_t i : {2, 1, 0}) w.put(i);
  w.put(int32_t{0});

  TempDir dir;
  Expected<Scene> s = loadPly(dir.write("mixed.ply", header + w.bytes()));
  ASSERT_TRUE(s.ok()) << s.error().describe();
  ASSERT_EQ(s->meshes.size(), 1u);
  const Mesh& m = s->meshes[0];
  ASSERT_EQ(m.positions.size(), 4u);
  for (int v = 0; v < 4; ++v) {
    EXPECT_EQ(m.positions[v], glm::vec3(xyz[v][0], xyz[v][1], xyz[v][2])) << v;
  }
  ASSERT_EQ(m.normals.size(), 4u);
  EXPECT_EQ(m.normals[3], glm::vec3(0, 0, 1));
  ASSERT_EQ(m.uvs.size(), 4u);
  EXPECT_EQ(m.uvs[3], glm::vec2(0.75f, 0.25f));
  ASSERT_EQ(m.triangles.size(), 3u);
  EXPECT_EQ(m.triangles[0], glm::uvec3(3, 0, 1));
  EXPECT_EQ(m.triangles[1], glm::uvec3(3, 1, 2));
  EXPECT_EQ(m.triangles[2], glm::uvec3(2, 1, 0));
  // Cut the last face short: the walk names it.
  Expected<Scene> cut =
      loadPly(dir.write("cut.ply", header + w.bytes().substr(0, w.bytes().size() - 6)));
  EXPECT_TRUE(errorNames(cut, "cut.ply", "face 1: the file ends early"));
}

TEST(PlyLoad, ErrorsNameFileAndPlace) {
  TempDir dir;
  struct Case {
    const char* name;
    std::string text;
    const char* place;
  };
  const Case cases[] = {
      // Header lines 1-10, so vertex i is on line 11 + i and face j on line 16 + j.
      {"nan.ply", asciiPly("0 0 0\n1 0 0\nnan 1 0\n1 2 0\n0 1 0\n", "3 0 1 2\n", 5, 1),
       "line 13, vertex 2"},
      {"inf.ply", asciiPly("0 0 0\n1 0 0\n2 1 0\n1 2 1e300\n0 1 0\n", "3 0 1 2\n", 5, 1),
       "vertex 3"},
      {"range.ply", asciiPly(kFiveVertices, "3 0 1 2\n3 0 2 5\n", 5, 2), "line 17, face 1"},
      {"negative.ply", asciiPly(kFiveVertices, "3 0 1 2\n3 -1 2 3\n", 5, 2), "face 1"},
      {"truncated.ply", asciiPly(kFiveVertices, "3 0 1 2\n", 5, 2), "face 1"},
      {"shortvertex.ply", asciiPly("0 0 0\n1 0\n", "", 5, 0), "ends early"},
      {"word.ply", asciiPly(kFiveVertices, "3 0 one 2\n", 5, 1), "line 16, face 0"},
      {"noply.ply", "solid cube\nfacet normal 0 0 1\n", "line 1"},
      {"noend.ply", "ply\nformat ascii 1.0\nelement vertex 3\n", "end_header"},
      {"badheader.ply", "ply\nformat ascii 1.0\nelemant vertex 3\nend_header\n", "line 3"},
      {"empty.ply", "", "line 1"},
      // Counts no file of this size can hold, refused before any loop over them.
      {"huge.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 18446744073709551615\n"
       "property float x\nproperty float y\nproperty float z\nend_header\n0000",
       "18446744073709551615 entries"},
      {"huge31.ply",
       "ply\nformat ascii 1.0\nelement vertex 2147483648\nproperty float x\n"
       "property float y\nproperty float z\nelement face 1\nproperty list uchar int "
       "vertex_indices\nend_header\n0 0 0\n",
       "2147483648 entries"},
      {"noproperties.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
       "property float y\nproperty float z\nelement junk 18446744073709551615\nend_header\n",
       "no properties"},
      {"noz.ply",
       "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
       "end_header\n0 0\n",
       "one scalar property 'z'"},
      // Found by fuzzing: a list length no count type holds (an ASCII file can write it).
      {"biglist.ply", asciiPly(kFiveVertices, "3 0 1 2\n5.5e75 0 1 2\n", 5, 2),
       "line 17, face 1: list length 5.5e+75"},
      {"typedlist.ply", asciiPly(kFiveVertices, "256 0 1 2\n", 5, 1), "list length 256"},
      // Found by fuzzing: two formats, and NUL bytes in a header line.
      {"twoformats.ply",
       "ply\nformat ascii 1.0\nformat binary_little_endian 1.0\nelement vertex 1\n"
       "property float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n",
       "line 3: a second 'format' line"},
      {"twovertex.ply",
       "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
       "property float z\nelement vertex 1\nproperty float x\nend_header\n0 0 0\n0\n",
       "line 7: a second element 'vertex'"},
      {"noindices.ply",
       "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
       "property float z\nelement face 1\nproperty list uchar int vertex_indice\nend_header\n"
       "0 0 0\n1 0\n",
       "no 'vertex_indices' list"},
      {"nul.ply",
       std::string("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty "
                   "float y\0\0z\nend_header\n0 0 0\n",
                   92),
       "line 5: the header holds a byte that is not text"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string path = dir.write(c.name, c.text);
    EXPECT_TRUE(errorNames(loadPly(path), path, c.place));
  }
  // A binary file cut short, in the faces.
  const std::string bunny = readAll(dataPath("bunny.ply"));
  const std::string cut = dir.write("cut.ply", bunny.substr(0, 600000));
  EXPECT_TRUE(errorNames(loadPly(cut), cut, "face "));
  // ... and in the vertices.
  const std::string cut2 = dir.write("cut2.ply", bunny.substr(0, 100000));
  EXPECT_TRUE(errorNames(loadPly(cut2), cut2, "vertex "));
  // An out-of-range index in the binary bunny: the last face's last index set to 35947.
  std::string bad = bunny;
  const int32_t too_big = 35947;
  std::memcpy(bad.data() + bad.size() - 4, &too_big, 4);
  const std::string badpath = dir.write("badindex.ply", bad);
  EXPECT_TRUE(errorNames(loadPly(badpath), badpath, "face 69450"));
  // A NaN coordinate in the binary bunny: vertex 7's y.
  std::string nan = bunny;
  const float qnan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(nan.data() + bunny.find("end_header\n") + 11 + 7 * 12 + 4, &qnan, 4);
  const std::string nanpath = dir.write("nan-binary.ply", nan);
  EXPECT_TRUE(errorNames(loadPly(nanpath), nanpath, "vertex 7"));

  const std::string missing = dir.file("missing.ply");
  EXPECT_TRUE(errorNames(loadPly(missing), missing, "no such file"));
}

}  // namespace
}  // namespace penumbra
