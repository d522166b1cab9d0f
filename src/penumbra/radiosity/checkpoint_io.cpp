#include "penumbra/radiosity/checkpoint_io.h"

#include "penumbra/core/file_util.h"
#include "penumbra/core/hash.h"

#include <cstdio>
#include <memory>
#include <variant>

namespace penumbra {

Status writeCheckpointFile(const std::string& path, CheckpointWriter& w) {
  Fnv1a h;
  h.add(w.bytes.data(), w.bytes.size());
  w.put(h.h);
  return writeAtomicallyNow(
      path, [&](const std::string& tmp) -> Status { return writeBytesTo(path, tmp, w.bytes); });
}

bool checkpointChecksumMatches(const std::string& bytes) {
  if (bytes.size() < 8) return false;
  Fnv1a h;
  h.add(bytes.data(), bytes.size() - 8);
  uint64_t stored = 0;
  std::memcpy(&stored, bytes.data() + bytes.size() - 8, 8);
  return stored == h.h;
}

uint64_t radiosityFingerprint(const Scene& scene, const RadiositySurface& surface,
                              bool shading_normals) {
  Fnv1a h;
  const FlatTriangles& flat = surface.flat;
  h.add(flat.positions.data(), flat.positions.size() * sizeof(glm::vec3));
  h.add(flat.triangles.data(), flat.triangles.size() * sizeof(glm::uvec3));
  h.add(flat.material_ids.data(), flat.material_ids.size() * sizeof(uint32_t));
  for (const Material& m : scene.materials) {
    h.addValue(m.reflectance);
    h.addValue(m.emission);
    h.addValue(uint8_t(m.two_sided ? 1 : 0));
    h.addValue(uint8_t(m.alpha_mode));
    h.addValue(m.alpha);
    h.addValue(m.alpha_cutoff);
    h.addValue(uint8_t(m.unlit ? 1 : 0));
  }
  // What the textures, vertex colours, cut-outs and normal maps make of each element: a texture
  // or alpha mode changed since the checkpoint changes these (resuming onto them would mix two
  // solutions).
  auto add_all = [&](const auto& v) {
    if (!v.empty()) h.add(v.data(), v.size() * sizeof(v[0]));
  };
  add_all(surface.texture_reflectance);
  add_all(surface.texture_emission);
  add_all(surface.coverage);
  add_all(surface.reflectance);
  add_all(surface.emission);
  add_all(surface.shading_normal);
  for (const Light& light : scene.lights) {
    h.addValue(uint32_t(light.index()));
    std::visit([&](const auto& l) { h.addValue(l); }, light);
  }
  // The light from outside (radiosity/outside_light.h): a checkpoint solved under one sky or
  // environment must not resume under another (--sky and --environment change them).
  h.addValue(scene.environment);
  h.addValue(uint8_t(scene.sky ? 1 : 0));
  if (scene.sky) {
    const Sky& sky = *scene.sky;
    h.addValue(sky.type);
    h.addValue(sky.zenith_luminance);
    h.addValue(sky.sun_elevation_deg);
    h.addValue(sky.sun_azimuth_deg);
    h.addValue(sky.ground_reflectance);
    h.addValue(sky.sun_illuminance);
    h.addValue(sky.north);
  }
  for (const Opening& o : scene.openings) {
    add_all(o.corners);
    h.addValue(uint8_t(o.glazed ? 1 : 0));
    h.addValue(o.transmittance);
    h.addValue(o.ior);
    h.addValue(uint8_t(o.falloff));
  }
  h.addValue(surface.atlas.width);
  h.addValue(surface.atlas.height);
  h.addValue(uint64_t(surface.elementCount()));
  h.addValue(uint8_t(shading_normals ? 1 : 0));
  return h.h;
}

}  // namespace penumbra
