// Real-time subsurface scattering by the three passes of Carr, Hall, Hart 2003 (sec. 4.2), on the
// CPU. The precomputation (sec. 4.2.1) lays the scene's faces out in the chart atlas with its
// hierarchy (translucent surfaces one-sided: the medium is inside) and builds the links
// (subsurface/sss_links.h); after that a moving light or camera costs only the passes:
//
//  - Pass 1, the radiosity map (sec. 4.2.2): per element of a translucent object the irradiance
//    transmitted through the boundary, E = sum over lights of F_t(eta, cos theta) E_light V
//    (eq. 8, one shadow ray per element and light), plus what emissive surfaces send (static, so
//    computed once with the links: per emitting triangle pi L_e times Lambert's point-to-polygon
//    form factor, times F_t towards its centroid and the visible fraction of four points on it),
//    plus what the scene's uniform environment sends (also static: pi L_env times the mean of
//    V F_t over 64 stratified cosine-distributed directions per element),
//    MIP-mapped up the hierarchy (nodeMeans).
//  - Pass 2, the scattered irradiance map (sec. 4.2.3): B_i = sum_links F E_node (eq. 9).
//  - Pass 3, the image (sec. 4.2.4): a translucent surface point shows L = F_t(eta, cos theta_o)
//    B / pi (eq. 6) with B looked up bilinearly in the atlas (render/sss_view.h). The
//    boundary's specular reflection is not part of the model; opaque surfaces show their direct
//    light (rho / pi E) and emitters their radiance.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/image.h"
#include "penumbra/radiosity/radiosity_surface.h"
#include "penumbra/scene/scene.h"
#include "penumbra/subsurface/sss_links.h"

#include <glm/vec3.hpp>

#include <functional>
#include <span>
#include <vector>

namespace penumbra {

// The paper's real-time atlas: 512 x 512 (Table 1 also runs 1024 x 1024).
inline constexpr int kSssDefaultAtlas = 512;

struct SssOptions {
  LightmapResolution resolution{std::nullopt, kSssDefaultAtlas};
  SssLinkOptions links;
  // Shadow rays in pass 1. Without them pass 1 is the paper's (sec. 4.2.2: the OpenGL lighting
  // model in a vertex program), and light reaches surfaces that face it through the object.
  bool shadows = true;
  // Where the links are cached (subsurface/sss_cache.h); empty: not cached.
  std::string cache_directory;
};

struct SssPassTimes {
  double irradiance = 0.0;  // pass 1, with the MIP-map
  double gather = 0.0;      // pass 2
  double image = 0.0;       // pass 3
};

class SssSolver {
 public:
  // Fails when no material has a subsurface block. `progress(done, total)` follows the links.
  static Expected<SssSolver> build(const Scene& scene, const SssOptions& options,
                                   const std::function<void(size_t, size_t)>& progress = nullptr);
  // What build checks before the links (--dry-run): a translucent material, the memory the links
  // will take, and the atlas itself, built (an atlas too small for the charts is refused).
  static Status check(const Scene& scene, const SssOptions& options);

  const RadiositySurface& surface() const { return surface_; }
  const SssTree& tree() const { return tree_; }
  const SssLinks& links() const { return links_; }
  const std::vector<Dipole>& media() const { return media_; }
  // The scene as solved: translucent materials one-sided.
  const Scene& scene() const { return scene_; }
  // Per element: the index of refraction of its medium, 0 for opaque elements.
  float eta(size_t element) const { return eta_[element]; }
  bool translucent(size_t element) const { return tree_.object[element] >= 0; }
  double buildSeconds() const { return build_seconds_; }
  // Whether pass 1 traces shadow rays (SssOptions::shadows).
  bool shadows() const { return options_.shadows; }
  // Whether the links came from the cache, and why they could not be written to it (empty when
  // they were, or came from it).
  bool linksFromCache() const { return links_from_cache_; }
  const std::string& cacheProblem() const { return cache_problem_; }

  // Pass 1: E per element (W m^-2), zero on opaque elements. Adds the shadow rays to *rays.
  std::vector<glm::vec3> transmittedIrradiance(std::span<const Light> lights,
                                               uint64_t* rays = nullptr) const;
  // Pass 2 from pass 1 (the MIP-map included): B per element (W m^-2).
  std::vector<glm::vec3> scatter(std::span<const glm::vec3> irradiance) const;
  // Pass 1's static share: the irradiance emissive surfaces and the scene's environment send
  // into each element, transmitted.
  const std::vector<glm::vec3>& staticIrradiance() const { return static_irradiance_; }
  // B / pi per atlas texel, the charts' gaps filled for bilinear lookups.
  Image scatteredRadianceAtlas(std::span<const glm::vec3> scattered) const;

 private:
  // The scene made one-sided where translucent and the atlas built: build's first half.
  static Expected<SssSolver> buildSurface(const Scene& scene, const SssOptions& options);
  std::vector<glm::vec3> computeEmitterIrradiance() const;
  void addEnvironmentIrradiance(std::vector<glm::vec3>& out) const;

  Scene scene_;
  SssOptions options_;
  RadiositySurface surface_;
  SssTree tree_;
  std::vector<Dipole> media_;
  SssLinks links_;
  std::vector<float> eta_;
  // Per element, transmitted, from emissive faces and the environment.
  std::vector<glm::vec3> static_irradiance_;
  double build_seconds_ = 0.0;
  bool links_from_cache_ = false;
  std::string cache_problem_;
};

}  // namespace penumbra
