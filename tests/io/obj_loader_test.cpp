// OBJ loading: the Cornell box parts (real data), fan triangulation in file order, MTL
// materials, per-corner normals, and errors that name the file and the line.
#include "penumbra/io/scene_io.h"
#include "support/test_util.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <cmath>

#include <string>

namespace penumbra {
namespace {

using test::dataPath;
using test::TempDir;

using test::errorNames;

TEST(ObjLoad, CornellPartsCountsAndValues) {
  struct Part {
    const char* name;
    size_t triangles;
    size_t vertices;
  };
  // Quads become two triangles; the boxes are already triangles, with one normal per side.
  const Part parts[] = {{"floor", 2, 4},      {"ceiling", 4, 8},  {"back", 2, 4},
                        {"greenwall", 2, 4},  {"redwall", 2, 4},  {"smallbox", 12, 24},
                        {"largebox", 12, 24}, {"luminaire", 2, 4}};
  for (const Part& p : parts) {
    SCOPED_TRACE(p.name);
    Expected<Scene> s = loadObj(dataPath(std::string("cornell-box/") + p.name + ".obj"));
    ASSERT_TRUE(s.ok()) << s.error().describe();
    EXPECT_EQ(s->triangleCount(), p.triangles);
    EXPECT_EQ(s->vertexCount(), p.vertices);
    ASSERT_EQ(s->materials.size(), 1u);  // no MTL: the default material
    EXPECT_EQ(s->materials[0].name, "default");
    EXPECT_FLOAT_EQ(s->materials[0].reflectance.y, 0.8f);
  }
  Expected<Scene> floor = loadObj(dataPath("cornell-box/floor.obj"));
  ASSERT_TRUE(floor.ok());
  const Mesh& m = floor->meshes[0];
  EXPECT_FLOAT_EQ(m.positions[0].x, 552.79999f);  // "v 552.79999 0 0"
  EXPECT_FLOAT_EQ(m.positions[0].y, 0.0f);
  EXPECT_EQ(m.triangles[0], glm::uvec3(0, 1, 2));  // f 1 2 3 4 -> (1 2 3), (1 3 4)
  EXPECT_EQ(m.triangles[1], glm::uvec3(0, 2, 3));
  EXPECT_FLOAT_EQ(m.positions[3].z, 559.20001f);
  EXPECT_TRUE(m.normals.empty());
}

TEST(ObjLoad, LargeBoxHasNormals) {
  Expected<Scene> s = loadObj(dataPath("cornell-box/largebox.obj"));
  ASSERT_TRUE(s.ok()) << s.error().describe();
  const Mesh& m = s->meshes[0];
  ASSERT_EQ(m.normals.size(), m.positions.size());
  EXPECT_EQ(m.positions.size(), 24u);
  // First face "f 1//1 2//1 3//1": the top, normal +y, at y = 330.
  EXPECT_FLOAT_EQ(m.normals[0].y, 1.0f);
  EXPECT_FLOAT_EQ(m.positions[0].y, 330.0f);
  // Second side's normal (0.955649 0 -0.294508) on its vertices.
  const glm::uvec3 t = m.triangles[2];
  EXPECT_NEAR(m.normals[t.x].x, 0.955649f, 1e-5f);
  EXPECT_NEAR(m.normals[t.x].z, -0.294508f, 1e-5f);
}

TEST(ObjLoad, FanTriangulationMaterialsAndCorners) {
  TempDir dir;
  dir.write("m.mtl",
            "newmtl red\nKd 0.6 0.1 0.1\n"
            "newmtl lamp\nKd 0.5 0.5 0.5\nKe 10 8 6\n");
  const std::string path = dir.write("poly.obj",
                                     "mtllib m.mtl\n"
                                     "v 0 0 0\nv 1 0 0\nv 2 1 0\nv 1 2 0\nv 0 1 0\n"
                                     "vn 0 0 1\nvn 0 0 -1\n"
                                     "f 1 2 3 4 5   # a pentagon, no material\n"
                                     "usemtl lamp\n"
                                     "f -5//1 -4//1 -3//1\n"
                                     "usemtl red\n"
                                     "f 1//2 2//2 3//2\n");
  Expected<Scene> s = loadObj(path);
  ASSERT_TRUE(s.ok()) << s.error().describe();
  ASSERT_EQ(s->triangleCount(), 5u);
  const Mesh& m = s->meshes[0];
  // The pentagon: (v0 v1 v2) (v0 v2 v3) (v0 v3 v4), in file order.
  EXPECT_EQ(m.triangles[0], glm::uvec3(0, 1, 2));
  EXPECT_EQ(m.triangles[1], glm::uvec3(0, 2, 3));
  EXPECT_EQ(m.triangles[2], glm::uvec3(0, 3, 4));
  // Some faces lack normals: normals dropped (with a warning), vertices shared by position; the
  // lamp lies on the pentagon, so it is lifted off it on three vertices of its own
  // (scene/coplanar_emitters.h).
  EXPECT_TRUE(m.normals.empty());
  EXPECT_EQ(m.positions.size(), 8u);
  EXPECT_EQ(m.triangles[3], glm::uvec3(5, 6, 7));
  EXPECT_FALSE(s->warnings.empty());
  // Materials: red, lamp from the MTL, then the default for the pentagon.
  ASSERT_EQ(s->materials.size(), 3u);
  const Material& pent = s->materials[m.material_ids[0]];
  EXPECT_EQ(pent.name, "default");
  const Material& lamp = s->materials[m.material_ids[3]];
  EXPECT_EQ(lamp.name, "lamp");
  EXPECT_FLOAT_EQ(lamp.emission.x, 10.0f);
  EXPECT_FLOAT_EQ(lamp.emission.z, 6.0f);
  EXPECT_FLOAT_EQ(lamp.reflectance.y, 0.5f);
  const Material& red = s->materials[m.material_ids[4]];
  EXPECT_FLOAT_EQ(red.reflectance.x, 0.6f);
  EXPECT_FALSE(red.isEmissive());
}

TEST(ObjLoad, PolygonsOfAnySizeKeepEveryCornerInFileOrder) {
  // A convex 1000-gon (a CAD export's disc) and a triangle after it: 998 + 1 triangles, the
  // polygon's fan (v0 v_k v_k+1) in order, then the triangle, with the material it names.
  TempDir dir;
  dir.write("m.mtl", "newmtl red\nKd 0.6 0.1 0.1\n");
  std::string text = "mtllib m.mtl\n";
  const int n = 1000;
  for (int k = 0; k < n; ++k) {
    const double a = 2.0 * 3.14159265358979 * k / n;
    text += fmt::format("v {} {} 0\n", std::cos(a), std::sin(a));
  }
  text += "v 0 0 1\nusemtl red\nf";
  for (int k = 1; k <= n; ++k) text += fmt::format(" {}", k);
  text += fmt::format("\nf 1 2 {}\n", n + 1);
  Expected<Scene> s = loadObj(dir.write("disc.obj", text));
  ASSERT_TRUE(s.ok()) << s.error().describe();
  ASSERT_EQ(s->triangleCount(), size_t(n - 2 + 1));
  const Mesh& m = s->meshes[0];
  for (int k = 0; k < n - 2; ++k) {
    ASSERT_EQ(m.positions[m.triangles[size_t(k)].x], m.positions[0]) << k;
    ASSERT_EQ(m.positions[m.triangles[size_t(k)].y], m.positions[size_t(k + 1)]) << k;
    ASSERT_EQ(m.positions[m.triangles[size_t(k)].z], m.positions[size_t(k + 2)]) << k;
  }
  EXPECT_EQ(m.positions[m.triangles[size_t(n - 2)].z], glm::vec3(0, 0, 1));
  // The fan covers the disc: its area is the polygon's.
  double area = 0.0;
  for (int k = 0; k < n - 2; ++k) {
    const glm::uvec3 t = m.triangles[size_t(k)];
    area += 0.5 * glm::length(glm::cross(m.positions[t.y] - m.positions[t.x],
                                         m.positions[t.z] - m.positions[t.x]));
  }
  EXPECT_NEAR(area, 0.5 * n * std::sin(2.0 * 3.14159265358979 / n), 1e-4);
  for (uint32_t id : m.material_ids) EXPECT_EQ(s->materials[id].name, "red");
}

TEST(ObjLoad, VerticesAreSplitPerNormal) {
  TempDir dir;
  // Two triangles share positions 1 and 3 but not their normals.
  const std::string path = dir.write("split.obj",
                                     "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
                                     "vn 0 0 1\nvn 0 0.6 0.8\nvt 0 0\nvt 1 1\n"
                                     "f 1/1/1 2/1/1 3/2/1\nf 2/1/2 4/2/2 3/2/2\n");
  Expected<Scene> s = loadObj(path);
  ASSERT_TRUE(s.ok()) << s.error().describe();
  const Mesh& m = s->meshes[0];
  EXPECT_EQ(m.positions.size(), 6u);
  ASSERT_EQ(m.normals.size(), 6u);
  ASSERT_EQ(m.uvs.size(), 6u);
  EXPECT_FLOAT_EQ(m.normals[m.triangles[1].x].y, 0.6f);
  EXPECT_FLOAT_EQ(m.uvs[m.triangles[1].y].x, 1.0f);
  EXPECT_EQ(m.positions[m.triangles[1].x], glm::vec3(1, 0, 0));
}

// MTL illumination models that ray-trace: illum 3 and 5 make a mirror of Ks, illum 4, 6, 7 and 9
// glass of index Ni filtered by Tf; illum 2 stays diffuse.
TEST(ObjLoad, RayTracedIllumModelsAreMirrorsAndGlass) {
  TempDir dir;
  dir.write("m.mtl",
            "newmtl chrome\nillum 5\nKd 0.1 0.1 0.1\nKs 0.9 0.8 0.7\n"
            "newmtl crown\nillum 7\nNi 1.52\nTf 1 1 0.9\n"
            "newmtl bare\nillum 7\n"
            "newmtl paint\nillum 2\nKd 0.5 0.5 0.5\nKs 0.9 0.9 0.9\n");
  const std::string path = dir.write(
      "m.obj",
      "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl chrome\nf 1 2 3\nusemtl crown\nf 1 2 3\n"
      "usemtl bare\nf 1 2 3\nusemtl paint\nf 1 2 3\n");
  Expected<Scene> s = loadObj(path);
  ASSERT_TRUE(s.ok()) << s.error().describe();
  ASSERT_EQ(s->materials.size(), 4u);
  EXPECT_EQ(s->materials[0].scattering, Scattering::kMirror);
  EXPECT_EQ(s->materials[0].specular, glm::vec3(0.9f, 0.8f, 0.7f));
  EXPECT_EQ(s->materials[0].reflectance, glm::vec3(0.9f, 0.8f, 0.7f));  // the stand-in
  EXPECT_EQ(s->materials[1].scattering, Scattering::kDielectric);
  EXPECT_FLOAT_EQ(s->materials[1].ior, 1.52f);
  EXPECT_EQ(s->materials[1].specular, glm::vec3(1.0f, 1.0f, 0.9f));
  EXPECT_EQ(s->materials[2].scattering, Scattering::kDielectric);  // no Ni: 1.5, with a warning
  EXPECT_FLOAT_EQ(s->materials[2].ior, 1.5f);
  EXPECT_EQ(s->materials[2].specular, glm::vec3(1.0f));
  ASSERT_EQ(s->warnings.size(), 1u);
  EXPECT_NE(s->warnings[0].find("material 'bare': illum 7 (glass) with Ni 1 read as Ni 1.5"),
            std::string::npos)
      << s->warnings[0];
  EXPECT_EQ(s->materials[3].scattering, Scattering::kDiffuse);
  dir.write("bad.mtl", "newmtl flint\nillum 7\nNi 9\n");
  const std::string bad = dir.write("bad.obj",
                                    "mtllib bad.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\n"
                                    "usemtl flint\nf 1 2 3\n");
  EXPECT_TRUE(errorNames(loadObj(bad), bad, "material 'flint': Ni 9 is outside [1, 4]"));
}

TEST(ObjLoad, MissingMaterialLibraryIsAWarning) {
  TempDir dir;
  const std::string path =
      dir.write("nomtl.obj", "mtllib gone.mtl\nusemtl x\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  Expected<Scene> s = loadObj(path);
  ASSERT_TRUE(s.ok()) << s.error().describe();
  ASSERT_EQ(s->warnings.size(), 1u);
  EXPECT_NE(s->warnings[0].find("gone.mtl"), std::string::npos) << s->warnings[0];
  EXPECT_EQ(s->materials[s->meshes[0].material_ids[0]].name, "default");
}

TEST(ObjLoad, ErrorsNameFileAndLine) {
  TempDir dir;
  const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  struct Case {
    const char* name;
    std::string text;
    const char* place;
  };
  const Case cases[] = {
      {"garbage.obj", tri + "this is not obj\nf 1 2 3\n", "line 4"},
      {"badnum.obj", "v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n", "line 2"},
      {"nan.obj", "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n", "line 3, vertex 3"},
      {"inf.obj", "v 0 0 0\nv 1 0 1e99\nv 0 1 0\nf 1 2 3\n", "line 2, vertex 2"},
      {"range.obj", tri + "f 1 2 3\nf 1 2 9\n", "line 5"},
      {"relative.obj", tri + "f -1 -2 -4\n", "line 4"},
      {"zero.obj", tri + "f 0 1 2\n", "line 4"},
      {"normal.obj", tri + "vn 0 0 1\nf 1//1 2//2 3//1\n", "line 5"},
      {"twocorners.obj", tri + "f 1 2\n", "line 4"},
      {"badcorner.obj", tri + "f 1/2/3/4 2 3\n", "line 4"},
      {"empty.obj", "", "no faces"},
      {"nofaces.obj", tri, "no faces"},
      {"degenerate.obj", "v 0 0 0\nv 0 0 0\nv 0 0 0\nf 1 2 3\n", "degenerate"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string path = dir.write(c.name, c.text);
    EXPECT_TRUE(errorNames(loadObj(path), path, c.place));
  }
  // A missing file, and a binary PLY given as OBJ.
  const std::string missing = dir.file("missing.obj");
  EXPECT_TRUE(errorNames(loadObj(missing), missing, "no such file"));
  EXPECT_TRUE(errorNames(loadObj(dataPath("bunny.ply")), dataPath("bunny.ply"), "line 1"));
}

TEST(ObjLoad, NonFiniteOrNegativeMaterialValuesNameTheLibraryAndLine) {
  TempDir dir;
  const std::string obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n";
  struct Case {
    const char* mtl;
    const char* place;
  };
  const Case cases[] = {
      {"newmtl a\nKd nan 0.5 0.5\n", "line 2"},
      {"newmtl a\nKd 0.5 0.5 0.5\nKe 1 inf 1\n", "line 3"},
      {"newmtl a\n\nKd 0.5 -0.5 0.5\n", "line 3"},
      {"newmtl a\nKd 0.5 half 0.5\n", "line 2"},
      {"newmtl a\nNs 1e999\n", "line 2"},
      {"newmtl a\nKd spectral white.rfl\n", "line 2"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.mtl);
    const std::string mtl = dir.write("m.mtl", c.mtl);
    const std::string path = dir.write("o.obj", obj);
    EXPECT_TRUE(errorNames(loadObj(path), mtl, c.place));
  }
  // Good values load.
  dir.write("m.mtl", "newmtl a  # comment\nKd 0.5 0.25 1\nKe 2 2 2\nNs 10\nd 1\n");
  Expected<Scene> s = loadObj(dir.write("o.obj", obj));
  ASSERT_TRUE(s.ok()) << s.error().describe();
  EXPECT_FLOAT_EQ(s->materials[0].reflectance.y, 0.25f);
}

TEST(ObjLoad, IgnoredStatementsWarn) {
  TempDir dir;
  const std::string path =
      dir.write("lines.obj", "o thing\nv 0 0 0\nv 1 0 0\nv 0 1 0\ns off\nl 1 2\nf 1 2 3\n");
  Expected<Scene> s = loadObj(path);
  ASSERT_TRUE(s.ok()) << s.error().describe();
  EXPECT_EQ(s->triangleCount(), 1u);
  EXPECT_EQ(s->meshes[0].name, "thing");
  ASSERT_EQ(s->warnings.size(), 1u);
  EXPECT_NE(s->warnings[0].find("line 6"), std::string::npos) << s->warnings[0];
}

}  // namespace
}  // namespace penumbra
