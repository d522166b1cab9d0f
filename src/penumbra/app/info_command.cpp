// `penumbra info`: what a scene holds.
#include "penumbra/accel/bounds.h"
#include "penumbra/app/commands.h"
#include "penumbra/core/file_util.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/parallel.h"
#include "penumbra/gpu/context.h"
#include "penumbra/io/image_io.h"
#include "penumbra/io/photometry.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/methods/scene_inputs.h"
#include "penumbra/render/plot.h"
#include "penumbra/render/ugr_table.h"

#include <glm/exponential.hpp>
#include <glm/trigonometric.hpp>

#include <fmt/format.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <variant>

namespace penumbra {

namespace {

int printDevices() {
  fmt::print("cpu        {} threads\n", threadCount());
  const GlProbe probe = probeGlDevices();
  for (const GlDeviceInfo& d : probe.devices) {
    fmt::print("gpu        {}: {} | {} | {}{}\n", d.platform, d.vendor, d.renderer, d.version,
               d.software ? " (software renderer: correctness runs, never timings)" : "");
    fmt::print("  max shader storage block   {}\n", formatBytes(uint64_t(d.max_ssbo_bytes)));
    fmt::print("  max 2D texture size        {}\n", d.max_texture_size);
    fmt::print(
        "  compute work group         {} invocations, size {} x {} x {}, count {} x {} x "
        "{}, {} shared\n",
        d.max_compute_invocations, d.max_compute_group_size[0], d.max_compute_group_size[1],
        d.max_compute_group_size[2], d.max_compute_group_count[0], d.max_compute_group_count[1],
        d.max_compute_group_count[2], formatBytes(uint64_t(d.max_compute_shared_bytes)));
  }
  for (const std::string& f : probe.failures) fmt::print("no context {}\n", f);
  if (probe.devices.empty())
    fmt::print("gpu        none: --device gpu will fail, auto uses the cpu\n");
  return 0;
}

// The luminaire's UGR table by CIE 190's tabular method (render/ugr_table.h), as data sheets
// print it: rooms 4H x 8H and 8H x 4H, S = 0.25 H, crosswise / endwise per reflectance set.
void printUgrTable(const Photometry& p) {
  Expected<std::vector<UgrTableRow>> table = ugrTable(p, 0.25);
  if (!table) {
    fmt::print("UGR          none: {}\n", table.error().message);
    return;
  }
  auto value = [](double v) { return std::isnan(v) ? std::string("-") : fmt::format("{:.1f}", v); };
  std::string head =
      "UGR          CIE 190, S = 0.25H, crosswise / endwise; ceiling/walls/floor:\n"
      "             room   ";
  for (const UgrReflectances& r : kUgrReflectances) head += fmt::format(" {:>11}", r.label());
  fmt::print("{}\n", head);
  for (size_t i = 0; i < table->size(); i += kUgrReflectances.size()) {
    const UgrRoom& room = (*table)[i].room;
    std::string line = fmt::format("             {}H x {}H", room.x_h, room.y_h);
    for (size_t k = 0; k < kUgrReflectances.size(); ++k) {
      const UgrTableRow& row = (*table)[i + k];
      line += fmt::format(" {:>11}", value(row.crosswise) + " / " + value(row.endwise));
    }
    fmt::print("{}\n", line);
  }
}

// A luminaire's photometric file: what it states, the flux integrated from its distribution
// next to the stated one, and its polar plot (--plot).
int printPhotometry(const InfoOptions& options) {
  if (!options.plot.empty()) {
    if (extensionOf(options.plot) != ".png") {
      return reportError(inputError(options.plot, "", "--plot writes a .png"));
    }
    if (Status s = checkOutputPath(options.plot); !s.ok()) return reportError(s.error());
  }
  Expected<Photometry> loaded = readPhotometry(options.scene);
  if (!loaded) return reportError(loaded.error());
  const Photometry& p = *loaded;
  const char* types[] = {"C", "B", "A"};
  fmt::print("file         {}\nformat       {}\n", p.file, p.format);
  if (!p.manufacturer.empty()) fmt::print("manufacturer {}\n", p.manufacturer);
  if (!p.luminaire.empty()) fmt::print("luminaire    {}\n", p.luminaire);
  if (!p.lamp.empty()) fmt::print("lamp         {}\n", p.lamp);
  fmt::print(
      "photometry   type {}, symmetry {}, {} planes x {} angles ({:g}..{:g} x {:g}..{:g} "
      "deg)\n",
      types[int(p.type)], p.symmetry, p.planes.size(), p.angles.size(), p.planes.front(),
      p.planes.back(), p.angles.front(), p.angles.back());
  fmt::print("opening      {:.4g} x {:.4g} x {:.4g} m{}\n", p.length, p.width, p.height,
             p.circular ? " (round)" : "");
  if (p.watts > 0.0) fmt::print("power        {:.4g} W\n", p.watts);
  double peak = 0.0;
  for (double v : p.candela) peak = std::max(peak, v);
  fmt::print("intensity    {:.5g} cd at most, {:.5g} cd at the nadir\n", peak,
             p.intensity(0.0, 0.0));
  const double integrated = p.integratedFlux();
  if (p.lamp_flux >= 0.0) {
    fmt::print("lamp flux    {:.6g} lm\n", p.lamp_flux);
  } else {
    fmt::print("lamp flux    none stated (absolute photometry)\n");
  }
  if (p.stated_flux >= 0.0 && p.format.starts_with("IES")) {
    // LM-63 states the lamps' flux only: the ratio is the luminaire's efficiency.
    fmt::print(
        "flux         {:.6g} lm integrated from the distribution: {:.1f}% of the lamps' "
        "{:.6g} lm (LM-63 states no luminaire flux)\n",
        integrated, 100.0 * integrated / p.stated_flux, p.stated_flux);
  } else if (p.stated_flux >= 0.0) {
    fmt::print(
        "flux         {:.6g} lm integrated from the distribution, {:.6g} lm stated "
        "({:+.2f}%)\n",
        integrated, p.stated_flux, 100.0 * (integrated / p.stated_flux - 1.0));
  } else {
    fmt::print("flux         {:.6g} lm integrated from the distribution\n", integrated);
  }
  printUgrTable(p);
  if (!options.plot.empty()) {
    ToneMapSettings none;
    none.op = ToneMapOperator::kNone;
    OutputTransaction transaction;
    Status s = writeImage(options.plot, luminairePolarPlot(p), none);
    if (s.ok()) s = transaction.commit();
    if (!s.ok()) return reportError(s.error());
    fmt::print("plot         {}\n", options.plot);
  }
  return 0;
}

// A material's textures (the image, its size and encoding, the UV set it reads) and coverage.
void printTexturesAndCoverage(const Material& m) {
  auto texture = [](const char* slot, const std::optional<TextureBinding>& b) {
    if (!b) return;
    const Texture& t = *b->texture;
    fmt::print("    {} '{}': {} x {}, {}, UV set {}{}\n", slot, t.source(), t.width(), t.height(),
               t.encoding() == TexelEncoding::kSrgb8     ? "8-bit sRGB"
               : t.encoding() == TexelEncoding::kLinear8 ? "8-bit"
                                                         : "16-bit",
               b->uv_set, b->sampler.nearest ? ", nearest" : "");
  };
  texture("reflectance texture", m.reflectance_texture);
  texture("emission texture", m.emission_texture);
  texture("coverage texture", m.coverage_texture);
  if (m.alpha_mode == AlphaMode::kMask) {
    fmt::print("    cut-out: covered where alpha >= {:.3g} (alpha factor {:.3g})\n", m.alpha_cutoff,
               m.alpha);
  } else if (m.alpha_mode == AlphaMode::kBlend) {
    fmt::print(
        "    partial coverage: light passes with probability 1 - alpha (alpha factor "
        "{:.3g})\n",
        m.alpha);
  }
}

}  // namespace

int runInfo(const InfoOptions& options, const CommonOptions&) {
  if (options.devices) return printDevices();
  const std::string ext = extensionOf(options.scene);
  if (ext == ".ldt" || ext == ".ies") return printPhotometry(options);
  if (!options.plot.empty()) {
    return reportError(inputError("", "--plot", "applies to photometric files (.ldt, .ies)"));
  }
  Expected<Scene> loaded = loadScene(options.scene);
  if (!loaded) return reportError(loaded.error());
  const Scene& s = *loaded;
  Bounds3 bounds;
  for (const Mesh& m : s.meshes) {
    for (const glm::vec3& p : m.positions) bounds.extend(p);
  }
  fmt::print("scene      {}\n", s.source);
  fmt::print("triangles  {}\nvertices   {}\n", s.triangleCount(), s.vertexCount());
  fmt::print("bounds     ({:.4g}, {:.4g}, {:.4g}) to ({:.4g}, {:.4g}, {:.4g}) m\n", bounds.lo.x,
             bounds.lo.y, bounds.lo.z, bounds.hi.x, bounds.hi.y, bounds.hi.z);
  fmt::print("meshes     {}\n", s.meshes.size());
  for (const Mesh& m : s.meshes) {
    std::string sets;
    for (size_t k = 0; k <= m.extra_uvs.size(); ++k) {
      if (m.uvSet(uint32_t(k)).empty()) continue;
      if (!sets.empty()) sets += ' ';
      sets += std::to_string(k);
    }
    fmt::print("  {:<20} {:>9} triangles {:>9} vertices{}{}{}\n", m.name.empty() ? "-" : m.name,
               m.triangles.size(), m.positions.size(), m.normals.empty() ? "" : ", normals",
               sets.empty() ? "" : ", uv sets " + sets, m.colors.empty() ? "" : ", colours");
  }
  fmt::print("materials  {}\n", s.materials.size());
  for (const Material& m : s.materials) {
    if (m.scattering == Scattering::kMirror) {
      fmt::print("  {:<20} mirror ({:.3g}, {:.3g}, {:.3g})", m.name, m.specular.x, m.specular.y,
                 m.specular.z);
    } else if (m.scattering == Scattering::kDielectric) {
      fmt::print("  {:<20} glass, ior {:.4g}, filter ({:.3g}, {:.3g}, {:.3g})", m.name, m.ior,
                 m.specular.x, m.specular.y, m.specular.z);
    } else {
      fmt::print("  {:<20} reflectance ({:.3g}, {:.3g}, {:.3g})", m.name, m.reflectance.x,
                 m.reflectance.y, m.reflectance.z);
    }
    if (m.isEmissive()) {
      fmt::print("  emission ({:.4g}, {:.4g}, {:.4g}) W/m^2/sr", m.emission.x, m.emission.y,
                 m.emission.z);
    }
    fmt::print("\n");
    printTexturesAndCoverage(m);
    if (const std::optional<Subsurface>& ss = m.subsurface) {
      // Per millimetre, as the scene gives them; the diffusion length 1 / sigma_tr in mm.
      const glm::dvec3 sp = ss->sigma_s_prime * 1e-3, a = ss->sigma_a * 1e-3;
      const glm::dvec3 tr = glm::sqrt(3.0 * a * (sp + a));
      fmt::print(
          "    subsurface{}: sigma_s' ({:.4g}, {:.4g}, {:.4g}) sigma_a ({:.4g}, {:.4g}, {:.4g}) "
          "/mm, eta {:.3g}, diffusion length ({:.3g}, {:.3g}, {:.3g}) mm\n",
          ss->preset.empty() ? "" : " " + ss->preset, sp.x, sp.y, sp.z, a.x, a.y, a.z, ss->eta,
          1.0 / tr.x, 1.0 / tr.y, 1.0 / tr.z);
    }
  }
  fmt::print("lights     {}\n", s.lights.size());
  for (const Light& l : s.lights) {
    std::visit(
        Overloaded{
            [](const PointLight& p) {
              fmt::print(
                  "  point at ({:.4g}, {:.4g}, {:.4g}), intensity ({:.4g}, {:.4g}, {:.4g}) W/sr\n",
                  p.position.x, p.position.y, p.position.z, p.intensity.x, p.intensity.y,
                  p.intensity.z);
            },
            [](const SpotLight& sp) {
              fmt::print(
                  "  spot at ({:.4g}, {:.4g}, {:.4g}), intensity ({:.4g}, {:.4g}, {:.4g}) W/sr, "
                  "cone {:.1f}-{:.1f} deg\n",
                  sp.position.x, sp.position.y, sp.position.z, sp.intensity.x, sp.intensity.y,
                  sp.intensity.z, glm::degrees(sp.inner_angle), glm::degrees(sp.outer_angle));
            },
            [](const DirectionalLight& d) {
              fmt::print(
                  "  directional towards ({:.3g}, {:.3g}, {:.3g}), irradiance ({:.4g}, {:.4g}, "
                  "{:.4g}) W/m^2\n",
                  d.direction.x, d.direction.y, d.direction.z, d.irradiance.x, d.irradiance.y,
                  d.irradiance.z);
            },
            [](const LuminaireLight& lu) {
              const LuminaireDistribution& t = *lu.distribution;
              const glm::dvec3 lumens = luminairePower(lu) * kLumensPerWatt;
              fmt::print(
                  "  luminaire {} at ({:.4g}, {:.4g}, {:.4g}) aimed ({:.3g}, {:.3g}, {:.3g}), "
                  "C0 ({:.3g}, {:.3g}, {:.3g}), {:.0f} lm (G channel), I_max {:.4g} cd, LDT "
                  "{} x {}\n",
                  t.source, lu.position.x, lu.position.y, lu.position.z, lu.nadir.x, lu.nadir.y,
                  lu.nadir.z, lu.c0.x, lu.c0.y, lu.c0.z, lumens.y,
                  double(lu.scale.y) * kLumensPerWatt, t.gamma_count, t.c_count);
            }},
        l);
  }
  if (s.camera) {
    fmt::print(
        "camera     at ({:.4g}, {:.4g}, {:.4g}) looking at ({:.4g}, {:.4g}, {:.4g}), "
        "vertical fov {:.2f} deg\n",
        s.camera->position.x, s.camera->position.y, s.camera->position.z, s.camera->look_at.x,
        s.camera->look_at.y, s.camera->look_at.z, glm::degrees(s.camera->vertical_fov));
  } else {
    fmt::print("camera     none (render frames the bounding box from +z)\n");
  }
  std::vector<std::string> warnings = s.warnings;
  for (std::string& w : firstPictureWarnings(s)) warnings.push_back(std::move(w));
  fmt::print("warnings   {}\n", warnings.size());
  for (const std::string& w : warnings) fmt::print("  {}\n", w);
  return 0;
}

}  // namespace penumbra
