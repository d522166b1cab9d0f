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

  std::vector<TreeNode> nodes;
  std::vector<glm::vec3> sample_sum;  // per pixel sample of the wave
  std::vector<glm::vec3> value;       // per node: what it adds to its sample
  std::vector<uint8_t> diffuse;       // per node: it ended on a diffuse surface
  std::vector<DiffuseVertex> vertices;
  std::vector<uint32_t> vertex_node;
  std::vector<glm::vec3> extra;
  std::vector<uint32_t> child_offset;
  std::vector<ShadowQuery> shadow;
  std::vector<int> shadow_count;
  std::vector<size_t> shadow_slot;
  std::vector<uint8_t> occluded;
  RayBatch batch;
  HitBatch hits;

  for (size_t y0 = size_t(y_begin); y0 < size_t(y_end); y0 += rows_per_wave) {
    const size_t y1 = std::min(size_t(y_end), y0 + rows_per_wave);
    const size_t samples = (y1 - y0) * width * spp;
    sample_sum.assign(samples, glm::vec3(0.0f));
    // The camera rays, jittered within their pixels.
    nodes.resize(samples);
    parallelRange(samples, 1024, [&](size_t b, size_t e) {
      for (size_t i = b; i < e; ++i) {
        const size_t local_pixel = i / spp, s = i % spp;
        const size_t x = local_pixel % width, y = y0 + local_pixel / width;
        const uint64_t key = mixBits((uint64_t(y) * width + x) * spp + s + 1);
        Rng rng(seed, key);
        const float jx = rng.uniform(), jy = rng.uniform();
        nodes[i] =
            TreeNode{cam.ray(float(x) + jx, float(y) + jy), glm::vec3(1.0f), uint32_t(i), 0, key};
      }
    });
    // One generation: its rays, its shading and shadow rays, then its children, chunk by chunk,
    // each chunk with all its descendants.
    std::function<Status(const std::vector<TreeNode>&)> generation =
        [&](const std::vector<TreeNode>& nodes) -> Status {
      throwIfInterrupted();  // a caller of the library asked to stop (core/interrupt.h)
      const size_t n = nodes.size();
      if (n == 0) return {};
      // 1. This generation's rays, as one batch.
      batch.resize(n);
      for (size_t k = 0; k < n; ++k) batch.set(k, nodes[k].ray);
      PENUMBRA_TRY(queries.intersect(batch, hits));
      stats.rays += n;
      // 2. Shade: emission and the environment, the children of mirrors and glass, the shadow
      //    queries of diffuse vertices.
      value.assign(n, glm::vec3(0.0f));
      diffuse.assign(n, 0);
      child_offset.assign(n + 1, 0);
      shadow.resize(n * cap);
      shadow_count.assign(n, 0);
      if (vertices.size() < n) vertices.resize(n);
      std::vector<std::array<TreeNode, 2>> children(n);
      parallelRange(n, 256, [&](size_t b, size_t e) {
        for (size_t k = b; k < e; ++k) {
          const TreeNode& node = nodes[k];
          const Hit hit = hits.get(k);
          if (!hit.hit()) {
            value[k] = node.weight * environment_;
            continue;
          }
          const SurfaceHit h = geometry_.surfaceHit(hit, node.ray.dir);
          const Material& mat = *h.material;
          if (mat.isEmissive() && h.front) value[k] = node.weight * mat.emission;
          if (mat.isSpecular()) {
            if (node.depth >= settings.max_depth) continue;
            // The reflected and refracted rays, kept until the generation's order is known.
            const SpecularLobes lobes = specularLobes(mat, h.geometric_normal, h.dir);
            for (int l = 0; l < lobes.count; ++l) {
              const SpecularLobe& lobe = lobes.lobe[l];
              children[k][size_t(l)] =
                  TreeNode{Ray{offsetOrigin(h.point, h.offset, h.geometric_normal, lobe.dir), 0.0f,
                               lobe.dir, kRayInfinity},
                           node.weight * lobe.weight, node.sample, node.depth + 1,
                           mixBits(node.key * 2 + uint64_t(l) + 1)};
            }
            child_offset[k + 1] = uint32_t(lobes.count);
            continue;
          }
          if (mat.reflectance == glm::vec3(0.0f)) continue;
          if (!mat.two_sided && !h.front) continue;
          DiffuseVertex& v = vertices[k];
          v.point = h.point;
          v.offset = h.offset;
          v.normal = h.normal;
          v.reflectance = mat.reflectance;
          v.key = node.key;
          diffuse[k] = 1;
          Rng rng(seed, node.key);
          rng.advance(2);  // past the camera jitter of a root
          shadow_count[k] = directQueries(v, settings.light_samples, rng, &shadow[k * cap]);
        }
      });
      // 3. The shadow rays, as one batch.
      shadow_slot.clear();
      for (size_t k = 0; k < n; ++k) {
        for (int q = 0; q < shadow_count[k]; ++q) {
          if (shadow[k * cap + size_t(q)].trace) shadow_slot.push_back(k * cap + size_t(q));
        }
      }
      batch.resize(shadow_slot.size());
      for (size_t j = 0; j < shadow_slot.size(); ++j) batch.set(j, shadow[shadow_slot[j]].ray);
      PENUMBRA_TRY(queries.occluded(batch, occluded));
      stats.shadow_rays += shadow_slot.size();
      for (size_t j = 0; j < shadow_slot.size(); ++j) {
        if (occluded[j]) shadow[shadow_slot[j]].value = glm::vec3(0.0f);
      }
      // 4. The hook's radiance at this generation's diffuse vertices.
      if (shading) {
        vertex_node.clear();
        for (size_t k = 0; k < n; ++k) {
          if (diffuse[k]) vertex_node.push_back(uint32_t(k));
        }
        std::vector<DiffuseVertex> batch_vertices(vertex_node.size());
        for (size_t j = 0; j < vertex_node.size(); ++j)
          batch_vertices[j] = vertices[vertex_node[j]];
        extra.assign(vertex_node.size(), glm::vec3(0.0f));
        PENUMBRA_TRY(shading(batch_vertices, extra, queries));
        for (size_t j = 0; j < vertex_node.size(); ++j) {
          value[vertex_node[j]] += nodes[vertex_node[j]].weight * extra[j];
        }
      }
      // 5. Sum into the pixel samples in node order (so any thread count gives the same sums).
      for (size_t k = 0; k < n; ++k) {
        glm::vec3 direct(0.0f);
        for (int q = 0; q < shadow_count[k]; ++q) direct += shadow[k * cap + size_t(q)].value;
        stats.diffuse_vertices += diffuse[k];
        sample_sum[nodes[k].sample] += value[k] + nodes[k].weight * direct;
      }
      // 6. The next generation: the reflected and refracted rays, in their parents' order.
      for (size_t k = 0; k < n; ++k) child_offset[k + 1] += child_offset[k];
      std::vector<TreeNode> next(child_offset[n]);
      for (size_t k = 0; k < n; ++k) {
        for (uint32_t l = 0; l < child_offset[k + 1] - child_offset[k]; ++l) {
          next[child_offset[k] + l] = children[k][l];
        }
      }
      // Children that carry nothing (a black mirror) are dropped; faint ones go on by Russian
      // roulette.
      size_t kept = 0;
      for (TreeNode& c : next) {
        const float w = std::max({c.weight.x, c.weight.y, c.weight.z});
        if (!(w > 0.0f)) continue;
        if (w < kFaintBranch) {
          Rng rng(seed, c.key);
          if (rng.uniform() * kFaintBranch >= w) continue;
          c.weight *= kFaintBranch / w;
        }
        next[kept++] = c;
      }
      next.resize(kept);
      for (size_t c0 = 0; c0 < next.size(); c0 += kMaxGeneration) {
        const size_t c1 = std::min(next.size(), c0 + kMaxGeneration);
        const std::vector<TreeNode> chunk(next.begin() + std::ptrdiff_t(c0),
                                          next.begin() + std::ptrdiff_t(c1));
        PENUMBRA_TRY(generation(chunk));
      }
      return {};
    };
    PENUMBRA_TRY(generation(nodes));
    // Pixels: the mean of their samples, summed in order.
    for (size_t local_pixel = 0; local_pixel < samples / spp; ++local_pixel) {
      glm::dvec3 sum(0.0);
      for (size_t s = 0; s < spp; ++s) sum += glm::dvec3(sample_sum[local_pixel * spp + s]);
      const size_t x = local_pixel % width, y = y0 + local_pixel / width;
      rows[(y - size_t(y_begin)) * width + x] = glm::vec3(sum / double(spp));
    }
    if (on_rows) on_rows(int(y1 - y0));
  }
  return {};
}

}  // namespace penumbra
