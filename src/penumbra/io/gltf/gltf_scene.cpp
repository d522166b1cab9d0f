// glTF 2.0 scenes (.gltf, .glb) into Penumbra's Scene (docs/scene-format.md, "glTF 2.0"):
//   - the file and every file it names are read by Penumbra itself (io/gltf/gltf_asset.h);
//   - one scene of the file: `scene`, else the first (or --gltf-scene's), its node trees
//     flattened into world space; normals by the inverse transpose; a node whose transform mirrors
//     has its triangles' winding flipped so front faces stay counter-clockwise;
//   - a mesh under several nodes, and each copy EXT_mesh_gpu_instancing places, becomes a mesh
//     of its own in world space: every method gives each copy its own elements and lightmap
//     texels, and the Ray Engine's BVH is one level, so copies are expanded (counted and checked
//     against memory first);
//   - skinned meshes are posed by their joints' node transforms (the file's rest pose, as a viewer
//     shows it without animation: linear blend skinning, sec. 3.7.3), morph targets blended with
//     the node's weights or the mesh's (sec. 3.7.2.2);
//   - materials: io/gltf/gltf_materials.h; KHR_lights_punctual intensities are photometric (cd
//     for point and spot, lx for directional) and become radiometric by dividing by 683 lm/W and
//     multiplying by the light's linear colour; lights and cameras look down their node's -Z,
//     a camera's up is its node's +Y; the first perspective camera is the scene's.
#include "penumbra/core/memory.h"
#include "penumbra/io/gltf/gltf_accessor.h"
#include "penumbra/io/gltf/gltf_asset.h"
#include "penumbra/io/gltf/gltf_extensions.h"
#include "penumbra/io/gltf/gltf_materials.h"
#include "penumbra/io/gltf/gltf_primitive.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/scene/luminaire.h"

#include <nlohmann/json.hpp>

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/matrix.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <new>
#include <numbers>
#include <set>
#include <string>
#include <vector>

namespace penumbra {

namespace {

using nlohmann::json;

// The most triangles one glTF scene may instance (the engine indexes triangles with 32 bits;
// beyond this the memory guard refuses long before), and what each costs once loaded
// (positions, normals and indices of an expanded instance, with the vectors' slack).
constexpr uint64_t kMaxSceneTriangles = uint64_t(1) << 31;
constexpr uint64_t kLoadedBytesPerTriangle = 64;

bool finite(const glm::dmat4& m) {
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 4; ++r) {
      if (!std::isfinite(m[c][r])) return false;
    }
  }
  return true;
}

glm::dmat4 trs(const glm::dvec3& t, const glm::dquat& q, const glm::dvec3& s) {
  glm::dmat4 m = glm::mat4_cast(q);
  m[0] *= s.x;
  m[1] *= s.y;
  m[2] *= s.z;
  m[3] = glm::dvec4(t, 1.0);
  return m;
}

class GltfSceneReader {
 public:
  GltfSceneReader(GltfAsset& asset, Scene& scene, const SceneLoadOptions& options)
      : asset_(asset),
        scene_(scene),
        options_(options),
        materials_(asset, scene, options.textures) {}

  Status read();

 private:
  const std::string& path() const { return asset_.path(); }
  const json& nodes() const { return member(asset_.json(), "nodes"); }
  Status checkHierarchy();
  Expected<std::vector<int64_t>> sceneRoots();
  Status computeWorldTransforms();
  Expected<glm::dmat4> localTransform(size_t node);
  Expected<std::vector<glm::dmat4>> instances(size_t node);
  Status planScene(const std::vector<int64_t>& roots);
  Status addNode(size_t node);
  Status addPrimitive(size_t node, int64_t mesh, size_t primitive,
                      const std::vector<glm::dmat4>& placements);
  Expected<std::vector<glm::dmat4>> jointMatrices(size_t node);
  void placeMesh(const PrimitiveData& d, const glm::dmat4& world,
                 const std::vector<glm::dmat4>* joints, Mesh& mesh);
  Status addLight(size_t node);
  Status addCamera(size_t node);
  std::vector<double> morphWeights(size_t node, int64_t mesh) const;

  GltfAsset& asset_;
  Scene& scene_;
  const SceneLoadOptions& options_;
  GltfMaterials materials_;
  std::vector<int64_t> parent_;    // per node, -1 for a root
  std::vector<glm::dmat4> world_;  // per node
  // Primitives read once for every node that places them unchanged (no skin, no weights of its
  // own), by (mesh, primitive).
  std::map<std::pair<int64_t, size_t>, PrimitiveData> shared_;
  size_t skipped_primitives_ = 0;  // points and lines, which are not drawn
};

Status GltfSceneReader::checkHierarchy() {
  // glTF 2.0 (sec. 3.5.3, "Nodes and Hierarchy"): the nodes form disjoint strict trees; no node
  // has two parents, and none is its own ancestor. A file that breaks this (a DAG, which
  // instances a subtree once per path and can grow exponentially, or a cycle) is refused.
  const size_t nn = nodes().size();
  parent_.assign(nn, -1);
  for (size_t n = 0; n < nn; ++n) {
    const json& node = nodes()[n];
    for (const json& cj : member(node, "children")) {
      const int64_t c = cj.get<int64_t>();
      if (c < 0 || size_t(c) >= nn) {
        return inputError(path(), fmt::format("node {}", n),
                          fmt::format("child {} does not exist (the file has {} nodes)", c, nn));
      }
      if (parent_[size_t(c)] >= 0) {
        return inputError(
            path(), fmt::format("node {}", n),
            parent_[size_t(c)] == int64_t(n)
                ? fmt::format("child {} is listed twice (glTF nodes form trees)", c)
                : fmt::format("node {} is also a child of node {}: a node has at most one parent "
                              "(glTF nodes form trees)",
                              c, parent_[size_t(c)]));
      }
      parent_[size_t(c)] = int64_t(n);
    }
    static constexpr std::pair<const char*, const char*> kRefs[] = {
        {"mesh", "meshes"}, {"camera", "cameras"}, {"skin", "skins"}};
    for (const auto& [key, list] : kRefs) {
      if (!node.contains(key)) continue;
      Expected<const json*> e =
          asset_.entry(list, node[key].get<int64_t>(), fmt::format("node {}", n));
      if (!e) return e.error();
    }
  }
  // A cycle: following parents from some node never ends at a root.
  std::vector<uint8_t> state(nn, 0);  // 0 unknown, 1 on the current walk, 2 reaches a root
  std::vector<size_t> walk;
  for (size_t n = 0; n < nn; ++n) {
    walk.clear();
    size_t at = n;
    while (state[at] == 0) {
      state[at] = 1;
      walk.push_back(at);
      if (parent_[at] < 0) break;
      at = size_t(parent_[at]);
    }
    if (state[at] == 1 && parent_[at] >= 0) {
      return inputError(path(), fmt::format("node {}", at), "the node hierarchy has a cycle");
    }
    for (size_t w : walk) state[w] = 2;
  }
  return {};
}

Expected<std::vector<int64_t>> GltfSceneReader::sceneRoots() {
  std::vector<int64_t> roots;
  const json& scenes = member(asset_.json(), "scenes");
  if (scenes.empty()) {
    // No scene: every node that is nobody's child is a root.
    for (size_t i = 0; i < parent_.size(); ++i) {
      if (parent_[i] < 0) roots.push_back(int64_t(i));
    }
    if (!roots.empty()) {
      scene_.warnings.push_back(
          fmt::format("{}: the file defines no scene; all root nodes are loaded", path()));
    }
    return roots;
  }
  int64_t si =
      options_.gltf_scene >= 0 ? options_.gltf_scene : asset_.json().value("scene", int64_t(0));
  if (si < 0 || size_t(si) >= scenes.size()) {
    return inputError(path(), options_.gltf_scene >= 0 ? "--gltf-scene" : "scene",
                      fmt::format("scene {} does not exist (the file has {})", si, scenes.size()));
  }
  if (scenes.size() > 1) {
    scene_.warnings.push_back(fmt::format(
        "{}: the file holds {} scenes; scene {}{} is loaded (--gltf-scene chooses another)", path(),
        scenes.size(), si,
        scenes[size_t(si)].contains("name")
            ? fmt::format(" ('{}')", scenes[size_t(si)]["name"].get<std::string>())
            : std::string()));
  }
  const std::string place = fmt::format("scene {}", si);
  std::vector<bool> listed(parent_.size(), false);
  std::vector<int64_t> given;
  for (const json& rj : member(scenes[size_t(si)], "nodes")) {
    const int64_t r = rj.get<int64_t>();
    if (r < 0 || size_t(r) >= parent_.size()) {
      return inputError(path(), place, fmt::format("node {} does not exist", r));
    }
    if (listed[size_t(r)]) {
      scene_.warnings.push_back(
          fmt::format("{}: {}: node {} is listed twice; it is drawn once", path(), place, r));
      continue;
    }
    listed[size_t(r)] = true;
    given.push_back(r);
  }
  // A scene must list roots only (glTF 2.0 sec. 3.5.1; the validator's SCENE_NON_ROOT_NODE), yet
  // exporters list children too. Such a node is drawn once, where the file's node tree puts it
  // (its parents' transforms apply): under a listed ancestor if it has one, else from itself.
  for (const int64_t r : given) {
    if (parent_[size_t(r)] < 0) {
      roots.push_back(r);
      continue;
    }
    int64_t a = parent_[size_t(r)];
    while (a >= 0 && !listed[size_t(a)]) a = parent_[size_t(a)];
    scene_.warnings.push_back(fmt::format(
        "{}: {}: node {} is a child of node {}, not a root; it is drawn once, {}", path(), place, r,
        parent_[size_t(r)],
        a >= 0 ? fmt::format("under node {}", a) : std::string("with its parents' transforms")));
    if (a < 0) roots.push_back(r);
  }
  return roots;
}

Expected<glm::dmat4> GltfSceneReader::localTransform(size_t n) {
  const json& node = nodes()[n];
  const std::string place = fmt::format("node {}", n);
  if (node.contains("matrix")) {
    glm::dmat4 m;
    for (int c = 0; c < 4; ++c) {
      for (int r = 0; r < 4; ++r) m[c][r] = node["matrix"][size_t(4 * c + r)].get<double>();
    }
    return m;  // glTF matrices are column-major, like glm
  }
  glm::dvec3 t(0.0), s(1.0);
  glm::dquat q(1.0, 0.0, 0.0, 0.0);
  if (node.contains("translation")) {
    for (int i = 0; i < 3; ++i) t[i] = node["translation"][size_t(i)].get<double>();
  }
  if (node.contains("rotation")) {
    const json& r = node["rotation"];
    // glTF stores x y z w; glm::dquat's constructor takes w first.
    q = glm::dquat(r[3].get<double>(), r[0].get<double>(), r[1].get<double>(), r[2].get<double>());
    if (!(glm::length(q) > 0.0)) return inputError(path(), place, "rotation is a zero quaternion");
    q = glm::normalize(q);
  }
  if (node.contains("scale")) {
    for (int i = 0; i < 3; ++i) s[i] = node["scale"][size_t(i)].get<double>();
  }
  return trs(t, q, s);
}

Status GltfSceneReader::computeWorldTransforms() {
  // Every tree of the file, not only the scene's: a skin's joints may lie outside it. Depth first
  // with an explicit stack: a chain of nodes thousands deep is a valid tree.
  const size_t nn = nodes().size();
  world_.assign(nn, glm::dmat4(1.0));
  std::vector<size_t> stack;
  for (size_t n = 0; n < nn; ++n) {
    if (parent_[n] < 0) stack.push_back(n);
  }
  while (!stack.empty()) {
    const size_t n = stack.back();
    stack.pop_back();
    Expected<glm::dmat4> local = localTransform(n);
    if (!local) return local.error();
    const glm::dmat4 world = parent_[n] < 0 ? *local : world_[size_t(parent_[n])] * *local;
    if (!finite(world)) {
      return inputError(path(), fmt::format("node {}", n), "the transform is not finite");
    }
    world_[n] = world;
    for (const json& c : member(nodes()[n], "children")) stack.push_back(size_t(c.get<int64_t>()));
  }
  return {};
}

// EXT_mesh_gpu_instancing: the node's copies, each T R S of its TRANSLATION, ROTATION and
// SCALE accessors (quaternions may be normalized integers); one identity without the extension.
Expected<std::vector<glm::dmat4>> GltfSceneReader::instances(size_t n) {
  const json& ext = member(member(nodes()[n], "extensions"), "EXT_mesh_gpu_instancing");
  if (!ext.is_object()) return std::vector<glm::dmat4>{glm::dmat4(1.0)};
  const std::string where = fmt::format("node {} EXT_mesh_gpu_instancing", n);
  const json& attributes = member(ext, "attributes");
  if (!attributes.is_object() || attributes.empty()) {
    return inputError(path(), where, "needs TRANSLATION, ROTATION or SCALE attributes");
  }
  std::map<std::string, AccessorView> views;
  size_t count = 0;
  for (const char* name : {"TRANSLATION", "ROTATION", "SCALE"}) {
    if (!attributes.contains(name)) continue;
    if (!attributes[name].is_number_integer()) {
      return inputError(path(), where + " " + name, "must be an accessor index");
    }
    Expected<AccessorView> v =
        readAccessor(asset_, attributes[name].get<int64_t>(), name, where + " " + name);
    if (!v) return v.error();
    if (count != 0 && v->count != count) {
      return inputError(
          path(), where + " " + name,
          fmt::format("count {} differs from the other attributes' {}", v->count, count));
    }
    count = v->count;
    views.emplace(name, std::move(*v));
  }
  std::vector<glm::dmat4> out(count);
  for (size_t i = 0; i < count; ++i) {
    glm::dvec3 t(0.0), s(1.0);
    glm::dquat q(1.0, 0.0, 0.0, 0.0);
    if (views.count("TRANSLATION")) {
      for (int k = 0; k < 3; ++k) t[k] = views["TRANSLATION"].component(i, k);
    }
    if (views.count("ROTATION")) {
      const AccessorView& r = views["ROTATION"];
      q = glm::dquat(r.component(i, 3), r.component(i, 0), r.component(i, 1), r.component(i, 2));
      if (!(glm::length(q) > 0.0)) {
        return inputError(path(), fmt::format("{} ROTATION, instance {}", where, i),
                          "a zero quaternion");
      }
      q = glm::normalize(q);
    }
    if (views.count("SCALE")) {
      for (int k = 0; k < 3; ++k) s[k] = views["SCALE"].component(i, k);
    }
    out[i] = trs(t, q, s);
    if (!finite(out[i])) {
      return inputError(path(), fmt::format("{}, instance {}", where, i),
                        "the transform is not finite");
    }
  }
  return out;
}

// Before anything is built: the triangles the scene instances (a mesh counts once per node and
// per GPU instance) against the limit and the memory, and the images its materials read.
Status GltfSceneReader::planScene(const std::vector<int64_t>& roots) {
  const json& meshes = member(asset_.json(), "meshes");
  std::vector<uint64_t> per_mesh(meshes.size(), 0);
  for (size_t m = 0; m < meshes.size(); ++m) {
    for (const json& prim : meshes[m]["primitives"]) {
      if (!drawsTriangles(prim)) continue;
      const json& attributes = prim["attributes"];
      const int64_t accessor = prim.contains("indices") ? prim["indices"].get<int64_t>()
                               : attributes.contains("POSITION")
                                   ? attributes["POSITION"].get<int64_t>()
                                   : -1;
      if (accessor < 0 || size_t(accessor) >= asset_.count("accessors")) continue;
      const uint64_t count =
          asset_.json()["accessors"][size_t(accessor)].value("count", uint64_t(0));
      per_mesh[m] += prim.value("mode", 4) == 4 ? count / 3 : count >= 3 ? count - 2 : 0;
    }
  }
  uint64_t total = 0;
  std::set<int64_t> materials;
  std::vector<int64_t> stack(roots.rbegin(), roots.rend());
  while (!stack.empty()) {
    const json& node = nodes()[size_t(stack.back())];
    const size_t n = size_t(stack.back());
    stack.pop_back();
    if (node.contains("mesh")) {
      const int64_t m = node["mesh"].get<int64_t>();
      const json& ext = member(member(node, "extensions"), "EXT_mesh_gpu_instancing");
      uint64_t copies = 1;
      if (ext.is_object() && member(ext, "attributes").is_object()) {
        for (auto it = ext["attributes"].begin(); it != ext["attributes"].end(); ++it) {
          if (!it->is_number_integer()) continue;
          Expected<const json*> a = asset_.entry("accessors", it->get<int64_t>(),
                                                 fmt::format("node {} EXT_mesh_gpu_instancing", n));
          if (!a) return a.error();
          copies = std::max<uint64_t>(copies, (*a)->value("count", uint64_t(1)));
        }
      }
      // Saturating: a file's counts may claim more than 64 bits hold.
      const uint64_t add =
          per_mesh[size_t(m)] > 0 && copies > (uint64_t(1) << 62) / per_mesh[size_t(m)]
              ? uint64_t(1) << 62
              : per_mesh[size_t(m)] * copies;
      total = std::min(total + add, uint64_t(1) << 62);
      for (const json& prim : meshes[size_t(m)]["primitives"]) {
        materials.insert(prim.value("material", int64_t(-1)));
      }
    }
    for (const json& c : member(node, "children")) stack.push_back(c.get<int64_t>());
  }
  if (total > kMaxSceneTriangles) {
    return inputError(path(), "nodes",
                      fmt::format("the scene instances {} triangles, more than the {} a scene may "
                                  "hold",
                                  total, kMaxSceneTriangles));
  }
  PENUMBRA_TRY(checkMemory(total * kLoadedBytesPerTriangle,
                           fmt::format("{}: the scene's {} instanced triangles", path(), total)));
  return materials_.plan(materials);
}

std::vector<double> GltfSceneReader::morphWeights(size_t n, int64_t mesh) const {
  const json& w = nodes()[n].contains("weights")
                      ? nodes()[n]["weights"]
                      : member(asset_.json()["meshes"][size_t(mesh)], "weights");
  std::vector<double> out;
  for (const json& v : w) out.push_back(v.is_number() ? v.get<double>() : 0.0);
  return out;
}

// Linear blend skinning's joint matrices (glTF 2.0 sec. 3.7.3): each joint's world transform times
// its inverse bind matrix; the skinned mesh's own node transform is not used.
Expected<std::vector<glm::dmat4>> GltfSceneReader::jointMatrices(size_t n) {
  const int64_t skin_index = nodes()[n]["skin"].get<int64_t>();
  const json& skin = asset_.json()["skins"][size_t(skin_index)];
  const std::string where = fmt::format("skin {}", skin_index);
  const json& joints = member(skin, "joints");
  if (joints.empty()) return inputError(path(), where, "has no joints");
  std::vector<glm::dmat4> out(joints.size(), glm::dmat4(1.0));
  AccessorView ibm;
  if (skin.contains("inverseBindMatrices")) {
    Expected<AccessorView> v = readAccessor(asset_, skin["inverseBindMatrices"].get<int64_t>(),
                                            "inverseBindMatrices", where + " inverseBindMatrices");
    if (!v) return v.error();
    if (v->count < joints.size()) {
      return inputError(
          path(), where,
          fmt::format("{} inverse bind matrices for {} joints", v->count, joints.size()));
    }
    ibm = std::move(*v);
  }
  for (size_t j = 0; j < joints.size(); ++j) {
    const int64_t joint = joints[j].get<int64_t>();
    if (joint < 0 || size_t(joint) >= world_.size()) {
      return inputError(path(), where, fmt::format("joint {} does not exist", joint));
    }
    glm::dmat4 inverse_bind(1.0);
    if (ibm.count) {
      for (int c = 0; c < 4; ++c) {
        for (int r = 0; r < 4; ++r) inverse_bind[c][r] = ibm.component(j, 4 * c + r);
      }
    }
    out[j] = world_[size_t(joint)] * inverse_bind;
    if (!finite(out[j])) {
      return inputError(path(), fmt::format("{} joint {}", where, j), "the matrix is not finite");
    }
  }
  return out;
}

void GltfSceneReader::placeMesh(const PrimitiveData& d, const glm::dmat4& world,
                                const std::vector<glm::dmat4>* joints, Mesh& mesh) {
  const size_t nv = d.positions.size();
  mesh.positions.resize(nv);
  if (!d.normals.empty()) mesh.normals.resize(nv);
  for (size_t i = 0; i < nv; ++i) {
    glm::dmat4 m = world;
    if (joints && !d.joints[0].empty()) {
      glm::dmat4 blend(0.0);
      double sum = 0.0;
      for (int set = 0; set < 2; ++set) {
        if (d.joints[set].empty()) continue;
        for (int k = 0; k < 4; ++k) {
          const double w = d.weights[set][i][k];
          const uint32_t j = d.joints[set][i][k];
          if (w <= 0.0 || j >= joints->size()) continue;
          blend += w * (*joints)[j];
          sum += w;
        }
      }
      if (sum > 0.0) m = blend / sum;
    }
    mesh.positions[i] = glm::vec3(m * glm::dvec4(d.positions[i], 1.0));
    if (!d.normals.empty()) {
      const glm::dvec3 w = glm::transpose(glm::inverse(glm::dmat3(m))) * d.normals[i];
      const double len = glm::length(w);
      mesh.normals[i] = len > 0.0 && std::isfinite(len) ? glm::vec3(w / len) : glm::vec3(0.0f);
    }
  }
  for (size_t set = 0; set < d.uvs.size(); ++set) {
    if (d.uvs[set].empty()) continue;
    if (set == 0) {
      mesh.uvs = d.uvs[0];
    } else {
      if (mesh.extra_uvs.size() < set) mesh.extra_uvs.resize(set);
      mesh.extra_uvs[set - 1] = d.uvs[set];
    }
    mesh.uv_origin_top = true;  // glTF: (0, 0) is the top-left of an image
  }
  mesh.colors = d.colors;
}

Status GltfSceneReader::addPrimitive(size_t n, int64_t mesh_index, size_t p,
                                     const std::vector<glm::dmat4>& placements) {
  const json& node = nodes()[n];
  const json& gmesh = asset_.json()["meshes"][size_t(mesh_index)];
  const json& prim = gmesh["primitives"][p];
  const std::string where = fmt::format("mesh {} primitive {}", mesh_index, p);
  if (!drawsTriangles(prim)) {
    scene_.warnings.push_back(fmt::format("{}: {}: points and lines (mode {}) are skipped", path(),
                                          where, prim.value("mode", 4)));
    ++skipped_primitives_;
    return {};
  }
  // A primitive is read once per mesh; a node's own morph weights give it its own reading (a
  // skin does not: placeMesh poses the shared reading).
  const bool own = node.contains("weights");
  PrimitiveData local;
  const PrimitiveData* d = nullptr;
  auto cached = shared_.find({mesh_index, p});
  if (!own && cached != shared_.end()) {
    d = &cached->second;
  } else {
    const std::vector<double> weights = morphWeights(n, mesh_index);
    Expected<PrimitiveData> read = readPrimitive(asset_, mesh_index, p, weights, where);
    if (!read) return read.error();
    if (read->dropped) {
      scene_.warnings.push_back(
          fmt::format("{}: {}: {} vertices is not a multiple of 3; the last {} are ignored", path(),
                      where, read->corners.size() + read->dropped, read->dropped));
    }
    if (read->bad_normals) {
      scene_.warnings.push_back(fmt::format(
          "{}: {}: {} normals are not finite numbers; those vertices are shaded with their "
          "triangle's own normal",
          path(), where, read->bad_normals));
    }
    if (own) {
      local = std::move(*read);
      d = &local;
    } else {
      d = &(shared_[{mesh_index, p}] = std::move(*read));
    }
  }
  Expected<uint32_t> material = materials_.material(d->material, where);
  if (!material) return material.error();
  // A texture reads a UV set the primitive has (glTF 2.0 sec. 5.20: texCoord names an attribute).
  const Material& m = scene_.materials[*material];
  for (const auto* binding : {&m.reflectance_texture, &m.emission_texture}) {
    if (!*binding) continue;
    const uint32_t set = (*binding)->uv_set;
    if (set >= d->uvs.size() || d->uvs[set].empty()) {
      return inputError(path(), where,
                        fmt::format("material '{}' reads TEXCOORD_{}, which the primitive does "
                                    "not have",
                                    m.name, set));
    }
  }
  std::vector<glm::dmat4> joints;
  if (node.contains("skin")) {
    Expected<std::vector<glm::dmat4>> j = jointMatrices(n);
    if (!j) return j.error();
    joints = std::move(*j);
  }
  const std::string base = node.contains("name")    ? node["name"].get<std::string>()
                           : gmesh.contains("name") ? gmesh["name"].get<std::string>()
                                                    : fmt::format("mesh{}", mesh_index);
  for (size_t k = 0; k < placements.size(); ++k) {
    Mesh mesh;
    mesh.name = base;
    if (gmesh["primitives"].size() > 1) mesh.name += fmt::format("#{}", p);
    if (placements.size() > 1) mesh.name += fmt::format("@{}", k);
    const glm::dmat4 world = world_[n] * placements[k];
    placeMesh(*d, world, joints.empty() ? nullptr : &joints, mesh);
    const bool mirrored = glm::determinant(glm::dmat3(joints.empty() ? world : joints[0])) < 0.0;
    mesh.triangles.reserve(d->corners.size() / 3);
    for (size_t i = 0; i + 2 < d->corners.size(); i += 3) {
      const uint32_t a = d->corners[i], b = d->corners[i + 1], c = d->corners[i + 2];
      mesh.triangles.push_back(mirrored ? glm::uvec3(a, c, b) : glm::uvec3(a, b, c));
    }
    mesh.material_ids.assign(mesh.triangles.size(), *material);
    mesh.gltf_node = int(n);
    mesh.gltf_mesh = int(mesh_index);
    mesh.gltf_primitive = int(p);
    // Every copy of an instancing node, a single one included: the plain document
    // (gltf_plain.cpp) gives each its own child node.
    mesh.gltf_instance =
        member(member(node, "extensions"), "EXT_mesh_gpu_instancing").is_object() ? int(k) : -1;
    mesh.gltf_mirrored = mirrored;
    if (mesh.triangles.empty()) {
      scene_.warnings.push_back(fmt::format("{}: {}: no triangles", path(), where));
      return {};
    }
    scene_.meshes.push_back(std::move(mesh));
  }
  return {};
}

Status GltfSceneReader::addNode(size_t n) {
  const json& node = nodes()[n];
  if (node.contains("mesh")) {
    Expected<std::vector<glm::dmat4>> placements = instances(n);
    if (!placements) return placements.error();
    const int64_t m = node["mesh"].get<int64_t>();
    const size_t primitives = asset_.json()["meshes"][size_t(m)]["primitives"].size();
    for (size_t p = 0; p < primitives; ++p) PENUMBRA_TRY(addPrimitive(n, m, p, *placements));
  }
  if (node.contains("camera")) PENUMBRA_TRY(addCamera(n));
  if (member(member(node, "extensions"), "KHR_lights_punctual").is_object()) {
    PENUMBRA_TRY(addLight(n));
  }
  return {};
}

Status GltfSceneReader::addLight(size_t n) {
  const json& ext = nodes()[n]["extensions"]["KHR_lights_punctual"];
  const std::string place = fmt::format("node {}.extensions.KHR_lights_punctual", n);
  if (!ext.contains("light") || !ext["light"].is_number_integer()) {
    return inputError(path(), place, "needs an integer 'light'");
  }
  const int64_t li = ext["light"].get<int64_t>();
  const json& lights =
      member(member(member(asset_.json(), "extensions"), "KHR_lights_punctual"), "lights");
  if (li < 0 || size_t(li) >= lights.size()) {
    return inputError(path(), place, fmt::format("light {} does not exist", li));
  }
  const json& gl = lights[size_t(li)];
  const std::string lplace = fmt::format("KHR_lights_punctual.lights[{}]", li);
  glm::dvec3 color(1.0);
  if (gl.contains("color")) {
    for (int i = 0; i < 3; ++i)
      color[i] = std::clamp(gl["color"][size_t(i)].get<double>(), 0.0, 1.0);
  }
  const double intensity = gl.value("intensity", 1.0);
  // KHR_lights_punctual: photometric intensities, at 683 lm/W as its implementations take them.
  const glm::vec3 radiometric(color * (intensity / kLumensPerWatt));
  const glm::dmat4& world = world_[n];
  const glm::vec3 position(world * glm::dvec4(0.0, 0.0, 0.0, 1.0));
  const glm::dvec3 axis = glm::dmat3(world) * glm::dvec3(0.0, 0.0, -1.0);
  if (!(glm::length(axis) > 0.0)) {
    return inputError(path(), fmt::format("node {}", n), "the light's transform is singular");
  }
  const glm::vec3 direction(glm::normalize(axis));
  if (gl.value("range", 0.0) > 0.0) {
    scene_.warnings.push_back(fmt::format(
        "{}: {}: range {} is ignored (lights fall off with the inverse square law only)", path(),
        lplace, gl["range"].get<double>()));
  }
  const std::string type = gl.value("type", std::string());
  if (type == "point") {
    scene_.lights.push_back(PointLight{position, radiometric});
  } else if (type == "spot") {
    const json& spot = member(gl, "spot");
    const double inner = valueOr(spot, "innerConeAngle", 0.0);
    const double outer = valueOr(spot, "outerConeAngle", std::numbers::pi / 4.0);
    if (!(inner >= 0.0 && inner < outer && outer <= 0.5 * std::numbers::pi + 1e-9)) {
      return inputError(path(), lplace,
                        fmt::format("spot cone angles need 0 <= innerConeAngle < outerConeAngle "
                                    "<= pi/2 (got {} and {})",
                                    inner, outer));
    }
    scene_.lights.push_back(
        SpotLight{position, direction, radiometric, float(inner), float(outer)});
  } else if (type == "directional") {
    scene_.lights.push_back(DirectionalLight{direction, radiometric});
  } else {
    return inputError(path(), lplace, fmt::format("unknown light type '{}'", type));
  }
  return {};
}

Status GltfSceneReader::addCamera(size_t n) {
  if (scene_.camera) return {};  // the first camera wins
  const int64_t ci = nodes()[n]["camera"].get<int64_t>();
  const json& gc = asset_.json()["cameras"][size_t(ci)];
  const std::string type = gc.value("type", std::string());
  if (type != "perspective") {
    scene_.warnings.push_back(fmt::format(
        "{}: camera {}: '{}' cameras are not supported, only perspective", path(), ci, type));
    return {};
  }
  const double yfov = valueOr(member(gc, "perspective"), "yfov", 0.0);
  if (!(yfov > 0.0 && yfov < std::numbers::pi)) {
    return inputError(path(), fmt::format("camera {}", ci),
                      fmt::format("yfov {} must be in (0, pi)", yfov));
  }
  const glm::dmat4& world = world_[n];
  const glm::dmat3 linear(world);
  const glm::dvec3 forward = linear * glm::dvec3(0.0, 0.0, -1.0);
  const glm::dvec3 up = linear * glm::dvec3(0.0, 1.0, 0.0);
  if (!(glm::length(forward) > 0.0) || !(glm::length(up) > 0.0)) {
    return inputError(path(), fmt::format("node {}", n), "the camera's transform is singular");
  }
  Camera cam;
  const glm::dvec3 position(world * glm::dvec4(0.0, 0.0, 0.0, 1.0));
  cam.position = glm::vec3(position);
  cam.look_at = glm::vec3(position + glm::normalize(forward));
  cam.up = glm::vec3(glm::normalize(up));
  cam.vertical_fov = float(yfov);
  scene_.camera = cam;
  return {};
}

Status GltfSceneReader::read() {
  for (std::string& w : extensionWarnings(path(), asset_.json())) {
    scene_.warnings.push_back(std::move(w));
  }
  PENUMBRA_TRY(checkHierarchy());
  Expected<std::vector<int64_t>> roots = sceneRoots();
  if (!roots) return roots.error();
  PENUMBRA_TRY(computeWorldTransforms());
  PENUMBRA_TRY(planScene(*roots));
  // Depth first, children in order (the order of the scene's meshes).
  std::vector<int64_t> stack(roots->rbegin(), roots->rend());
  while (!stack.empty()) {
    const size_t n = size_t(stack.back());
    stack.pop_back();
    PENUMBRA_TRY(addNode(n));
    const json& children = member(nodes()[n], "children");
    for (auto it = children.rbegin(); it != children.rend(); ++it) {
      stack.push_back(it->get<int64_t>());
    }
  }
  for (const std::string& w : materials_.warnings()) scene_.warnings.push_back(w);
  if (scene_.triangleCount() == 0) {
    // Nothing to compute light on: say why, so a valid file is not taken for a broken one.
    const std::string why = roots->empty() ? "the file's scene holds no nodes"
                            : skipped_primitives_
                                ? fmt::format(
                                      "its primitives ({}) are points or lines, which "
                                      "Penumbra does not draw (it computes light on surfaces)",
                                      skipped_primitives_)
                                : "none of its nodes holds a mesh (an animation or an empty scene)";
    return inputError(path(), "", fmt::format("the scene has no triangles: {}", why));
  }
  return {};
}

}  // namespace

Expected<Scene> loadGltf(const std::string& path, const SceneLoadOptions& options) {
  try {
    Expected<GltfAsset> asset = GltfAsset::open(path, options.files);
    if (!asset) return asset.error();
    Scene scene;
    scene.source = path;
    GltfSceneReader reader(*asset, scene, options);
    PENUMBRA_TRY(reader.read());
    PENUMBRA_TRY(validateScene(scene));
    return scene;
  } catch (const std::bad_alloc&) {
    // What the plans above could not foresee (a library's own allocation).
    return inputError(path, "", "reading it needs more memory than this process may allocate");
  } catch (const nlohmann::json::exception& e) {
    // Every value is checked against the schema first; a safety net, not a path.
    return inputError(path, "", fmt::format("unexpected JSON value: {}", e.what()));
  }
}

}  // namespace penumbra
