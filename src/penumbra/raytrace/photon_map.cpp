#include "penumbra/raytrace/photon_map.h"

#include "penumbra/core/interrupt.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/core/timer.h"
#include "penumbra/kernels/sampling.h"
#include "penumbra/raytrace/direct_light.h"
#include "penumbra/raytrace/lights.h"
#include "penumbra/raytrace/specular.h"

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <nanoflann.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <variant>

namespace penumbra {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr float kPiF = std::numbers::pi_v<float>;

// The photons as nanoflann's dataset.
struct PhotonCloud {
  const std::vector<glm::vec3>* positions = nullptr;
  size_t kdtree_get_point_count() const { return positions->size(); }
  float kdtree_get_pt(size_t i, size_t dim) const { return (*positions)[i][int(dim)]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};

using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, PhotonCloud>,
                                                   PhotonCloud, 3, uint32_t>;

// The k nearest points within a radius (squared distances), as a bounded max-heap: the result set
// nanoflann's search fills, pruning with the current k-th distance. The heap lives in a buffer of
// the calling thread's, so a query allocates nothing.
class KnnWithin {
 public:
  KnnWithin(size_t k, float r2_max) : k_(k), r2_max_(r2_max), heap_(buffer()) { heap_.clear(); }
  size_t size() const { return heap_.size(); }
  bool full() const { return heap_.size() == k_; }
  float worstDist() const { return full() ? heap_.front().first : r2_max_; }
  bool addPoint(float d2, uint32_t index) {
    if (d2 < worstDist()) {
      if (full()) {
        std::pop_heap(heap_.begin(), heap_.end());
        heap_.back() = {d2, index};
      } else {
        heap_.push_back({d2, index});
      }
      std::push_heap(heap_.begin(), heap_.end());
    }
    return true;
  }
  // The squared radius the estimate spans: the k-th distance when k were found, else the limit.
  float radius2() const { return full() ? heap_.front().first : r2_max_; }
  template <class F>
  void forEach(F&& f) const {
    for (const auto& [d2, i] : heap_) f(i, d2);
  }

 private:
  static std::vector<std::pair<float, uint32_t>>& buffer() {
    thread_local std::vector<std::pair<float, uint32_t>> heap;
    return heap;
  }
  size_t k_;
  float r2_max_;
  std::vector<std::pair<float, uint32_t>>& heap_;
};

float channelMean(const glm::dvec3& c) {
  return float((c.x + c.y + c.z) / 3.0);
}

// A direction uniformly distributed in the cone of half-angle acos(cos_max) around unit `axis`;
// its pdf is 1 / (2 pi (1 - cos_max)).
glm::dvec3 sampleCone(const glm::dvec3& axis, double cos_max, double u1, double u2) {
  const double c = 1.0 - u1 * (1.0 - cos_max);
  const double s = std::sqrt(std::max(0.0, 1.0 - c * c));
  const double phi = 2.0 * kPi * u2;
  const Frame f = Frame::fromNormal(glm::vec3(axis));
  return glm::normalize(glm::dvec3(f.t) * (s * std::cos(phi)) +
                        glm::dvec3(f.b) * (s * std::sin(phi)) + axis * c);
}

}  // namespace

// The photons and their tree, on the heap together: the tree reads the photons through the
// cloud's pointer, which must not move.
// The photons in Morton order (neighbours in space are neighbours in memory, so a search touches
// few cache lines), their positions packed apart for the tree, and the tree; on the heap
// together, since the tree reads the positions through the cloud's pointer.
struct PhotonMap::Index {
  std::vector<Photon> photons;
  std::vector<glm::vec3> positions;
  PhotonCloud cloud;
  KdTree tree;
  explicit Index(std::vector<Photon> p)
      : photons(mortonOrder(std::move(p))),
        positions(positionsOf(photons)),
        cloud{&positions},
        tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(8)) {}

  static std::vector<Photon> mortonOrder(std::vector<Photon> p) {
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    for (const Photon& ph : p) {
      lo = glm::min(lo, ph.position);
      hi = glm::max(hi, ph.position);
    }
    const glm::vec3 scale = 1023.0f / glm::max(hi - lo, glm::vec3(1e-30f));
    const auto spread = [](uint32_t v) {  // 10 bits to every third of 30
      v = (v | (v << 16)) & 0x030000FFu;
      v = (v | (v << 8)) & 0x0300F00Fu;
      v = (v | (v << 4)) & 0x030C30C3u;
      return (v | (v << 2)) & 0x09249249u;
    };
    std::vector<std::pair<uint32_t, uint32_t>> keys(p.size());
    for (size_t i = 0; i < p.size(); ++i) {
      const glm::uvec3 c((p[i].position - lo) * scale);
      keys[i] = {spread(c.x) | spread(c.y) << 1 | spread(c.z) << 2, uint32_t(i)};
    }
    std::sort(keys.begin(), keys.end());
    std::vector<Photon> out(p.size());
    for (size_t i = 0; i < p.size(); ++i) out[i] = p[keys[i].second];
    return out;
  }
  static std::vector<glm::vec3> positionsOf(const std::vector<Photon>& p) {
    std::vector<glm::vec3> out(p.size());
    for (size_t i = 0; i < p.size(); ++i) out[i] = p[i].position;
    return out;
  }
};

PhotonMap::PhotonMap() = default;
PhotonMap::~PhotonMap() = default;
PhotonMap::PhotonMap(PhotonMap&&) noexcept = default;
PhotonMap& PhotonMap::operator=(PhotonMap&&) noexcept = default;

void PhotonMap::build(std::vector<Photon> photons) {
  index_.reset();
  radiance_index_.reset();
  if (!photons.empty()) index_ = std::make_unique<Index>(std::move(photons));
}

const std::vector<Photon>& PhotonMap::photons() const {
  static const std::vector<Photon> kNone;
  return index_ ? index_->photons : kNone;
}

size_t PhotonMap::memoryBytes() const {
  // The photons and, per photon, nanoflann's index and about one node per 4 (leaves of <= 8).
  const size_t radiance = radiance_index_ ? radiance_index_->photons.size() : 0;
  return (photons().size() + radiance) * (sizeof(Photon) + sizeof(uint32_t) + 16);
}

glm::vec3 PhotonMap::irradiance(const glm::vec3& x, const glm::vec3& n, int k, float r_max,
                                bool cone, bool indirect_only) const {
  if (!index_) return glm::vec3(0.0f);
  KnnWithin found(size_t(std::max(k, 1)), r_max * r_max);
  const float q[3] = {x.x, x.y, x.z};
  index_->tree.findNeighbors(found, q, nanoflann::SearchParams());
  const float r2 = found.radius2();
  if (!(r2 > 0.0f)) return glm::vec3(0.0f);
  const float r = std::sqrt(r2);
  // Jensen 2001 eq. 7.7: the cone filter w = 1 - d / (k r), normalised by 1 - 2 / (3 k).
  constexpr float kCone = 1.1f;
  glm::vec3 sum(0.0f);
  found.forEach([&](uint32_t i, float d2) {
    const Photon& p = index_->photons[i];
    if (glm::dot(p.normal, n) <= 0.0f) return;  // arrived on the other side
    if (indirect_only && !p.indirect) return;
    const float w = cone ? 1.0f - std::sqrt(d2) / (kCone * r) : 1.0f;
    sum += w * p.power;
  });
  const float norm = cone ? 1.0f - 2.0f / (3.0f * kCone) : 1.0f;
  return sum / (norm * kPiF * r * r);
}

void PhotonMap::precomputeRadiance(int k, float r_max, int stride) {
  radiance_index_.reset();
  if (!index_) return;
  const std::vector<Photon>& photons = index_->photons;
  const size_t count = (photons.size() + size_t(stride) - 1) / size_t(stride);
  std::vector<Photon> points(count);
  parallelRange(count, 64, [&](size_t b, size_t e) {
    for (size_t i = b; i < e; ++i) {
      const Photon& p = photons[i * size_t(stride)];
      Photon r = p;
      r.power = p.reflectance * kInvPi * irradiance(p.position, p.normal, k, r_max, false, false);
      points[i] = r;
    }
  });
  radiance_index_ = std::make_unique<Index>(std::move(points));
}

glm::vec3 PhotonMap::radiance(const glm::vec3& x, const glm::vec3& n, float r_max) const {
  if (!radiance_index_) return glm::vec3(0.0f);
  const float q[3] = {x.x, x.y, x.z};
  // The nearest point, and when it faces another way (a corner, a thin wall), the nearest of the
  // closest few that faces the same way.
  for (const size_t k : {size_t(1), size_t(8)}) {
    KnnWithin found(k, r_max * r_max);
    radiance_index_->tree.findNeighbors(found, q, nanoflann::SearchParams());
    float best = std::numeric_limits<float>::max();
    glm::vec3 value(0.0f);
    bool any = false;
    found.forEach([&](uint32_t i, float d2) {
      const Photon& p = radiance_index_->photons[i];
      if (glm::dot(p.normal, n) > 0.7f && d2 < best) {
        best = d2;
        value = p.power;
        any = true;
      }
    });
    if (any || found.size() < k) return value;
  }
  return glm::vec3(0.0f);
}

namespace {

// Where photons come from, chosen in proportion to `power` (the mean of the channels, W).
struct PhotonSource {
  enum class Kind { kEmitters, kLight, kEnvironment } kind;
  size_t light = 0;
  double power = 0.0;
};

// A photon in flight.
struct PhotonPath {
  Ray ray;
  glm::vec3 power{0.0f};
  int events = 0;
  bool diffuse_seen = false;   // it has bounced off a diffuse surface
  bool specular_seen = false;  // it has met a mirror or glass
  bool alive = true;
};

// The photons' emitter: the sources, the scene's bounding sphere and the target sphere of the
// caustic photons.
class PhotonEmitter {
 public:
  PhotonEmitter(const Scene& scene, const SceneGeometry& g, const Bounds3& bounds)
      : g_(g), lights_(scene.lights), environment_(scene.environment) {
    const glm::vec3 lo = bounds.lo, hi = bounds.hi;
    centre_ = 0.5 * (glm::dvec3(lo) + glm::dvec3(hi));
    radius_ = std::max(0.5 * glm::length(glm::dvec3(hi) - glm::dvec3(lo)), 1e-6);
    if (!g.emitters.empty()) {
      sources_.push_back({PhotonSource::Kind::kEmitters, 0, double(g.total_emitted_power)});
    }
    for (size_t i = 0; i < lights_.size(); ++i) {
      sources_.push_back(
          {PhotonSource::Kind::kLight, i, channelMean(lightPower(lights_[i], bounds))});
    }
    if (environment_ != glm::vec3(0.0f)) {
      sources_.push_back(
          {PhotonSource::Kind::kEnvironment, 0,
           channelMean(glm::dvec3(environment_)) * 4.0 * kPi * kPi * radius_ * radius_});
    }
    sources_.erase(std::remove_if(sources_.begin(), sources_.end(),
                                  [](const PhotonSource& s) { return !(s.power > 0.0); }),
                   sources_.end());
    for (const PhotonSource& s : sources_) total_ += s.power;
    // The caustic photons' target: the bounding sphere of the mirrors and glass.
    glm::dvec3 slo(std::numeric_limits<double>::max()), shi(-std::numeric_limits<double>::max());
    for (size_t t = 0; t < g.triangles.size(); ++t) {
      if (!g.materials[g.material_ids[t]].isSpecular()) continue;
      for (int c = 0; c < 3; ++c) {
        const glm::dvec3 p(g.positions[g.triangles[t][c]]);
        slo = glm::min(slo, p);
        shi = glm::max(shi, p);
      }
      has_specular_ = true;
    }
    if (has_specular_) {
      target_centre_ = 0.5 * (slo + shi);
      target_radius_ = std::max(0.5 * glm::length(shi - slo), 1e-6) * 1.001;
    }
  }

  bool empty() const { return sources_.empty(); }
  bool hasSpecular() const { return has_specular_; }

  // Photon `index` of `count`, drawn from `rng`; aimed at the specular target when `caustic`.
  PhotonPath emit(Rng& rng, uint64_t count, bool caustic) const {
    PhotonPath out;
    double u = double(rng.uniform()) * total_;
    size_t si = 0;
    while (si + 1 < sources_.size() && u >= sources_[si].power) u -= sources_[si++].power;
    const PhotonSource& src = sources_[si];
    const double scale = total_ / src.power / double(count);  // 1 / (p_source N)
    out.ray.tmin = 0.0f;
    out.ray.tmax = kRayInfinity;
    // From a point x with the intensity I(w) the function gives: towards the target's cone
    // when aiming and the point is outside it, else by `fallback` (direction, pdf).
    const auto from_point = [&](const glm::dvec3& x, auto&& intensity, auto&& fallback) {
      glm::dvec3 dir;
      double pdf;
      const glm::dvec3 to = target_centre_ - x;
      const double d = glm::length(to);
      if (caustic && d > target_radius_) {
        const double cos_max =
            std::sqrt(std::max(0.0, 1.0 - target_radius_ * target_radius_ / (d * d)));
        dir = sampleCone(to / d, cos_max, rng.uniform(), rng.uniform());
        pdf = 1.0 / (2.0 * kPi * (1.0 - cos_max));
      } else {
        fallback(dir, pdf);
      }
      out.ray.origin = glm::vec3(x);
      out.ray.dir = glm::vec3(dir);
      out.power =
          pdf > 0.0 ? glm::vec3(glm::dvec3(intensity(dir)) * (scale / pdf)) : glm::vec3(0.0f);
    };
    const auto uniform_sphere = [&](glm::dvec3& dir, double& pdf) {
      dir = sampleUniformSphere(rng.uniform(), rng.uniform());
      pdf = 1.0 / (4.0 * kPi);
    };
    // From a disc perpendicular to `dir` covering the sphere (c, r), outside the scene.
    const auto from_disc = [&](const glm::dvec3& dir, const glm::dvec3& c, double r) {
      const Frame f = Frame::fromNormal(glm::vec3(dir));
      const double rr = r * std::sqrt(double(rng.uniform()));
      const double phi = 2.0 * kPi * double(rng.uniform());
      const double back = 2.0 * radius_ + glm::length(c - centre_) + r;
      out.ray.origin = glm::vec3(c - dir * back + glm::dvec3(f.t) * (rr * std::cos(phi)) +
                                 glm::dvec3(f.b) * (rr * std::sin(phi)));
      out.ray.dir = glm::vec3(dir);
      return kPi * r * r;  // the disc's area
    };
    switch (src.kind) {
      case PhotonSource::Kind::kEmitters: {
        const EmitterPick pick = g_.pickEmitter(rng.nextU32());
        const uint32_t tri = g_.emitters[pick.index];
        const glm::vec2 b = sampleTriangleBarycentrics(pick.u, rng.uniform());
        const glm::dvec3 nl(g_.normals[tri]);
        const glm::dvec3 le(g_.emissionSampled(tri, b.x, b.y));
        const double pdf_area = double(g_.emitter_pick_pdf[tri]) / double(g_.areas[tri]);
        const glm::vec3 q = g_.point(tri, b.x, b.y);
        const glm::dvec3 x(
            offsetOrigin(q, g_.surfaceOffset(tri), g_.normals[tri], g_.normals[tri]));
        // Radiance times cos per unit area of the emitter: a Lambertian front face.
        from_point(
            x, [&](const glm::dvec3& w) { return le * std::max(0.0, glm::dot(nl, w)) / pdf_area; },
            [&](glm::dvec3& dir, double& pdf) {
              const glm::vec3 local = sampleCosineHemisphere(rng.uniform(), rng.uniform());
              dir = glm::normalize(glm::dvec3(Frame::fromNormal(g_.normals[tri]).toWorld(local)));
              pdf = std::max(0.0, glm::dot(nl, dir)) / kPi;
            });
        break;
      }
      case PhotonSource::Kind::kLight: {
        std::visit(
            Overloaded{[&](const PointLight& pl) {
                         from_point(
                             glm::dvec3(pl.position),
                             [&](const glm::dvec3&) { return glm::dvec3(pl.intensity); },
                             uniform_sphere);
                       },
                       [&](const SpotLight& sl) {
                         const glm::dvec3 axis = glm::normalize(glm::dvec3(sl.direction));
                         const double cos_outer = std::cos(double(sl.outer_angle));
                         from_point(
                             glm::dvec3(sl.position),
                             [&](const glm::dvec3& w) {
                               return glm::dvec3(sl.intensity) * spotFalloff(sl, glm::dot(axis, w));
                             },
                             [&](glm::dvec3& dir, double& pdf) {
                               dir = sampleCone(axis, cos_outer, rng.uniform(), rng.uniform());
                               pdf = 1.0 / (2.0 * kPi * (1.0 - cos_outer));
                             });
                       },
                       [&](const LuminaireLight& lu) {
                         from_point(
                             glm::dvec3(lu.position),
                             [&](const glm::dvec3& w) {
                               return glm::dvec3(luminaireIntensity(lu, glm::vec3(w)));
                             },
                             uniform_sphere);
                       },
                       [&](const DirectionalLight& dl) {
                         const glm::dvec3 dir = glm::normalize(glm::dvec3(dl.direction));
                         const double area = caustic
                                                 ? from_disc(dir, target_centre_, target_radius_)
                                                 : from_disc(dir, centre_, radius_);
                         out.power = glm::vec3(glm::dvec3(dl.irradiance) * (area * scale));
                       }},
            lights_[src.light]);
        break;
      }
      case PhotonSource::Kind::kEnvironment: {
        // Radiance L from every direction: flux L x 4 pi x (the disc's area) through the disc.
        const glm::dvec3 dir = sampleUniformSphere(rng.uniform(), rng.uniform());
        const double area = caustic ? from_disc(dir, target_centre_, target_radius_)
                                    : from_disc(dir, centre_, radius_);
        out.power = glm::vec3(glm::dvec3(environment_) * (4.0 * kPi * area * scale));
        break;
      }
    }
    if (!(out.power.x > 0.0f || out.power.y > 0.0f || out.power.z > 0.0f)) out.alive = false;
    return out;
  }

 private:
  const SceneGeometry& g_;
  std::vector<Light> lights_;
  glm::vec3 environment_;
  glm::dvec3 centre_{0.0};
  double radius_ = 1.0;
  std::vector<PhotonSource> sources_;
  double total_ = 0.0;
  bool has_specular_ = false;
  glm::dvec3 target_centre_{0.0};
  double target_radius_ = 0.0;
};

// Photons per batch: each generation of a batch is one query to the Ray Engine.
constexpr uint64_t kPhotonBatch = uint64_t(1) << 18;

// Traces `count` photons (caustic or global) and returns the stored ones in a fixed order:
// by generation, then by photon index, whatever the thread count.
Expected<std::vector<Photon>> tracePhotons(const PhotonEmitter& emitter, const SceneGeometry& g,
                                           const PhotonSettings& settings, uint64_t count,
                                           bool caustic, RayQueries& queries, PhotonStats& stats,
                                           const std::function<void(uint64_t)>& on_batch) {
  std::vector<Photon> stored;
  std::vector<PhotonPath> paths;
  std::vector<Rng> rngs;
  std::vector<uint32_t> alive;
  std::vector<Photon> slot;
  std::vector<uint8_t> has_slot;
  RayBatch batch;
  HitBatch hits;
  const uint64_t seed = mixBits(settings.seed ^ (caustic ? 0x9e3779b97f4a7c15ULL : 0x5bd1e995ULL));
  for (uint64_t b0 = 0; b0 < count; b0 += kPhotonBatch) {
    throwIfInterrupted();
    const uint64_t n = std::min(kPhotonBatch, count - b0);
    paths.resize(n);
    rngs.resize(n);
    parallelRange(n, 1024, [&](size_t b, size_t e) {
      for (size_t i = b; i < e; ++i) {
        rngs[i] = Rng(seed, b0 + i);
        paths[i] = emitter.emit(rngs[i], count, caustic);
      }
    });
    alive.clear();
    for (uint32_t i = 0; i < n; ++i) {
      if (paths[i].alive) alive.push_back(i);
    }
    while (!alive.empty()) {
      throwIfInterrupted();
      batch.resize(alive.size());
      for (size_t k = 0; k < alive.size(); ++k) batch.set(k, paths[alive[k]].ray);
      PENUMBRA_TRY(queries.intersect(batch, hits));
      stats.rays += alive.size();
      slot.resize(alive.size());
      has_slot.assign(alive.size(), 0);
      parallelRange(alive.size(), 256, [&](size_t b, size_t e) {
        for (size_t k = b; k < e; ++k) {
          PhotonPath& ph = paths[alive[k]];
          Rng& rng = rngs[alive[k]];
          const Hit hit = hits.get(k);
          ph.alive = false;
          if (!hit.hit()) continue;
          const SurfaceHit h = g.surfaceHit(hit, ph.ray.dir);
          const Material& mat = *h.material;
          if (++ph.events > settings.max_bounces) continue;
          if (mat.isSpecular()) {
            SpecularLobe lobe;
            if (!sampleSpecular(mat, h.geometric_normal, h.dir, rng.uniform(), lobe)) continue;
            ph.power *= lobe.weight;
            ph.specular_seen = true;
            ph.ray = Ray{offsetOrigin(h.point, h.offset, h.geometric_normal, lobe.dir), 0.0f,
                         lobe.dir, kRayInfinity};
            ph.alive = ph.power != glm::vec3(0.0f);
            continue;
          }
          if (caustic && !ph.specular_seen) continue;  // not a caustic path
          const glm::vec3 rho = h.reflectance;
          if (rho == glm::vec3(0.0f)) continue;
          if (!mat.two_sided && !h.front) continue;
          slot[k] = Photon{h.point, ph.power, h.normal, rho, ph.diffuse_seen};
          has_slot[k] = 1;
          if (caustic) continue;  // caustic photons end at their first diffuse surface
          // Russian roulette by reflectance (Jensen 2001 sec. 5.2), then a cosine bounce.
          const float q = std::max({rho.x, rho.y, rho.z});
          if (rng.uniform() >= q) continue;
          ph.power *= rho / q;
          const glm::vec3 wi = Frame::fromNormal(h.normal).toWorld(
              sampleCosineHemisphere(rng.uniform(), rng.uniform()));
          if (!(glm::dot(wi, h.normal) > 0.0f)) continue;
          ph.diffuse_seen = true;
          ph.ray = Ray{offsetOrigin(h.point, h.offset, h.normal, wi), 0.0f, wi, kRayInfinity};
          ph.alive = true;
        }
      });
      for (size_t k = 0; k < alive.size(); ++k) {
        if (has_slot[k]) stored.push_back(slot[k]);
      }
      size_t kept = 0;
      for (uint32_t i : alive) {
        if (paths[i].alive) alive[kept++] = i;
      }
      alive.resize(kept);
    }
    if (on_batch) on_batch(n);
  }
  return stored;
}

}  // namespace

Expected<PhotonMaps> shootPhotons(const Scene& scene, const SceneGeometry& geometry,
                                  const PhotonSettings& settings, RayQueries& queries,
                                  PhotonStats* stats_out,
                                  const std::function<void(uint64_t)>& on_progress) {
  Timer timer;
  PhotonStats stats;
  PhotonMaps maps;
  const Bounds3 bounds = geometry.engine.bounds();
  maps.radius = settings.gather_radius > 0.0f ? settings.gather_radius
                                              : 0.01f * glm::length(bounds.hi - bounds.lo);
  const PhotonEmitter emitter(scene, geometry, bounds);
  uint64_t traced = 0;
  const auto progress = [&](uint64_t n) {
    traced += n;
    if (on_progress) on_progress(traced);
  };
  if (!emitter.empty()) {
    Expected<std::vector<Photon>> global = tracePhotons(
        emitter, geometry, settings, settings.photons, false, queries, stats, progress);
    if (!global) return global.error();
    stats.emitted = settings.photons;
    stats.stored = global->size();
    std::vector<Photon> caustic;
    if (emitter.hasSpecular() && settings.caustic_photons > 0) {
      Expected<std::vector<Photon>> c = tracePhotons(
          emitter, geometry, settings, settings.caustic_photons, true, queries, stats, progress);
      if (!c) return c.error();
      stats.caustic_emitted = settings.caustic_photons;
      stats.caustic_stored = c->size();
      caustic = std::move(*c);
    }
    stats.seconds = timer.seconds();
    Timer build;
    maps.global.build(std::move(*global));
    maps.caustic.build(std::move(caustic));
    stats.build_seconds = build.seconds();
  }
  if (settings.final_gather > 0) {
    Timer gather;
    maps.global.precomputeRadiance(settings.gather_count, maps.radius, 4);
    stats.precompute_seconds = gather.seconds();
  }
  if (stats_out) *stats_out = stats;
  return maps;
}

namespace {

// The final gather at `vertices`, added to `radiance`: cosine-distributed rays (stratified in
// their first coordinate), each followed through mirrors and glass to a diffuse surface, where the
// global map's radiance is read; f cos / pdf = rho, so each adds rho L / gather rays.
Status finalGather(const SceneGeometry& geometry, const PhotonMaps& maps,
                   const PhotonSettings& settings, uint64_t* gather_rays,
                   std::span<const DiffuseVertex> vertices, std::span<glm::vec3> radiance,
                   RayQueries& queries) {
  const float r = maps.radius;
  const size_t g = size_t(settings.final_gather);
  const size_t n = vertices.size() * g;
  struct GatherRay {
    Ray ray;
    glm::vec3 weight{1.0f};
    Rng rng;
    bool alive = false;
  };
  std::vector<GatherRay> rays(n);
  parallelRange(vertices.size(), 64, [&](size_t b, size_t e) {
    for (size_t i = b; i < e; ++i) {
      const DiffuseVertex& v = vertices[i];
      const Frame frame = Frame::fromNormal(v.normal);
      Rng rng(mixBits(settings.seed ^ 0x6a09e667f3bcc909ULL), v.key);
      for (size_t j = 0; j < g; ++j) {
        GatherRay& gr = rays[i * g + j];
        const float u1 = std::min((float(j) + rng.uniform()) / float(g), 1.0f - 0x1p-24f);
        const glm::vec3 wi = frame.toWorld(sampleCosineHemisphere(u1, rng.uniform()));
        gr.rng = Rng(mixBits(v.key), j);
        if (!(glm::dot(wi, v.normal) > 0.0f)) continue;
        gr.ray = Ray{offsetOrigin(v.point, v.offset, v.normal, wi), 0.0f, wi, kRayInfinity};
        gr.alive = true;
      }
    }
  });
  std::vector<glm::vec3> found(n, glm::vec3(0.0f));
  std::vector<uint32_t> alive;
  for (uint32_t i = 0; i < n; ++i) {
    if (rays[i].alive) alive.push_back(i);
  }
  RayBatch batch;
  HitBatch hits;
  for (int depth = 0; !alive.empty(); ++depth) {
    throwIfInterrupted();
    batch.resize(alive.size());
    for (size_t a = 0; a < alive.size(); ++a) batch.set(a, rays[alive[a]].ray);
    PENUMBRA_TRY(queries.intersect(batch, hits));
    if (gather_rays) *gather_rays += alive.size();
    parallelRange(alive.size(), 256, [&](size_t b, size_t e) {
      for (size_t a = b; a < e; ++a) {
        GatherRay& gr = rays[alive[a]];
        gr.alive = false;
        const Hit hit = hits.get(a);
        // A miss or an emitter: direct light (or a caustic, after mirrors and glass), which the
        // shadow rays and the caustic map already count.
        if (!hit.hit()) continue;
        const SurfaceHit h = geometry.surfaceHit(hit, gr.ray.dir);
        const Material& mat = *h.material;
        if (mat.isSpecular()) {
          SpecularLobe lobe;
          if (depth >= settings.max_bounces ||
              !sampleSpecular(mat, h.geometric_normal, h.dir, gr.rng.uniform(), lobe)) {
            continue;
          }
          gr.weight *= lobe.weight;
          gr.ray = Ray{offsetOrigin(h.point, h.offset, h.geometric_normal, lobe.dir), 0.0f,
                       lobe.dir, kRayInfinity};
          gr.alive = gr.weight != glm::vec3(0.0f);
          continue;
        }
        if (!mat.two_sided && !h.front) continue;
        found[alive[a]] = gr.weight * maps.global.radiance(h.point, h.normal, r);
      }
    });
    size_t kept = 0;
    for (uint32_t i : alive) {
      if (rays[i].alive) alive[kept++] = i;
    }
    alive.resize(kept);
  }
  for (size_t i = 0; i < vertices.size(); ++i) {
    glm::vec3 sum(0.0f);
    for (size_t j = 0; j < g; ++j) sum += found[i * g + j];
    radiance[i] += vertices[i].reflectance * sum / float(g);
  }
  return {};
}

}  // namespace

DiffuseShading photonShading(const SceneGeometry& geometry, const PhotonMaps& maps,
                             const PhotonSettings& settings, uint64_t* gather_rays) {
  return [&geometry, &maps, settings, gather_rays](std::span<const DiffuseVertex> vertices,
                                                   std::span<glm::vec3> radiance,
                                                   RayQueries& queries) -> Status {
    const int k = settings.gather_count;
    const float r = maps.radius;
    // Caustics, and without a final gather the global map's indirect part, at the vertex.
    parallelRange(vertices.size(), 64, [&](size_t b, size_t e) {
      for (size_t i = b; i < e; ++i) {
        const DiffuseVertex& v = vertices[i];
        glm::vec3 e_sum = maps.caustic.irradiance(v.point, v.normal, k, r, true, false);
        if (settings.final_gather <= 0) {
          e_sum += maps.global.irradiance(v.point, v.normal, k, r, false, true);
        }
        radiance[i] = v.reflectance * kInvPi * e_sum;
      }
    });
    if (settings.final_gather <= 0) return {};
    // The final gather, in chunks of about 2^20 rays.
    const size_t chunk = std::max<size_t>(1, (size_t(1) << 20) / size_t(settings.final_gather));
    for (size_t v0 = 0; v0 < vertices.size(); v0 += chunk) {
      const size_t count = std::min(chunk, vertices.size() - v0);
      PENUMBRA_TRY(finalGather(geometry, maps, settings, gather_rays, vertices.subspan(v0, count),
                               radiance.subspan(v0, count), queries));
    }
    return {};
  };
}

}  // namespace penumbra
