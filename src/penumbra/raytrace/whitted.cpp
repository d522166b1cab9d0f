#include "penumbra/raytrace/whitted.h"

#include "penumbra/core/check.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/core/timer.h"
#include "penumbra/kernels/sampling.h"
#include "penumbra/raytrace/camera_rays.h"
#include "penumbra/raytrace/direct_light.h"
#include "penumbra/raytrace/specular.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>

namespace penumbra {

namespace {

// A ray of a ray tree: what it carries to its pixel sample, and its stream key (the root's from
// the pixel and sample, a child's from its parent's and its lobe).
struct TreeNode {
  Ray ray;
  glm::vec3 weight{1.0f};
  uint32_t sample = 0;  // pixel sample within the wave
  int depth = 0;        // generations after the camera ray
  uint64_t key = 0;
};

// Shadow queries per wave (about 40 bytes each): the camera rays of a wave are whole rows of about
// this many over the queries each may make, so that a generation and its shadow rays stay within
// a hundred MiB or so whatever the image size and light samples.
constexpr size_t kWaveQueries = size_t(1) << 21;
// A generation larger than this (glass in glass multiplies the rays) is traced in chunks, each with
// all its descendants before the next, so memory stays bounded whatever the depth.
constexpr size_t kMaxGeneration = size_t(1) << 17;
// Branches carrying less than this (their largest channel) are followed with probability
// weight / kFaintBranch, and then carry kFaintBranch (Russian roulette: unbiased), so that a tree
// keeps at most about 1 / kFaintBranch rays per generation for each camera ray.
constexpr float kFaintBranch = 1e-4f;

// The camera rays of a wave (rows from y0, `samples` of them), stratified within their pixels.
void cameraRays(const CameraRays& cam, uint64_t seed, size_t width, size_t spp, size_t y0,
                size_t samples, std::vector<TreeNode>& nodes) {
  nodes.resize(samples);
  parallelRange(samples, 1024, [&](size_t b, size_t e) {
    for (size_t i = b; i < e; ++i) {
      const size_t local_pixel = i / spp, s = i % spp;
      const size_t x = local_pixel % width, y = y0 + local_pixel / width;
      const uint64_t key = mixBits((uint64_t(y) * width + x) * spp + s + 1);
      // Stratified within the pixel (pixelJitter); one sample keeps its own random offset, as the
      // path tracer's does.
      glm::vec2 j;
      if (spp == 1) {
        Rng rng(seed, key);
        j.x = rng.uniform();
        j.y = rng.uniform();
      } else {
        j = pixelJitter(seed, uint64_t(y) * width + x, uint32_t(s), int(spp));
      }
      nodes[i] =
          TreeNode{cam.ray(float(x) + j.x, float(y) + j.y), glm::vec3(1.0f), uint32_t(i), 0, key};
    }
  });
}

// The ray trees of a wave of pixel samples, generation by generation, into sample_sum; the
// buffers are reused by every generation.
class WaveTracer {
 public:
  WaveTracer(const WhittedTracer& tracer, const glm::vec3& environment,
             const WhittedSettings& settings, RayQueries& queries, WhittedStats& stats,
             const DiffuseShading& shading, uint64_t seed, size_t cap)
      : tracer_(tracer),
        environment_(environment),
        settings_(settings),
        queries_(queries),
        stats_(stats),
        shading_(shading),
        seed_(seed),
        cap_(cap) {}

  std::vector<glm::vec3> sample_sum;  // per pixel sample of the wave

  // One generation: its rays, its shading and shadow rays, then its children, chunk by chunk,
  // each chunk with all its descendants.
  Status generation(const std::vector<TreeNode>& nodes) {
    throwIfInterrupted();  // a caller of the library asked to stop (core/interrupt.h)
    const size_t n = nodes.size();
    if (n == 0) return {};
    // 1. This generation's rays, as one batch.
    batch_.resize(n);
    for (size_t k = 0; k < n; ++k) batch_.set(k, nodes[k].ray);
    PENUMBRA_TRY(queries_.intersect(batch_, hits_));
    stats_.rays += n;
    // 2. Shade: emission and the environment, the children of mirrors and glass, the shadow
    //    queries of diffuse vertices.
    value_.assign(n, glm::vec3(0.0f));
    diffuse_.assign(n, 0);
    child_offset_.assign(n + 1, 0);
    shadow_.resize(n * cap_);
    shadow_count_.assign(n, 0);
    if (vertices_.size() < n) vertices_.resize(n);
    std::vector<std::array<TreeNode, 2>> children(n);
    parallelRange(n, 256, [&](size_t b, size_t e) {
      for (size_t k = b; k < e; ++k) shade(nodes[k], k, children[k]);
    });
    // 3. The shadow rays, as one batch.
    PENUMBRA_TRY(traceShadowRays(n));
    // 4. The hook's radiance at this generation's diffuse vertices.
    PENUMBRA_TRY(addShading(nodes));
    // 5. Sum into the pixel samples in node order (so any thread count gives the same sums).
    for (size_t k = 0; k < n; ++k) {
      glm::vec3 direct(0.0f);
      for (int q = 0; q < shadow_count_[k]; ++q) direct += shadow_[k * cap_ + size_t(q)].value;
      stats_.diffuse_vertices += diffuse_[k];
      sample_sum[nodes[k].sample] += value_[k] + nodes[k].weight * direct;
    }
    // 6. The next generation: the reflected and refracted rays, in their parents' order.
    const std::vector<TreeNode> next = nextGeneration(children);
    for (size_t c0 = 0; c0 < next.size(); c0 += kMaxGeneration) {
      const size_t c1 = std::min(next.size(), c0 + kMaxGeneration);
      const std::vector<TreeNode> chunk(next.begin() + std::ptrdiff_t(c0),
                                        next.begin() + std::ptrdiff_t(c1));
      PENUMBRA_TRY(generation(chunk));
    }
    return {};
  }

 private:
  // Node k's hit: its emission or the environment, its reflected and refracted rays (kept in
  // `children` until the generation's order is known), or its diffuse vertex's shadow queries.
  void shade(const TreeNode& node, size_t k, std::array<TreeNode, 2>& children) {
    const Hit hit = hits_.get(k);
    if (!hit.hit()) {
      value_[k] = node.weight * environment_;
      return;
    }
    const SurfaceHit h = tracer_.geometry().surfaceHit(hit, node.ray.dir);
    const Material& mat = *h.material;
    if (mat.isEmissive() && h.front) value_[k] = node.weight * h.emission;
    if (mat.isSpecular()) {
      if (node.depth >= settings_.max_depth) return;
      // The reflected and refracted rays, kept until the generation's order is known.
      const SpecularLobes lobes = specularLobes(mat, h.geometric_normal, h.dir);
      for (int l = 0; l < lobes.count; ++l) {
        const SpecularLobe& lobe = lobes.lobe[l];
        children[size_t(l)] =
            TreeNode{Ray{offsetOrigin(h.point, h.offset, h.geometric_normal, lobe.dir), 0.0f,
                         lobe.dir, kRayInfinity},
                     node.weight * lobe.weight, node.sample, node.depth + 1,
                     mixBits(node.key * 2 + uint64_t(l) + 1)};
      }
      child_offset_[k + 1] = uint32_t(lobes.count);
      return;
    }
    if (h.reflectance == glm::vec3(0.0f)) return;
    if (!mat.two_sided && !h.front) return;
    DiffuseVertex& v = vertices_[k];
    v.point = h.point;
    v.offset = h.offset;
    v.normal = h.normal;
    v.reflectance = h.reflectance;
    v.key = node.key;
    diffuse_[k] = 1;
    Rng rng(seed_, node.key);
    rng.advance(2);  // past the camera jitter of a root
    shadow_count_[k] = tracer_.directQueries(v, settings_.light_samples, rng, &shadow_[k * cap_]);
  }

  // The shadow queries of the generation's n nodes that need a ray, traced as one batch; the
  // occluded ones bring nothing.
  Status traceShadowRays(size_t n) {
    shadow_slot_.clear();
    for (size_t k = 0; k < n; ++k) {
      for (int q = 0; q < shadow_count_[k]; ++q) {
        if (shadow_[k * cap_ + size_t(q)].trace) shadow_slot_.push_back(k * cap_ + size_t(q));
      }
    }
    batch_.resize(shadow_slot_.size());
    for (size_t j = 0; j < shadow_slot_.size(); ++j) batch_.set(j, shadow_[shadow_slot_[j]].ray);
    PENUMBRA_TRY(queries_.occluded(batch_, occluded_));
    stats_.shadow_rays += shadow_slot_.size();
    for (size_t j = 0; j < shadow_slot_.size(); ++j) {
      if (occluded_[j]) shadow_[shadow_slot_[j]].value = glm::vec3(0.0f);
    }
    return {};
  }

  // The shading hook's radiance at the diffuse vertices, added to their nodes' values.
  Status addShading(const std::vector<TreeNode>& nodes) {
    if (!shading_) return {};
    const size_t n = nodes.size();
    vertex_node_.clear();
    for (size_t k = 0; k < n; ++k) {
      if (diffuse_[k]) vertex_node_.push_back(uint32_t(k));
    }
    std::vector<DiffuseVertex> batch_vertices(vertex_node_.size());
    for (size_t j = 0; j < vertex_node_.size(); ++j) batch_vertices[j] = vertices_[vertex_node_[j]];
    extra_.assign(vertex_node_.size(), glm::vec3(0.0f));
    PENUMBRA_TRY(shading_(batch_vertices, extra_, queries_));
    for (size_t j = 0; j < vertex_node_.size(); ++j) {
      value_[vertex_node_[j]] += nodes[vertex_node_[j]].weight * extra_[j];
    }
    return {};
  }

  // The children of the generation's nodes, in their parents' order.
  std::vector<TreeNode> nextGeneration(const std::vector<std::array<TreeNode, 2>>& children) {
    const size_t n = children.size();
    for (size_t k = 0; k < n; ++k) child_offset_[k + 1] += child_offset_[k];
    std::vector<TreeNode> next(child_offset_[n]);
    for (size_t k = 0; k < n; ++k) {
      for (uint32_t l = 0; l < child_offset_[k + 1] - child_offset_[k]; ++l) {
        next[child_offset_[k] + l] = children[k][l];
      }
    }
    // Children that carry nothing (a black mirror) are dropped; faint ones go on by Russian
    // roulette.
    size_t kept = 0;
    for (TreeNode& c : next) {
      const float w = std::max({c.weight.x, c.weight.y, c.weight.z});
      if (!(w > 0.0f)) continue;
      if (w < kFaintBranch) {
        Rng rng(seed_, c.key);
        if (rng.uniform() * kFaintBranch >= w) continue;
        c.weight *= kFaintBranch / w;
      }
      next[kept++] = c;
    }
    next.resize(kept);
    return next;
  }

  const WhittedTracer& tracer_;
  const glm::vec3 environment_;
  const WhittedSettings& settings_;
  RayQueries& queries_;
  WhittedStats& stats_;
  const DiffuseShading& shading_;
  const uint64_t seed_;
  const size_t cap_;  // shadow queries per node

  std::vector<glm::vec3> value_;  // per node: what it adds to its sample
  std::vector<uint8_t> diffuse_;  // per node: it ended on a diffuse surface
  std::vector<DiffuseVertex> vertices_;
  std::vector<uint32_t> vertex_node_;
  std::vector<glm::vec3> extra_;
  std::vector<uint32_t> child_offset_;
  std::vector<ShadowQuery> shadow_;
  std::vector<int> shadow_count_;
  std::vector<size_t> shadow_slot_;
  std::vector<uint8_t> occluded_;
  RayBatch batch_;
  HitBatch hits_;
};

}  // namespace

WhittedTracer::WhittedTracer(const Scene& scene)
    : geometry_(SceneGeometry::build(scene)),
      lights_(scene.lights),
      environment_(scene.environment) {}

int WhittedTracer::directQueries(const DiffuseVertex& v, int light_samples, Rng& rng,
                                 ShadowQuery* out) const {
  int count = deltaLightQueries(lights_, v.point, v.offset, v.normal, v.reflectance, out);
  if (light_samples <= 0) return count;
  const float inv = 1.0f / float(light_samples);
  // Emitters: sample j takes the j-th stratum of the power CDF (its first coordinate on the
  // emitter comes with it, SceneGeometry::pickEmitter), the second coordinate at random.
  if (!geometry_.emitters.empty()) {
    for (int j = 0; j < light_samples; ++j) {
      const double u = (double(j) + double(rng.uniform())) * inv;
      const uint32_t ux = uint32_t(std::min(u * 4294967296.0, 4294967295.0));
      if (emitterQuery(geometry_, v.point, v.offset, v.normal, v.reflectance, ux, rng.uniform(),
                       false, inv, out[count])) {
        ++count;
      }
    }
  }
  // The environment: cosine-distributed rays (f cos / pdf = rho), stratified in the first
  // coordinate.
  if (environment_ != glm::vec3(0.0f)) {
    const Frame frame = Frame::fromNormal(v.normal);
    for (int j = 0; j < light_samples; ++j) {
      const float u1 = (float(j) + rng.uniform()) * inv;
      const glm::vec3 wi =
          frame.toWorld(sampleCosineHemisphere(std::min(u1, 1.0f - 0x1p-24f), rng.uniform()));
      if (!(glm::dot(v.normal, wi) > 0.0f)) continue;
      out[count++] =
          ShadowQuery{Ray{offsetOrigin(v.point, v.offset, v.normal, wi), 0.0f, wi, kRayInfinity},
                      v.reflectance * environment_ * inv, true};
    }
  }
  return count;
}

Expected<Image> WhittedTracer::render(const Camera& camera, const WhittedSettings& settings,
                                      RayQueries& queries, WhittedStats* stats,
                                      const std::function<void(int)>& on_progress,
                                      const DiffuseShading& shading) const {
  Timer timer;
  Image image(settings.width, settings.height);
  WhittedStats s;
  int rows_done = 0;
  PENUMBRA_TRY(renderRows(
      camera, settings, 0, settings.height, queries, image.pixels, s,
      [&](int n) {
        rows_done += n;
        if (on_progress) on_progress(rows_done);
      },
      shading));
  s.seconds = timer.seconds();
  if (stats) *stats = s;
  return image;
}

Status WhittedTracer::renderRows(const Camera& camera, const WhittedSettings& settings, int y_begin,
                                 int y_end, RayQueries& queries, std::span<glm::vec3> rows,
                                 WhittedStats& stats, const std::function<void(int)>& on_rows,
                                 const DiffuseShading& shading) const {
  PENUMBRA_CHECK(0 <= y_begin && y_begin <= y_end && y_end <= settings.height &&
                 rows.size() == size_t(y_end - y_begin) * size_t(settings.width));
  const CameraRays cam(camera, settings.width, settings.height);
  const size_t spp = size_t(settings.spp);
  const size_t width = size_t(settings.width);
  const size_t cap = directCapacity(settings.light_samples);
  const size_t rows_per_wave = std::max<size_t>(1, kWaveQueries / cap / (width * spp));
  const uint64_t seed = mixBits(settings.seed);

  WaveTracer wave(*this, environment_, settings, queries, stats, shading, seed, cap);
  std::vector<TreeNode> nodes;
  for (size_t y0 = size_t(y_begin); y0 < size_t(y_end); y0 += rows_per_wave) {
    const size_t y1 = std::min(size_t(y_end), y0 + rows_per_wave);
    const size_t samples = (y1 - y0) * width * spp;
    wave.sample_sum.assign(samples, glm::vec3(0.0f));
    // The camera rays, stratified within their pixels.
    cameraRays(cam, seed, width, spp, y0, samples, nodes);
    PENUMBRA_TRY(wave.generation(nodes));
    // Pixels: the mean of their samples, summed in order.
    for (size_t local_pixel = 0; local_pixel < samples / spp; ++local_pixel) {
      glm::dvec3 sum(0.0);
      for (size_t s = 0; s < spp; ++s) sum += glm::dvec3(wave.sample_sum[local_pixel * spp + s]);
      const size_t x = local_pixel % width, y = y0 + local_pixel / width;
      rows[(y - size_t(y_begin)) * width + x] = glm::vec3(sum / double(spp));
    }
    if (on_rows) on_rows(int(y1 - y0));
  }
  return {};
}

}  // namespace penumbra
