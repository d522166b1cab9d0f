#include "penumbra/radiosity/progressive.h"
#include "penumbra/radiosity/cutout_jitter.h"
#include "penumbra/radiosity/outside_light.h"

#include "penumbra/geometry/shading_normals.h"
#include "penumbra/kernels/form_factor.h"
#include "penumbra/kernels/sampling.h"
#include "penumbra/raytrace/lights.h"

#include "penumbra/core/check.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/core/timer.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <numbers>
#include <span>
#include <utility>

namespace penumbra {

namespace {

constexpr double kPiD = std::numbers::pi;
constexpr uint32_t kNoElement = std::numeric_limits<uint32_t>::max();

// A shooter point: a cluster of the hierarchy under the shooter (substructuring, Wallner sec. 3:
// its position, summed area and area-weighted mean dB), with its children one level finer
// (elements at level 0).
struct ShooterPoint {
  // Clusters: the centroid of their elements' residual power (luminance(dB) times area), or
  // the hierarchy's area-weighted centroid when they have none.
  glm::dvec3 position{0.0};
  double area = 0.0;
  glm::dvec3 residual{0.0};
  glm::dvec3 normal{0.0};         // area-weighted mean shading normal (unit): the form factors'
  glm::dvec3 geometric{0.0};      // area-weighted mean face normal (unit): culling and rays
  uint32_t element = kNoElement;  // level 0: the element
  uint32_t child_first = 0, child_count = 0;  // points of its children
  uint32_t first = 0, last = 0;               // its elements
  ClusterRef cluster;
  bool above_top = false;  // coarser than the substructuring's top level
  int32_t pieces = -1;     // clusters: index of its pieces
};

// Cluster c's pieces: the candidate faces clipped to its texels, each passed to
// piece(corners, count).
template <typename Piece>
void clusterFacePieces(const RadiositySurface& surface, ClusterRef c,
                       std::span<const uint32_t> candidates, Piece&& piece) {
  const ClusterLevel& lv = surface.hierarchy.level(c.level);
  surface.atlas.forEachPiece(lv.lo[c.index], lv.hi[c.index], candidates, surface.flat.positions,
                             surface.flat.triangles,
                             [&](uint32_t, const std::array<glm::dvec3, 8>& corners, int count,
                                 double) { piece(corners, count); });
}

}  // namespace

constexpr double kNear = kProgressiveNear;
// Eq. 2's disc only for points farther than this many of their sizes, and Lambert's exact
// point-to-polygon form factor to the cluster's pieces nearer (from kNear on; nearer than kNear
// sizes a cluster is refined, or in flat mode its members take their own pieces). The disc's error
// falls with the square of size / distance: with discs from 3 sizes on, the furnace's worst element
// was 1.4% off, from 8 sizes on 0.81% (the flat scheme's), but discs alone needed refining down to
// 8 sizes, which at millions of elements costs hundreds of pairs per receiver.
constexpr double kFar = kProgressiveFar;
// Hierarchical mode: clusters coarser than the top level (up to the whole shooter) serve
// receivers farther than this many of their sizes (a small shooter far away shoots as one
// point).
constexpr double kCoarse = 20.0;
// Receivers gathered together: their pairs, rays and hits (about 12 pairs per receiver) fit in
// the L2 cache.
constexpr size_t kReceiverBlock = 256;

// Receivers shared out over the ranks of a distributed run (docs/scaling.md): chunks of whole
// receiver blocks dealt out in turn (chunk c to rank c mod size), about eight per rank, so each
// rank gets near and far, lit and shadowed parts of the scene alike. One process: one chunk.
class ReceiverShare {
 public:
  ReceiverShare(size_t n, Communicator* comm) : n_(n), comm_(comm) {
    const size_t ranks = comm ? size_t(comm->size()) : 1;
    const size_t per = (n + 8 * ranks - 1) / (8 * ranks);
    chunk_ = std::max(kReceiverBlock, (per + kReceiverBlock - 1) / kReceiverBlock * kReceiverBlock);
    if (ranks == 1) chunk_ = std::max<size_t>(n, 1);
  }
  size_t chunks() const { return (n_ + chunk_ - 1) / chunk_; }
  int ownerOf(size_t c) const { return comm_ ? int(c % size_t(comm_->size())) : 0; }
  bool mine(size_t c) const { return !comm_ || ownerOf(c) == comm_->rank(); }
  std::pair<size_t, size_t> range(size_t c) const {
    return {c * chunk_, std::min(n_, (c + 1) * chunk_)};
  }
  // body(begin, end) over this rank's receivers, in parallel within each chunk, in whole blocks
  // of kReceiverBlock from receiver 0 (chunks are whole blocks): a block's receivers are the
  // same whatever the threads and ranks, so what the gather decides per block (the penumbrae's
  // neighbours) is too.
  template <typename Body>
  void forMine(Body&& body) const {
    for (size_t c = 0; c < chunks(); ++c) {
      if (!mine(c)) continue;
      const auto chunk = range(c);
      const size_t b = chunk.first;  // a plain variable: lambdas may not capture bindings (C++17)
      const size_t e = chunk.second;
      const size_t blocks = (e - b + kReceiverBlock - 1) / kReceiverBlock;
      parallelRange(blocks, 1, [&](size_t i, size_t j) {
        body(b + i * kReceiverBlock, std::min(e, b + j * kReceiverBlock));
      });
    }
  }
  // Fills in the other ranks' receivers of `values` (one per receiver): every rank then has
  // every receiver's value, each computed once.
  template <typename T>
  void exchange(std::vector<T>& values) const {
    if (!comm_ || !comm_->distributed()) return;
    std::vector<T> packed;
    for (size_t c = 0; c < chunks(); ++c) {
      if (!mine(c)) continue;
      const auto [b, e] = range(c);
      packed.insert(packed.end(), values.begin() + std::ptrdiff_t(b),
                    values.begin() + std::ptrdiff_t(e));
    }
    std::vector<size_t> counts;
    const std::vector<T> all = allgatherValues<T>(*comm_, packed, &counts);
    size_t at = 0;
    for (int r = 0; r < comm_->size(); ++r) {
      for (size_t c = size_t(r); c < chunks(); c += size_t(comm_->size())) {
        const auto [b, e] = range(c);
        std::copy(all.begin() + std::ptrdiff_t(at), all.begin() + std::ptrdiff_t(at + e - b),
                  values.begin() + std::ptrdiff_t(b));
        at += e - b;
      }
    }
  }
  uint64_t sum(uint64_t mine) const {
    return comm_ && comm_->distributed() ? allreduceSum(*comm_, mine) : mine;
  }

 private:
  size_t n_ = 0;
  size_t chunk_ = 1;
  Communicator* comm_ = nullptr;
};

void ProgressiveRadiosity::elementPieces(size_t e, std::vector<std::array<glm::dvec3, 8>>& polygons,
                                         std::vector<int>& counts) const {
  surface_.atlas.elementPieces(e, surface_.flat.positions, surface_.flat.triangles, polygons,
                               counts);
}

double progressiveTexelDensity(const Scene& scene, uint32_t elements) {
  return texelDensityFor(scene, elements);
}

Expected<ProgressiveRadiosity> ProgressiveRadiosity::build(const Scene& scene,
                                                           const ProgressiveOptions& options) {
  if (options.max_iterations < 0) {
    return inputError("", "progressive radiosity", "max_iterations must not be negative");
  }
  if (!(options.convergence >= 0.0)) {
    return inputError("", "progressive radiosity", "convergence must be a fraction >= 0");
  }
  if (options.shooter_level < 0 || options.shooter_level > 16) {
    return inputError("", "progressive radiosity", "shooter_level must be in [0, 16]");
  }
  if (options.shooter_min_points < 0 || options.shooter_min_points > 4096) {
    return inputError("", "progressive radiosity", "shooter_min_points must be in [0, 4096]");
  }
  if (options.shooter_top_points < 0) {
    return inputError("", "progressive radiosity", "shooter_top_points must not be negative");
  }
  if (options.shooter_elements < 1) {
    return inputError("", "progressive radiosity", "shooter_elements must be at least 1");
  }
  if (options.probe_rays < 0 || options.probe_rays > (1 << 24)) {
    return inputError("", "progressive radiosity", "probe_rays must be in [0, 2^24]");
  }
  if (options.penumbra_rays < 1 || options.penumbra_rays > 1024) {
    return inputError("", "progressive radiosity", "penumbra_rays must be in [1, 1024]");
  }
  if (options.receiver_level < -1 || options.receiver_level > 16) {
    return inputError("", "progressive radiosity", "receiver_level must be in [0, 16] (or -1)");
  }
  if (options.adaptive) PENUMBRA_TRY(checkSubdivisionOptions(options.subdivision));
  Expected<RadiositySurface> surface =
      RadiositySurface::build(scene, options.atlas, options.shading_normals);
  if (!surface) return surface.error();
  return build(std::move(*surface), scene, options);
}

Expected<ProgressiveRadiosity> ProgressiveRadiosity::build(RadiositySurface surface,
                                                           const Scene& scene,
                                                           const ProgressiveOptions& options) {
  ProgressiveRadiosity pr;
  pr.options_ = options;
  pr.surface_ = std::move(surface);
  const size_t n = pr.surface_.elementCount();
  glm::dvec3 rho_area(0.0);
  for (size_t e = 0; e < n; ++e) {
    const double area = pr.surface_.atlas.element_area[e];
    rho_area += pr.surface_.reflectance[e] * area;
    pr.balance_.emitted += pr.surface_.emission[e] * area;
  }
  pr.lights_ = scene.lights;
  if (OutsideLight outside(scene); outside.active()) pr.outside_.emplace(std::move(outside));
  pr.lights_shot_ = pr.lights_.empty() && !pr.outside_;
  for (const Light& light : pr.lights_) pr.light_power_ += lightPower(light, pr.surface_.bounds);
  pr.balance_.emitted += pr.light_power_;
  if (residualLuminance(pr.balance_.emitted) <= 0.0 && !pr.outside_) {
    return noLightError(scene, "progressive radiosity");
  }
  // Shooters: chart roots, split down to at most shooter_elements elements.
  for (uint32_t c = 0; c < pr.surface_.hierarchy.chartCount(); ++c) {
    std::vector<ClusterRef> stack = {pr.surface_.hierarchy.root(c)};
    while (!stack.empty()) {
      const ClusterRef k = stack.back();
      stack.pop_back();
      if (pr.surface_.hierarchy.elementEnd(k) - pr.surface_.hierarchy.elementBegin(k) <=
              options.shooter_elements ||
          k.level == 0) {
        pr.shooters_.push_back(k);
        continue;
      }
      const std::vector<ClusterRef> children = pr.surface_.hierarchy.children(k);
      stack.insert(stack.end(), children.rbegin(), children.rend());
    }
  }
  std::sort(pr.shooters_.begin(), pr.shooters_.end(), [&](ClusterRef a, ClusterRef b) {
    return pr.surface_.hierarchy.elementBegin(a) < pr.surface_.hierarchy.elementBegin(b);
  });
  // Eq. 6, per channel.
  pr.ambient_factor_ = 1.0 / (1.0 - rho_area / pr.surface_.total_area);
  pr.b_ = pr.surface_.emission;
  pr.db_ = pr.surface_.emission;
  pr.shooter_power_.assign(pr.shooters_.size(), 0.0);
  pr.refreshShooterPowers();
  for (const double p : pr.shooter_power_) pr.emitter_power_ = std::max(pr.emitter_power_, p);
  pr.receiver_level_ = options.receiver_level >= 0 ? options.receiver_level
                       : options.adaptive          ? kAdaptiveReceiverLevel
                                                   : 0;
  pr.receivers_ = ProgressiveReceivers::uniform(pr.surface_, pr.receiver_level_);
  pr.subdivided_.assign(pr.shooters_.size() + 1, 0);
  pr.balance_.unshot = pr.balance_.emitted;
  return pr;
}

double ProgressiveRadiosity::residualPower(uint32_t shooter) const {
  PENUMBRA_CHECK(shooter < shooterCount());
  // The CPU twin of the paper's mipmap reduction over occupied texels, each weighted by its own
  // area (exact coverage).
  double sum = 0.0;
  for (uint32_t e = shooterBegin(shooter); e < shooterEnd(shooter); ++e) {
    sum += residualLuminance(db_[e]) * surface_.atlas.element_area[e];
  }
  return sum;
}

glm::dvec3 ProgressiveRadiosity::applyIncident(const glm::dvec3& scale, uint32_t first,
                                               uint32_t last) {
  // Update (progressive eq. 1), per shooter range in parallel: each range's elements in order,
  // its residual power (for the next selection) and its share of the energy books; the books
  // are then summed in order, so they do not depend on the threads. The shooter's own dB is
  // zeroed first (a curved chart lights itself).
  for (uint32_t e = first; e < last; ++e) db_[e] = glm::dvec3(0.0);
  struct Books {
    glm::dvec3 arrived{0.0}, absorbed{0.0}, reflected{0.0};
  };
  std::vector<Books> books(shooterCount());
  parallelRange(shooterCount(), 16, [&](size_t s_begin, size_t s_end) {
    for (size_t s = s_begin; s < s_end; ++s) {
      Books& k = books[s];
      for (uint32_t r = shooterBegin(uint32_t(s)); r < shooterEnd(uint32_t(s)); ++r) {
        if (incident_[r] == glm::dvec3(0.0)) continue;
        const glm::dvec3 in = incident_[r] * scale;
        const glm::dvec3 gain = surface_.reflectance[r] * in;
        b_[r] += gain;
        db_[r] += gain;
        // A cut-out intercepts its covered share; the rest goes on to what lies behind it.
        const double a = surface_.atlas.element_area[r] * surface_.coverageOf(r);
        k.arrived += in * a;
        k.absorbed += (glm::dvec3(surface_.coverageOf(r)) - surface_.reflectance[r]) * in *
                      surface_.atlas.element_area[r];
        k.reflected += gain * surface_.atlas.element_area[r];  // B is per element area
      }
      shooter_power_[s] = residualPower(uint32_t(s));
    }
  });
  glm::dvec3 arrived(0.0);
  for (const Books& k : books) {
    arrived += k.arrived;
    balance_.absorbed += k.absorbed;
    balance_.unshot += k.reflected;
  }
  return arrived;
}

glm::dvec3 ProgressiveRadiosity::closedScale(const glm::dvec3& shot) const {
  // The power the iteration's incident irradiance brings (summed per shooter range in parallel,
  // then in order), and per channel the factor that makes it the power shot.
  std::vector<glm::dvec3> part(shooterCount(), glm::dvec3(0.0));
  parallelRange(shooterCount(), 16, [&](size_t b, size_t e) {
    for (size_t s = b; s < e; ++s) {
      for (uint32_t r = shooterBegin(uint32_t(s)); r < shooterEnd(uint32_t(s)); ++r) {
        part[s] += incident_[r] * surface_.atlas.element_area[r] * surface_.coverageOf(r);
      }
    }
  });
  glm::dvec3 arrived(0.0);
  for (const glm::dvec3& p : part) arrived += p;
  glm::dvec3 scale(1.0);
  for (int c = 0; c < 3; ++c) {
    if (arrived[c] > 0.0) scale[c] = shot[c] / arrived[c];
  }
  return scale;
}

void ProgressiveRadiosity::refreshShooterPowers() {
  shooter_power_.resize(shooterCount());
  parallelRange(shooterCount(), 16, [&](size_t b, size_t e) {
    for (size_t s = b; s < e; ++s) shooter_power_[s] = residualPower(uint32_t(s));
  });
}

uint32_t ProgressiveRadiosity::selectShooter() const {
  if (!lights_shot_) return kLights;
  uint32_t best = kNoShooter;
  double best_power = 0.0;
  for (uint32_t s = 0; s < shooterCount(); ++s) {
    const double p = shooter_power_[s];  // residualPower(s), kept up to date by shoot()
    if (p > best_power) {
      best_power = p;
      best = s;
    }
  }
  return best;
}

std::vector<ClusterRef> ProgressiveRadiosity::shooterBlocks(uint32_t s, int level) const {
  PENUMBRA_CHECK(s < shooterCount());
  const ClusterRef root = shooters_[s];
  // The descendants at a level are one contiguous range of that level's clusters.
  uint32_t lo = root.index, hi = root.index + 1;
  uint32_t l = root.level;
  for (; l > uint32_t(std::max(level, 0)); --l) {
    const ClusterLevel& lv = surface_.hierarchy.level(l);
    lo = lv.child_first[lo];
    hi = lv.child_first[hi];
  }
  std::vector<ClusterRef> blocks;
  for (uint32_t k = lo; k < hi; ++k) blocks.push_back(ClusterRef{l, k});
  return blocks;
}

int ProgressiveRadiosity::flatLevel(uint32_t s) const {
  PENUMBRA_CHECK(s < shooterCount());
  int level = std::min(options_.shooter_level, int(shooters_[s].level));
  while (level > 0 && shooterBlocks(s, level).size() < size_t(options_.shooter_min_points)) {
    --level;
  }
  return level;
}

void ProgressiveRadiosity::clusterPieces(ClusterRef c,
                                         std::vector<std::array<glm::dvec3, 8>>& polygons,
                                         std::vector<int>& counts) const {
  polygons.clear();
  counts.clear();
  const ChartAtlas& atlas = surface_.atlas;
  std::vector<uint32_t> candidates;
  for (uint32_t e = surface_.hierarchy.elementBegin(c); e < surface_.hierarchy.elementEnd(c); ++e) {
    candidates.insert(candidates.end(), atlas.element_faces.begin() + atlas.element_face_first[e],
                      atlas.element_faces.begin() + atlas.element_face_first[e + 1]);
  }
  std::sort(candidates.begin(), candidates.end());
  candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
  clusterFacePieces(surface_, c, candidates,
                    [&](const std::array<glm::dvec3, 8>& corners, int count) {
                      polygons.push_back(corners);
                      counts.push_back(count);
                    });
}

bool ProgressiveRadiosity::shotClosed(uint32_t shooter, uint64_t* traced) const {
  const int count = options_.probe_rays;
  if (count == 0) return false;
  const size_t slot = shooter == kLights ? shooterCount() : size_t(shooter);
  PENUMBRA_CHECK(slot <= shooterCount());
  if (closed_.size() != shooterCount() + 1) closed_.assign(shooterCount() + 1, -1);
  if (closed_[slot] >= 0) return closed_[slot] != 0;
  closed_[slot] = 0;
  if (traced) *traced += uint64_t(count);
  // Cosine-distributed rays from points spread over the shooter by area (or from the lights,
  // lightProbeRay).
  if (shooter != kLights) {
    if (!surface_.seesOnlyElements(shooterBegin(shooter), shooterEnd(shooter), count, shooter)) {
      return false;
    }
  } else {
    Rng rng(0x5eedu, shooter);
    RayBatch rays;
    rays.resize(size_t(count));
    for (int i = 0; i < count; ++i) {
      Ray ray;
      if (!lightProbeRay(lights_, surface_.bounds, rng, ray)) return false;
      rays.set(size_t(i), ray);
    }
    if (!surface_.allHitElements(rays)) return false;
  }
  closed_[slot] = 1;
  return true;
}

template <typename Sample>
void ProgressiveRadiosity::subdivideFor(uint32_t slot, Sample&& sample, ProgressiveIteration& it) {
  if (!options_.adaptive || subdivided_[slot]) return;
  subdivided_[slot] = 1;
  const Timer timer;
  const size_t n = elementCount();
  std::vector<uint16_t> counted(n, 0), visible(n, 0);
  std::vector<float> share(n, 0.0f);
  std::atomic<uint64_t> rays{0};
  parallelRange(n, 1024, [&](size_t begin, size_t end) {
    uint64_t traced = 0;
    for (size_t e = begin; e < end; ++e) {
      if (!receivers_.samples(e, options_.subdivision.finest_level)) continue;
      // The sample's irradiance from the shooter (unoccluded) against what the element has
      // received so far (B / rho: its irradiance, as luminance).
      double shooter_e = 0.0;
      sample(e, counted[e], visible[e], shooter_e);
      traced += counted[e];
      share[e] = float(counted[e] * subdivisionShare(shooter_e, b_[e], surface_.emission[e],
                                                     surface_.reflectance[e]));
    }
    rays += traced;
  });
  it.refined = receivers_.subdivide(surface_, counted, visible, share, options_.subdivision);
  it.rays += rays.load();
  it.subdivision_seconds = timer.seconds();
}

double shooterDiscIrradiance(const glm::dvec3& residual, double area, const glm::dvec3& position,
                             const glm::dvec3& normal, const glm::dvec3& p, const glm::dvec3& n) {
  const glm::dvec3 d = position - p;
  const double d2 = glm::dot(d, d);
  if (!(d2 > 0.0)) return 0.0;
  const double inv = 1.0 / std::sqrt(d2);
  const double cos_r = std::max(glm::dot(n, d) * inv, 0.0),
               cos_s = std::max(-glm::dot(normal, d) * inv, 0.0);
  return residualLuminance(residual) * discFormFactor(area, cos_s, cos_r, d2);
}

double subdivisionShare(double shooter_irradiance, const glm::dvec3& radiosity,
                        const glm::dvec3& emission, const glm::dvec3& reflectance) {
  if (!(shooter_irradiance > 0.0)) return 0.0;
  const double rho = residualLuminance(reflectance);
  const double before =
      rho > 0.0 ? std::max(residualLuminance(radiosity - emission) / rho, 0.0) : 0.0;
  return shooter_irradiance / (before + shooter_irradiance);
}

namespace {

// The irradiance from `lights` at every receiver, each rank computing its share and then every
// rank holding all; adds the shadow rays this rank traced to `traced`.
std::vector<glm::dvec3> receiverIrradiance(const RadiositySurface& surface,
                                           const ProgressiveReceivers& receivers,
                                           std::span<const Light> lights, bool visibility,
                                           const ReceiverShare& share, uint64_t& traced) {
  std::vector<glm::dvec3> incident(receivers.size(), glm::dvec3(0.0));
  if (lights.empty()) return incident;
  for (size_t c = 0; c < share.chunks(); ++c) {
    if (!share.mine(c)) continue;
    const auto [b, e] = share.range(c);
    std::vector<glm::dvec3> positions(e - b), normals(e - b), shading(e - b);
    for (size_t k = b; k < e; ++k) {
      positions[k - b] = receivers.position(k);
      normals[k - b] = receivers.normal(k);
      shading[k - b] = receivers.shadingNormal(k);
    }
    const std::vector<glm::dvec3> got =
        surface.lightIrradianceAt(lights, visibility, positions, normals, shading, &traced);
    std::copy(got.begin(), got.end(), incident.begin() + std::ptrdiff_t(b));
  }
  share.exchange(incident);
  return incident;
}

}  // namespace

ProgressiveIteration ProgressiveRadiosity::shootLights() {
  const Timer timer;
  ProgressiveIteration it;
  it.iteration = ++iterations_;
  it.shooter = kLights;
  it.shooter_points = uint32_t(lights_.size());
  // Sec. 4 with the lights as the shooter: each sample counts once per light in front of it.
  subdivideFor(
      uint32_t(shooterCount()),
      [&](size_t e, uint16_t& counted, uint16_t& visible, double& irradiance) {
        const glm::dvec3 p = surface_.atlas.element_position[e],
                         ng = surface_.atlas.element_normal[e];
        double sum = 0.0;
        for (const Light& light : lights_) {
          const LightSample s = sampleLight(light, p, ng, surface_.shading_normal[e]);
          if (s.irradiance == glm::dvec3(0.0)) continue;
          ++counted;
          sum += residualLuminance(s.irradiance);
          if (!options_.visibility ||
              !surface_.engine.occluded(surface_.shadowRayToLight(s, p, ng)))
            ++visible;
        }
        irradiance = sum;
      },
      it);
  // Black elements that stop all light arriving take no part in the books of the sky, the
  // environment and the sun (absorbsOnArrival, radiosity/outside_light.h).
  const auto absorbs = [&](size_t e) { return absorbsOnArrival(surface_, e); };
  // A distant light (the sun) has no power of its own: the books take what it delivers to the
  // surfaces that take part instead of lightPower's pi r^2 E over the scene's bounding sphere,
  // most of which misses them. Its irradiance is gathered apart from the other lights' (the same
  // rays, once each) to be counted.
  std::vector<Light> local, distant;
  glm::dvec3 distant_nominal(0.0);
  for (const Light& light : lights_) {
    const bool far = std::holds_alternative<DirectionalLight>(light);
    (far ? distant : local).push_back(light);
    if (far) distant_nominal += lightPower(light, surface_.bounds);
  }
  // Each rank its chunks of receivers (one process: all of them), then every rank has all.
  const ReceiverShare share(receivers_.size(), comm_);
  uint64_t traced = 0;
  incident_ = receivers_.toElements(
      surface_,
      receiverIrradiance(surface_, receivers_, local, options_.visibility, share, traced));
  glm::dvec3 distant_delivered(0.0);
  if (!distant.empty()) {
    const std::vector<glm::dvec3> sun = receivers_.toElements(
        surface_,
        receiverIrradiance(surface_, receivers_, distant, options_.visibility, share, traced));
    for (size_t e = 0; e < sun.size(); ++e) {
      if (absorbs(e)) continue;
      incident_[e] += sun[e];
      distant_delivered += sun[e] * surface_.atlas.element_area[e] * surface_.coverageOf(e);
    }
    balance_.emitted += distant_delivered - distant_nominal;
    balance_.unshot += distant_delivered - distant_nominal;
  }
  traced = share.sum(traced);
  // The sky or the environment (radiosity/outside_light.h), element by element (the same on every
  // rank: each element has its own stream); what it brings to the surfaces that take part is
  // emitted now, as the sun's.
  glm::dvec3 outside_power(0.0);
  if (outside_) {
    const std::vector<glm::dvec3> outside = outside_->irradiance(surface_, &traced);
    for (size_t e = 0; e < outside.size(); ++e) incident_[e] += outside[e];
    outside_power = arrivingPower(surface_, outside);
    balance_.emitted += outside_power;
    balance_.unshot += outside_power;
  }
  uint64_t probes = 0;
  glm::dvec3 scale(1.0);
  it.closed = !outside_ && shotClosed(kLights, &probes);
  if (it.closed) scale = closedScale(light_power_);
  lights_shot_ = true;
  const glm::dvec3 shot = light_power_ - distant_nominal + distant_delivered + outside_power;
  const glm::dvec3 got = applyIncident(scale, 0, 0);
  balance_.unshot -= shot;
  balance_.escaped += shot - got;
  it.shot_power = residualLuminance(shot);
  it.unshot_fraction = unshotFraction();
  it.rays += traced + probes;
  it.seconds = timer.seconds();
  return it;
}

namespace {

// A convex polygon (up to eight corners) and its corner count.
using Piece = std::pair<std::array<glm::dvec3, 8>, int>;

// The shooter of one shot as its receivers see it: its points, where receivers start from, the
// points' pieces and the charts that receive nothing.
struct ShotGeometry {
  uint32_t first = 0, last = 0;  // the shooter's elements
  std::vector<ShooterPoint> points;
  // Points of level l: [level_first[l], level_end[l]) (the top level first in the list).
  std::vector<uint32_t> level_first, level_end;
  bool hierarchical = false;
  std::vector<uint32_t> roots;  // what receivers start from
  uint32_t top_level = 0;
  // Per cluster point (ShooterPoint::pieces): its pieces (hierarchical mode).
  std::vector<std::vector<Piece>> pieces;
  // The shooter's elements' own pieces: member_first[m - first] .. member_first[m - first + 1]
  // in member_polys.
  std::vector<uint32_t> member_first;
  std::vector<Piece> member_polys;
  std::vector<uint8_t> skip;  // per chart: receives nothing
  // Penumbrae (see the gather): rays per pair of a receiver whose rays disagree (1: none
  // traced), the shot's number (it seeds them), and for drawing their origins the shooter's
  // elements' residual power summed along their order (power_prefix[m - first]) and each member
  // polygon's area summed along member_polys.
  int penumbra_rays = 1;
  uint32_t iteration = 0;
  std::vector<double> power_prefix;
  std::vector<double> member_area_prefix;
};

// Shooter points (sec. 3): every cluster under the shooter, level by level from the shooter
// down to the elements (the descendants at each level are one contiguous range).
void findShooterPoints(ShotGeometry& shot, const RadiositySurface& surface,
                       const std::vector<glm::dvec3>& db, ClusterRef root) {
  std::vector<ShooterPoint>& points = shot.points;
  std::vector<uint32_t>&level_first = shot.level_first, &level_end = shot.level_end;
  level_first.assign(root.level + 1, 0);
  level_end.assign(root.level + 1, 0);
  std::vector<std::pair<uint32_t, uint32_t>> range(root.level + 1);
  range[root.level] = {root.index, root.index + 1};
  for (uint32_t l = root.level; l > 0; --l) {
    const ClusterLevel& lv = surface.hierarchy.level(l);
    range[l - 1] = {lv.child_first[range[l].first], lv.child_first[range[l].second]};
  }
  // Points from the top (index 0: the shooter) down.
  uint32_t count = 0;
  for (uint32_t l = root.level + 1; l-- > 0;) {
    level_first[l] = count;
    count += range[l].second - range[l].first;
    level_end[l] = count;
  }
  points.resize(count);
  // Level 0 first (elements), then each level from its children.
  for (uint32_t l = 0; l <= root.level; ++l) {
    const ClusterLevel& lv = surface.hierarchy.level(l);
    for (uint32_t k = range[l].first; k < range[l].second; ++k) {
      ShooterPoint& p = points[level_first[l] + (k - range[l].first)];
      p.cluster = ClusterRef{l, k};
      p.position = lv.position[k];
      p.area = lv.area[k];
      p.first = lv.first[k];
      p.last = lv.first[k + 1];
      if (l == 0) {
        p.element = k;
        p.residual = db[k];
        p.normal = surface.shading_normal[k];
        p.geometric = surface.atlas.element_normal[k];
        continue;
      }
      p.child_first = level_first[l - 1] + (lv.child_first[k] - range[l - 1].first);
      p.child_count = lv.child_first[k + 1] - lv.child_first[k];
      glm::dvec3 res(0.0), nrm(0.0), pos(0.0);
      double power = 0.0;
      for (uint32_t c = p.child_first; c < p.child_first + p.child_count; ++c) {
        res += points[c].residual * points[c].area;
        nrm += points[c].normal * points[c].area;
        const double w = residualLuminance(points[c].residual) * points[c].area;
        pos += points[c].position * w;
        power += w;
      }
      // The point shoots from its power's centroid: a cluster whose elements are partly
      // unlit (the floor under a box) would otherwise shoot its power from a point in the dark
      // part, and its shadow rays would lose it all (the Cornell box's tall box was 7% dark).
      if (power > 0.0) p.position = pos / power;
      p.residual = p.area > 0.0 ? res / p.area : glm::dvec3(0.0);
      const double len = glm::length(nrm);
      p.normal = len > 0.0 ? nrm / len : lv.normal[k];
      p.geometric = lv.normal[k];
    }
  }
}

// Where receivers start from, hierarchical or flat (from `flat_level`); returns the shot's
// points (the top level's, or the flat level's).
uint32_t chooseRoots(ShotGeometry& shot, const ProgressiveOptions& options, uint32_t root_level,
                     uint32_t flat_level) {
  shot.hierarchical = options.shooter_top_points > 0;
  if (shot.hierarchical) {
    // The top: the finest level with at most shooter_top_points clusters; coarser ones are
    // above it.
    uint32_t& top_level = shot.top_level;
    while (top_level < root_level && shot.level_end[top_level] - shot.level_first[top_level] >
                                         uint32_t(options.shooter_top_points)) {
      ++top_level;
    }
    for (uint32_t l = top_level + 1; l <= root_level; ++l) {
      for (uint32_t k = shot.level_first[l]; k < shot.level_end[l]; ++k) {
        shot.points[k].above_top = true;
      }
    }
    shot.roots = {0};  // the shooter itself (index 0: the top of the list)
    return shot.level_end[top_level] - shot.level_first[top_level];
  }
  const uint32_t l = std::min(flat_level, root_level);
  for (uint32_t k = shot.level_first[l]; k < shot.level_end[l]; ++k) shot.roots.push_back(k);
  return uint32_t(shot.roots.size());
}

// The points sec. 4's samples pair with: the top level's points, or the flat level's.
std::vector<uint32_t> samplePoints(const ShotGeometry& shot) {
  std::vector<uint32_t> sample_points;
  if (shot.hierarchical) {
    for (uint32_t k = shot.level_first[shot.top_level]; k < shot.level_end[shot.top_level]; ++k) {
      sample_points.push_back(k);
    }
  } else {
    sample_points = shot.roots;
  }
  return sample_points;
}

// Sec. 4: element e's sample against the shooter point s: counted when they face each other,
// with the whole shooter's disc irradiance, and visible when no face is between them.
void shooterSample(const ShotGeometry& shot, const ShooterPoint& s, const RadiositySurface& surface,
                   bool visibility, size_t e, uint16_t& counted, uint16_t& visible,
                   double& irradiance) {
  const glm::dvec3 pe = surface.atlas.element_position[e], ne = surface.atlas.element_normal[e];
  const glm::dvec3 d = s.position - pe;
  if (s.residual == glm::dvec3(0.0) || glm::dot(ne, d) <= 0.0 || glm::dot(s.geometric, d) >= 0.0) {
    return;
  }
  counted = 1;
  const ShooterPoint& whole = shot.points[0];
  irradiance =
      shooterDiscIrradiance(whole.residual, whole.area, whole.position, whole.normal, pe, ne);
  const glm::dvec3 from = pe + ne * surface.lift, to = s.position + s.geometric * surface.lift;
  if (!visibility ||
      !surface.engine.occluded(Ray{glm::vec3(from), 1e-4f, glm::vec3(to - from), 1.0f - 1e-4f})) {
    visible = 1;
  }
}

// The pieces of the clusters of levels [lo_level, root_level] (lo_level >= 1), for Lambert's
// form factor to a cluster: its chart's faces clipped to its texels; candidate faces merged up
// from the elements.
void findClusterPieces(ShotGeometry& shot, const RadiositySurface& surface, uint32_t lo_level,
                       uint32_t root_level) {
  std::vector<ShooterPoint>& points = shot.points;
  std::vector<std::vector<uint32_t>> candidates(points.size());
  for (uint32_t l = 0; l <= root_level; ++l) {
    for (uint32_t k = shot.level_first[l]; k < shot.level_end[l]; ++k) {
      std::vector<uint32_t>& c = candidates[k];
      if (l == 0) {
        const uint32_t e = points[k].element;
        c.assign(surface.atlas.element_faces.begin() + surface.atlas.element_face_first[e],
                 surface.atlas.element_faces.begin() + surface.atlas.element_face_first[e + 1]);
        std::sort(c.begin(), c.end());
        continue;
      }
      for (uint32_t ch = points[k].child_first; ch < points[k].child_first + points[k].child_count;
           ++ch) {
        c.insert(c.end(), candidates[ch].begin(), candidates[ch].end());
      }
      std::sort(c.begin(), c.end());
      c.erase(std::unique(c.begin(), c.end()), c.end());
    }
  }
  std::vector<uint32_t> clusters;
  for (uint32_t l = std::max(lo_level, 1u); l <= root_level; ++l) {
    for (uint32_t k = shot.level_first[l]; k < shot.level_end[l]; ++k) clusters.push_back(k);
  }
  shot.pieces.resize(clusters.size());
  parallelRange(clusters.size(), 64, [&](size_t b, size_t e) {
    for (size_t i = b; i < e; ++i) {
      ShooterPoint& p = points[clusters[i]];
      p.pieces = int32_t(i);
      clusterFacePieces(surface, p.cluster, candidates[clusters[i]],
                        [&](const std::array<glm::dvec3, 8>& corners, int count) {
                          shot.pieces[i].emplace_back(corners, count);
                        });
    }
  });
}

// The shooter's elements' own pieces (near pairs take Lambert's form factor to them), once
// per shot.
void findMemberPieces(ShotGeometry& shot, const ProgressiveRadiosity& solver) {
  const uint32_t first = shot.first, last = shot.last;
  shot.member_first.assign(last - first + 1, 0);
  std::vector<std::vector<Piece>> per(last - first);
  parallelRange(last - first, 256, [&](size_t b, size_t e) {
    std::vector<std::array<glm::dvec3, 8>> polys;
    std::vector<int> counts;
    for (size_t i = b; i < e; ++i) {
      solver.elementPieces(first + i, polys, counts);
      for (size_t q = 0; q < polys.size(); ++q) {
        if (counts[q] >= 3) per[i].emplace_back(polys[q], counts[q]);
      }
    }
  });
  for (size_t i = 0; i < per.size(); ++i) {
    shot.member_polys.insert(shot.member_polys.end(), per[i].begin(), per[i].end());
    shot.member_first[i + 1] = uint32_t(shot.member_polys.size());
  }
}

double polygonArea(const Piece& piece) {
  double twice = 0.0;
  for (int k = 1; k + 1 < piece.second; ++k) twice += fanTriangleArea2(piece.first.data(), k);
  return 0.5 * twice;
}

// What penumbra rays draw their origins from: the shooter's elements' residual power and their
// pieces' areas, summed along their orders.
void preparePenumbraSampling(ShotGeometry& shot, const std::vector<glm::dvec3>& db,
                             const std::vector<double>& element_area) {
  shot.power_prefix.assign(shot.last - shot.first + 1, 0.0);
  for (uint32_t m = shot.first; m < shot.last; ++m) {
    shot.power_prefix[m - shot.first + 1] =
        shot.power_prefix[m - shot.first] + residualLuminance(db[m]) * element_area[m];
  }
  shot.member_area_prefix.assign(shot.member_polys.size() + 1, 0.0);
  for (size_t q = 0; q < shot.member_polys.size(); ++q) {
    shot.member_area_prefix[q + 1] = shot.member_area_prefix[q] + polygonArea(shot.member_polys[q]);
  }
}

// The origin of penumbra ray j of n from point s (its face normal in *normal): stratum j of a
// weight summed along its elements' order picks the element (prefix[m] for element m, over
// [s.first, s.last]: the residual power, or a near pair's members' shares of the irradiance),
// and hashed numbers a point of the element's pieces uniform by area (a fan triangle by area,
// then Heitz's map). False when the weights are all 0 or the element has no pieces.
bool penumbraOrigin(const ShotGeometry& shot, const ShooterPoint& s, const double* prefix,
                    uint64_t key, int j, int n, const RadiositySurface& surface, glm::dvec3& origin,
                    glm::dvec3& normal) {
  const uint64_t h1 = mixBits(key + uint64_t(j) * 0x9e3779b97f4a7c15ULL), h2 = mixBits(h1);
  const auto unit = [](uint64_t bits) { return double(bits & 0xffffff) * 0x1p-24; };
  const double u0 = (double(j) + unit(h1 >> 40)) / double(n);
  const double u1 = unit(h1 >> 16), u2 = unit(h2 >> 40), u3 = unit(h2 >> 16);
  const double lo = prefix[s.first], hi = prefix[s.last];
  if (!(hi > lo)) return false;
  const double t = lo + u0 * (hi - lo);
  // The element m with prefix[m] <= t < prefix[m + 1] (skipping elements of no weight).
  const double* at = std::upper_bound(prefix + s.first + 1, prefix + s.last + 1, t);
  uint32_t m = uint32_t(std::min<ptrdiff_t>(at - prefix, s.last)) - 1;
  while (m + 1 < s.last && !(prefix[m + 1] > prefix[m])) ++m;
  const uint32_t q0 = shot.member_first[m - shot.first], q1 = shot.member_first[m - shot.first + 1];
  if (q0 == q1) return false;
  // A fan triangle of the element's pieces by area.
  const double a0 = shot.member_area_prefix[q0], a1 = shot.member_area_prefix[q1];
  double ta = a0 + u1 * (a1 - a0);
  uint32_t q = q0;
  while (q + 1 < q1 && shot.member_area_prefix[q + 1] <= ta) ++q;
  const auto& [c, count] = shot.member_polys[q];
  origin =
      pointOnFan(c.data(), count, 2.0 * (ta - shot.member_area_prefix[q]), float(u2), float(u3));
  normal = surface.atlas.element_normal[m];
  return true;
}

// Planar charts wholly behind or level with the shooter's bounding sphere receive nothing (the
// outsides of a room's walls, the back of a panel): skipped before visiting their elements.
void findSkippedCharts(ShotGeometry& shot, const RadiositySurface& surface, ClusterRef root) {
  std::vector<uint8_t>& skip = shot.skip;
  skip.assign(surface.atlas.chartCount(), 0);
  glm::dvec3 centre = shot.points[0].position;
  double radius = 0.0;
  for (uint32_t e = shot.first; e < shot.last; ++e) {
    radius = std::max(radius, glm::length(surface.atlas.element_position[e] - centre));
  }
  for (size_t c = 0; c < surface.atlas.chartCount(); ++c) {
    const Chart& chart = surface.atlas.charts.charts[c];
    const AtlasChartPlacement& pl = surface.atlas.placement[c];
    if (!chart.planar || pl.element_count == 0) continue;
    const glm::dvec3 p0 = surface.atlas.element_position[pl.first_element];
    // Planar charts lie within 1 degree of their normal: a margin of that over the sphere.
    const double margin = radius + 0.02 * glm::length(centre - p0);
    if (glm::dot(chart.normal, centre - p0) <= -margin) skip[c] = 1;
  }
  // A planar chart does not light itself: its points see its other faces edge-on (the
  // Cornell box's walls bend by half a degree), where a receiver's point a hair behind a
  // neighbouring face would see that face fill half its hemisphere.
  const uint32_t own = surface.hierarchy.level(root.level).chart[root.index];
  if (surface.atlas.charts.charts[own].planar) skip[own] = 1;
}

enum class Kernel : uint8_t {
  kDisc,     // eq. 2 with the point's area, position and mean residual
  kPolygon,  // Lambert's point-to-polygon form factor to a cluster's pieces, mean residual
  kMembers,  // the same to each member element's own pieces, with its own residual
};
struct Pair {
  uint32_t receiver;
  uint32_t point;
  Kernel kernel;
};

// Receiver r's pairs, from the roots down (see the gather's comment in shoot()).
void receiverPairs(const ShotGeometry& shot, const ProgressiveReceivers& receivers, size_t r,
                   std::vector<uint32_t>& stack, std::vector<Pair>& pairs) {
  const std::vector<ShooterPoint>& points = shot.points;
  const glm::dvec3 nr = receivers.normal(r), pr = receivers.position(r);
  stack.assign(shot.roots.rbegin(), shot.roots.rend());
  while (!stack.empty()) {
    const uint32_t k = stack.back();
    stack.pop_back();
    const ShooterPoint& s = points[k];
    if (s.residual == glm::dvec3(0.0)) continue;
    const glm::dvec3 d = s.position - pr;
    const double d2 = glm::dot(d, d);
    const bool near = d2 < kNear * kNear * s.area;
    // Clusters above the top level stand for their children only for receivers farther
    // than kCoarse of their sizes: to those the whole cluster subtends a few degrees at
    // most, so one visibility ray loses no penumbra worth resolving.
    if (shot.hierarchical && s.child_count > 0 &&
        (near || (s.above_top && d2 < kCoarse * kCoarse * s.area))) {
      for (uint32_t c = s.child_first + s.child_count; c-- > s.child_first;) {
        stack.push_back(c);
      }
      continue;
    }
    if (d2 <= 0.0) continue;
    // Culled by either plane (the faces' own normals).
    if (glm::dot(nr, d) <= 0.0 || glm::dot(s.geometric, d) >= 0.0) continue;
    Kernel kernel = near ? Kernel::kMembers : Kernel::kDisc;
    // Between kNear and kFar sizes: Lambert's form factor to the cluster's pieces (an element's
    // are its own: kMembers).
    if ((shot.hierarchical || !near) && d2 < kFar * kFar * s.area) {
      kernel = s.child_count == 0 ? Kernel::kMembers : Kernel::kPolygon;
    }
    pairs.push_back(Pair{uint32_t(r), k, kernel});
  }
}

// One shadow ray per pair, sorted by point so that the rays from neighbouring texels to one
// point travel as packets of eight; occluded[k] for pair k.
void traceShadowRays(const ShotGeometry& shot, const RadiositySurface& surface,
                     const ProgressiveReceivers& receivers, const std::vector<Pair>& pairs,
                     std::vector<uint64_t>& order, RayBatch& batch, HitBatch& hits,
                     std::vector<uint8_t>& occluded) {
  order.resize(pairs.size());
  for (size_t k = 0; k < pairs.size(); ++k) order[k] = uint64_t(pairs[k].point) << 32 | k;
  std::sort(order.begin(), order.end());
  batch.resize(pairs.size());
  const bool jitter = surface.textures && surface.textures->hasCutouts();
  for (size_t k = 0; k < pairs.size(); ++k) {
    const Pair& pair = pairs[uint32_t(order[k])];
    const ShooterPoint& s = shot.points[pair.point];
    const glm::dvec3 from =
        receivers.position(pair.receiver) + receivers.normal(pair.receiver) * surface.lift;
    glm::dvec3 to = s.position + s.geometric * surface.lift;
    glm::dvec3 origin, normal;
    if (shot.penumbra_rays > 1 &&
        penumbraOrigin(shot, s, shot.power_prefix.data() - shot.first,
                       ~mixBits(uint64_t(pair.receiver) << 32 | pair.point) ^ shot.iteration, 0, 1,
                       surface, origin, normal)) {
      // A shot that refines penumbrae finds them from random points of each point's power:
      // from the points' centres, a receiver whose rays all pass or all stop could still see
      // part of the shooter (the fringes of the penumbra, outside the centres' shadows).
      to = origin + normal * surface.lift;
    } else if (jitter) {
      to += cutoutJitter(s.geometric, s.area, uint64_t(pair.receiver) << 32 | pair.point);
    }
    batch.set(k, Ray{glm::vec3(from), 1e-4f, glm::vec3(to - from), 1.0f - 1e-4f});
  }
  surface.engine.intersectSerial(batch, hits);
  occluded.assign(pairs.size(), 0);
  for (size_t k = 0; k < pairs.size(); ++k) occluded[uint32_t(order[k])] = hits.triangle[k] >= 0;
}

// Penumbrae: the pairs of every receiver whose shadow rays disagree trace shot.penumbra_rays rays
// each, from points of their point's residual power; visible[k] is pair k's visible fraction
// (1 or 0 from its one ray elsewhere). Returns the rays traced.
uint64_t refinePenumbrae(const ShotGeometry& shot, const RadiositySurface& surface,
                         const ProgressiveReceivers& receivers, const std::vector<glm::dvec3>& db,
                         const std::vector<Pair>& pairs, const std::vector<uint64_t>& order,
                         const std::vector<uint8_t>& occluded, RayBatch& batch, HitBatch& hits,
                         std::vector<float>& visible) {
  visible.resize(pairs.size());
  for (size_t k = 0; k < pairs.size(); ++k) visible[k] = occluded[k] ? 0.0f : 1.0f;
  const int n = shot.penumbra_rays;
  if (n <= 1) return 0;
  // A receiver's pairs are consecutive: mark those of receivers with a hidden pair (in a
  // penumbra, or in an umbra whose edge may still see a strip of the shooter). Behind a cut-out
  // every receiver is refined: a lattice's holes can line up with the points' grid, and a
  // receiver whose 16 rays all pass sees only part of the shooter (26-35% too bright on the
  // textured room's floor under the lattice).
  // The receivers next to a marked one (its texel's eight neighbours in the atlas, within the
  // block) are marked too: a receiver on the penumbra's outer fringe may have all its rays pass
  // and still miss a strip of the shooter (the closed form's fringe was 20% bright).
  const bool all = surface.textures && surface.textures->hasCutouts();
  const size_t first = pairs.front().receiver, span = pairs.back().receiver - first + 1;
  std::vector<uint8_t> hidden_at(span, 0), marked(span, 0);
  for (size_t k = 0; k < pairs.size(); ++k) hidden_at[pairs[k].receiver - first] |= occluded[k];
  const ChartAtlas& atlas = surface.atlas;
  for (size_t r = 0; r < span; ++r) {
    if (!hidden_at[r]) continue;
    marked[r] = 1;
    const glm::ivec2 t = atlas.texelOf(receivers.texelElement(first + r));
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const int x = t.x + dx, y = t.y + dy;
        if (x < 0 || y < 0 || x >= atlas.width || y >= atlas.height) continue;
        const int32_t e = atlas.texel_element[atlas.texelIndex(x, y)];
        if (e < 0) continue;
        const size_t o = receivers.owner(size_t(e));
        if (o >= first && o < first + span) marked[o - first] = 1;
      }
    }
  }
  std::vector<uint8_t> refine(pairs.size(), 0);
  size_t refined = 0;
  for (size_t k = 0; k < pairs.size(); ++k) {
    if (all || marked[pairs[k].receiver - first]) refine[k] = 1, ++refined;
  }
  if (refined == 0) return 0;
  // By point (the order of the first rays), n rays a pair.
  std::vector<uint32_t> which;
  which.reserve(refined);
  for (const uint64_t o : order) {
    if (refine[uint32_t(o)]) which.push_back(uint32_t(o));
  }
  batch.resize(which.size() * size_t(n));
  std::vector<uint8_t> drawn(batch.size(), 0);
  std::vector<double> members;  // a near pair's members' shares, summed
  for (size_t w = 0; w < which.size(); ++w) {
    const Pair& pair = pairs[which[w]];
    const ShooterPoint& s = shot.points[pair.point];
    const glm::dvec3 pr = receivers.position(pair.receiver);
    const glm::dvec3 from = pr + receivers.normal(pair.receiver) * surface.lift;
    const uint64_t key = mixBits(uint64_t(pair.receiver) << 32 | pair.point) ^ shot.iteration;
    // A near pair's members each bring their own form factor (addPair's kMembers): the rays
    // leave them by their shares of the pair's irradiance, so that the visible fraction weighs
    // each member as the irradiance does (by power alone, the members nearest the receiver were
    // undersampled: a floor block half under the Cornell box lit the box 4% less than its
    // elements did).
    const double* prefix = shot.power_prefix.data() - shot.first;
    if (pair.kernel == Kernel::kMembers && s.last - s.first > 1) {
      const glm::dvec3 nr = receivers.shadingNormal(pair.receiver);
      members.assign(s.last - s.first + 1, 0.0);
      for (uint32_t m = s.first; m < s.last; ++m) {
        double f = 0.0;
        if (db[m] != glm::dvec3(0.0)) {
          for (uint32_t q = shot.member_first[m - shot.first];
               q < shot.member_first[m - shot.first + 1]; ++q) {
            f += pointToPolygonFormFactor<true>(pr, nr, shot.member_polys[q].first.data(),
                                                shot.member_polys[q].second);
          }
        }
        members[m - s.first + 1] = members[m - s.first] + residualLuminance(db[m]) * f;
      }
      prefix = members.data() - s.first;
    }
    for (int j = 0; j < n; ++j) {
      const size_t k = w * size_t(n) + size_t(j);
      glm::dvec3 origin, normal;
      if (penumbraOrigin(shot, s, prefix, key, j, n, surface, origin, normal)) {
        const glm::dvec3 to = origin + normal * surface.lift;
        batch.set(k, Ray{glm::vec3(from), 1e-4f, glm::vec3(to - from), 1.0f - 1e-4f});
        drawn[k] = 1;
      } else {
        batch.set(k, Ray{glm::vec3(from), 1e-4f, glm::vec3(0.0f, 0.0f, 1.0f), 0.0f});
      }
    }
  }
  surface.engine.intersectSerial(batch, hits);
  for (size_t w = 0; w < which.size(); ++w) {
    int seen = 0, tried = 0;
    for (int j = 0; j < n; ++j) {
      const size_t k = w * size_t(n) + size_t(j);
      if (!drawn[k]) continue;
      ++tried;
      seen += hits.triangle[k] < 0;
    }
    if (tried > 0) visible[which[w]] = float(seen) / float(tried);
  }
  return batch.size();
}

// Adds a pair's irradiance at the receiver (point pr, shading normal nr) to `incident`.
void addPair(const ShotGeometry& shot, const std::vector<glm::dvec3>& db, const Pair& pair,
             const glm::dvec3& pr, const glm::dvec3& nr, glm::dvec3& incident) {
  const ShooterPoint& s = shot.points[pair.point];
  if (pair.kernel == Kernel::kPolygon) {
    double f = 0.0;
    for (const auto& [poly, count] : shot.pieces[size_t(s.pieces)]) {
      if (count >= 3) f += pointToPolygonFormFactor<true>(pr, nr, poly.data(), count);
    }
    incident += s.residual * f;
    return;
  }
  if (pair.kernel == Kernel::kMembers) {
    // Near pairs (across an edge, in a corner): eq. 2's disc is a poor stand-in for a
    // neighbour seen edge-on, so each of the point's elements contributes Lambert's exact
    // point-to-polygon form factor (kernels/form_factor.h) to its own pieces.
    for (uint32_t m = s.first; m < s.last; ++m) {
      if (db[m] == glm::dvec3(0.0)) continue;
      double f = 0.0;
      for (uint32_t q = shot.member_first[m - shot.first];
           q < shot.member_first[m - shot.first + 1]; ++q) {
        f += pointToPolygonFormFactor<true>(pr, nr, shot.member_polys[q].first.data(),
                                            shot.member_polys[q].second);
      }
      incident += db[m] * f;
    }
    return;
  }
  const glm::dvec3 d = s.position - pr;
  const double d2 = glm::dot(d, d);
  const double inv = 1.0 / std::sqrt(d2);
  const double cos_r = glm::dot(nr, d) * inv, cos_s = -glm::dot(s.normal, d) * inv;
  if (cos_r <= 0.0 || cos_s <= 0.0) return;
  incident += s.residual * discFormFactor(s.area, cos_s, cos_r, d2);
}

// The gather of shoot() at the receivers [begin, end), block by block: each block's pairs, their
// shadow rays, then each pair's irradiance added in order.
void gatherReceivers(const ShotGeometry& shot, const RadiositySurface& surface,
                     const ProgressiveReceivers& receivers, const std::vector<glm::dvec3>& db,
                     bool visibility, size_t begin, size_t end, std::vector<glm::dvec3>& incident,
                     std::atomic<uint64_t>& rays) {
  std::vector<Pair> pairs;
  std::vector<uint32_t> stack;
  std::vector<uint64_t> order;  // (point, pair index): sorted, the pairs by point, stably
  std::vector<uint8_t> occluded;
  std::vector<float> visible;
  RayBatch batch;
  HitBatch hits;
  for (size_t block = begin; block < end; block += kReceiverBlock) {
    pairs.clear();
    for (size_t r = block; r < std::min(end, block + kReceiverBlock); ++r) {
      if (shot.skip[receivers.chart(r)]) continue;
      receiverPairs(shot, receivers, r, stack, pairs);
    }
    if (visibility && !pairs.empty()) {
      traceShadowRays(shot, surface, receivers, pairs, order, batch, hits, occluded);
      rays += pairs.size();
      rays += refinePenumbrae(shot, surface, receivers, db, pairs, order, occluded, batch, hits,
                              visible);
    }
    for (size_t k = 0; k < pairs.size(); ++k) {
      const float v = visibility ? visible[k] : 1.0f;
      if (v <= 0.0f) continue;
      const size_t r = pairs[k].receiver;
      // Form factors take the shading normals; culling and shadow rays the faces' own.
      glm::dvec3 got(0.0);
      addPair(shot, db, pairs[k], receivers.position(r), receivers.shadingNormal(r), got);
      incident[r] += got * double(v);
    }
  }
}

}  // namespace

ProgressiveIteration ProgressiveRadiosity::shoot(uint32_t shooter) {
  if (shooter == kLights) return shootLights();
  PENUMBRA_CHECK(shooter < shooterCount());
  const Timer timer;
  ProgressiveIteration it;
  it.iteration = ++iterations_;
  it.shooter = shooter;
  const uint32_t first = shooterBegin(shooter), last = shooterEnd(shooter);
  const ClusterRef root = shooters_[shooter];
  ShotGeometry geometry;
  geometry.first = first;
  geometry.last = last;

  // ---- Shooter points (sec. 3) and where receivers start from ----
  findShooterPoints(geometry, surface_, db_, root);
  it.shooter_points = chooseRoots(geometry, options_, root.level, uint32_t(flatLevel(shooter)));

  // ---- Adaptive subdivision ----
  // Sec. 4 before the shooter's first shot: element e's sample is the pair of it and the
  // shooting point e mod P (the top level's points, or the flat level's), so that the samples of
  // a block spread over the whole shooter and a penumbra counts as a boundary too.
  const std::vector<uint32_t> sample_points = samplePoints(geometry);
  subdivideFor(
      shooter,
      [&](size_t e, uint16_t& counted, uint16_t& visible, double& irradiance) {
        const ShooterPoint& s = geometry.points[sample_points[e % sample_points.size()]];
        shooterSample(geometry, s, surface_, options_.visibility, e, counted, visible, irradiance);
      },
      it);

  // ---- The points' pieces, the power shot and the charts that receive nothing ----
  // Hierarchical: every cluster may serve a receiver; flat: the roots' level only.
  const uint32_t pieces_from =
      geometry.hierarchical ? 1u : std::min(uint32_t(flatLevel(shooter)), root.level);
  if (pieces_from > 0) findClusterPieces(geometry, surface_, pieces_from, root.level);
  findMemberPieces(geometry, *this);
  glm::dvec3 shot(0.0);
  for (uint32_t e = first; e < last; ++e) shot += db_[e] * surface_.atlas.element_area[e];
  // Penumbra rays in proportion to the shot's power over the brightest emitter's (see the
  // file comment).
  if (options_.penumbra_rays > 1 && emitter_power_ > 0.0) {
    const double share = std::min(1.0, residualLuminance(shot) / emitter_power_);
    geometry.penumbra_rays = int(std::ceil(double(options_.penumbra_rays) * share - 1e-9));
    geometry.iteration = uint32_t(iterations_);
    if (geometry.penumbra_rays > 1)
      preparePenumbraSampling(geometry, db_, surface_.atlas.element_area);
  }
  findSkippedCharts(geometry, surface_, root);

  // ---- Gather ----
  // Gather at every receiver (an element, or a cluster standing for its elements: sec. 4) the
  // irradiance sum_s dB_s F_rs (W m^-2); in parallel over
  // chunks of receivers, each writing only its own entries. A receiver's pairs come from the
  // roots: a point farther than kNear of its sizes is one pair; a nearer one descends to its
  // children (hierarchical mode) or, at the elements or in flat mode, is a near pair whose
  // members each contribute Lambert's exact point-to-polygon form factor. Each pair has one
  // shadow ray; a chunk's rays are traced together, sorted by point, so the rays from
  // neighbouring texels to one point travel as packets of eight. Each receiver sums its pairs
  // in a fixed order, so the result does not depend on the chunking.
  const size_t n = receivers_.size();
  std::vector<glm::dvec3> incident(n, glm::dvec3(0.0));
  std::atomic<uint64_t> rays{0};
  // Each rank gathers at its chunks of receivers (one process: all of them); then every rank has
  // every receiver's irradiance, and the rest of the shot runs alike on all.
  const ReceiverShare share(n, comm_);
  share.forMine([&](size_t begin, size_t end) {
    gatherReceivers(geometry, surface_, receivers_, db_, options_.visibility, begin, end, incident,
                    rays);
  });

  share.exchange(incident);
  incident_ = receivers_.toElements(surface_, std::move(incident));

  // ---- Update ----
  // Closed shot: the power arriving equals the power shot (the form factors' sum rule).
  uint64_t probes = 0;
  glm::dvec3 scale(1.0);
  it.closed = shotClosed(shooter, &probes);
  if (it.closed) scale = closedScale(shot);

  const glm::dvec3 arrived = applyIncident(scale, first, last);
  balance_.unshot -= shot;
  balance_.escaped += shot - arrived;

  it.shot_power = residualLuminance(shot);
  it.unshot_fraction = unshotFraction();
  it.rays += share.sum(rays.load()) + probes;
  it.seconds = timer.seconds();
  return it;
}

ProgressiveIteration ProgressiveRadiosity::step() {
  const uint32_t s = selectShooter();
  if (s == kNoShooter) return ProgressiveIteration{};
  return shoot(s);
}

ProgressiveStats ProgressiveRadiosity::solve(
    const std::function<void(const ProgressiveIteration&)>& after_iteration,
    const std::function<bool()>& stop) {
  // The CPU's steps cannot fail.
  return *solveProgressively(
      options_, unshotFraction(), [&] { return Expected<ProgressiveIteration>(step()); },
      [&] { return Expected<bool>(selectShooter() == kNoShooter); }, [&] { return iterations_; },
      after_iteration, stop);
}

Status ProgressiveRadiosity::setShooterLevel(int level) {
  if (level < 0 || level > 16) {
    return inputError("", "progressive radiosity", "shooter_level must be in [0, 16]");
  }
  options_.shooter_level = level;
  return {};
}

ProgressiveState ProgressiveRadiosity::state() const {
  ProgressiveState state{b_, db_, balance_, iterations_, lights_shot_};
  state.receiver_levels = receivers_.elementLevels();
  state.subdivided = subdivided_;
  return state;
}

Status ProgressiveRadiosity::setState(ProgressiveState state) {
  if (state.radiosity.size() != elementCount() || state.residual.size() != elementCount()) {
    return inputError("", "progressive radiosity",
                      fmt::format("the state has {} elements, the solver {}",
                                  state.radiosity.size(), elementCount()));
  }
  if (state.iterations < 0) return inputError("", "progressive radiosity", "negative iterations");
  for (size_t e = 0; e < elementCount(); ++e) {
    const glm::dvec3 &b = state.radiosity[e], &db = state.residual[e];
    for (int c = 0; c < 3; ++c) {
      if (!std::isfinite(b[c]) || !std::isfinite(db[c]) || b[c] < 0.0 || db[c] < 0.0) {
        return inputError("", "progressive radiosity",
                          fmt::format("element {}: radiosity must be finite and >= 0", e));
      }
    }
  }
  if (!state.subdivided.empty() && state.subdivided.size() != subdivided_.size()) {
    return inputError("", "progressive radiosity",
                      fmt::format("the state has {} subdivision flags, the solver {}",
                                  state.subdivided.size(), subdivided_.size()));
  }
  if (!state.receiver_levels.empty()) {
    Expected<ProgressiveReceivers> receivers =
        ProgressiveReceivers::fromElementLevels(surface_, state.receiver_levels);
    if (!receivers) return receivers.error();
    receivers_ = std::move(*receivers);
  }
  if (!state.subdivided.empty()) subdivided_ = std::move(state.subdivided);
  b_ = std::move(state.radiosity);
  db_ = std::move(state.residual);
  refreshShooterPowers();
  balance_ = state.balance;
  iterations_ = state.iterations;
  lights_shot_ = state.lights_shot || (lights_.empty() && !outside_);
  return {};
}

glm::dvec3 ProgressiveRadiosity::unshotPower() const {
  glm::dvec3 sum(0.0);
  for (size_t e = 0; e < elementCount(); ++e) sum += db_[e] * surface_.atlas.element_area[e];
  if (!lights_shot_) sum += light_power_;
  return sum;
}

double ProgressiveRadiosity::unshotFraction() const {
  // Before the lights' iteration the power of the sky or the environment is not known (it is
  // found element by element as the lights are shot): all is unshot. A scene that emits nothing has
  // nothing left to shoot.
  if (!lights_shot_) return 1.0;
  const double emitted = residualLuminance(balance_.emitted);
  return emitted > 0.0 ? residualLuminance(balance_.unshot) / emitted : 0.0;
}

glm::dvec3 ProgressiveRadiosity::ambient() const {
  // Eq. 4 with F'_ij = A_j / sum_k A_k (eq. 5) and R of eq. 6.
  return ambient_factor_ * unshotPower() / surface_.total_area;
}

glm::dvec3 ProgressiveRadiosity::displayRadiosity(size_t element) const {
  return b_[element] + surface_.reflectance[element] * ambient();
}

Image ProgressiveRadiosity::radianceImage(bool with_ambient) const {
  const glm::dvec3 amb = with_ambient ? ambient() : glm::dvec3(0.0);
  std::vector<glm::dvec3> b(elementCount());
  for (size_t e = 0; e < elementCount(); ++e) b[e] = b_[e] + surface_.reflectance[e] * amb;
  return surface_.radianceImage(b);
}

}  // namespace penumbra
