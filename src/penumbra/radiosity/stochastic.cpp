#include "penumbra/radiosity/stochastic.h"
#include "penumbra/radiosity/cutout_jitter.h"

#include "penumbra/core/check.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/core/timer.h"
#include "penumbra/kernels/form_factor.h"
#include "penumbra/radiosity/outside_light.h"
#include "penumbra/radiosity/progressive.h"

#include <fmt/format.h>
#include <glm/common.hpp>
#include <glm/ext/vector_int3_sized.hpp>
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vector_relational.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <utility>

namespace penumbra {

namespace {

// Receivers gathered together: their rays traced as one serial batch (progressive.cpp's size).
constexpr size_t kReceiverBlock = 256;

double luminance(const glm::dvec3& c) {
  return residualLuminance(c);
}

}  // namespace

Expected<StochasticRadiosity> StochasticRadiosity::build(const Scene& scene,
                                                         const StochasticOptions& options) {
  const char* place = "stochastic radiosity";
  if (options.iterations < 0) return inputError("", place, "iterations must not be negative");
  if (!(options.time_limit >= 0.0)) {
    return inputError("", place, "the time limit must be a number of seconds >= 0");
  }
  if (options.shooters < 1 || options.shooters > 4096) {
    return inputError("", place, "shooters per iteration must be in [1, 4096]");
  }
  if (options.burn_in < -1 || options.burn_in > 1000000) {
    return inputError("", place, "burn_in must be in [0, 10^6] (or -1: automatic)");
  }
  if (options.first_shots < 0 || options.first_shots > 4096) {
    return inputError("", place, "first shots must be in [0, 4096]");
  }
  StochasticRadiosity sr;
  sr.options_ = options;
  Expected<RadiositySurface> surface =
      RadiositySurface::build(scene, options.atlas, options.shading_normals);
  if (!surface) return surface.error();
  sr.surface_ = std::move(*surface);
  const size_t n = sr.surface_.elementCount();
  PENUMBRA_TRY(options.first_shots > 0 ? sr.shootFirst(scene) : sr.buildSource(scene));
  double power = 0.0;
  for (size_t e = 0; e < n; ++e) {
    power += luminance(sr.shot_[e] + sr.source_[e]) * sr.surface_.atlas.element_area[e];
    sr.source_power_ += luminance(sr.source_[e]) * sr.surface_.atlas.element_area[e];
  }
  // No light at all is refused as every method refuses it (scene/scene.h); light that reaches no
  // surface (a lamp over nothing but cut-out holes) gives a black solution, as it does there.
  double emitted = 0.0;
  for (size_t e = 0; e < n; ++e) {
    emitted += luminance(sr.surface_.emission[e]) * sr.surface_.atlas.element_area[e];
  }
  if (!(emitted > 0.0) && !hasLightOtherThanSurfaces(scene)) return noLightError(scene, place);
  sr.dark_ = !(power > 0.0);
  sr.b_ = sr.source_;
  // Burn-in: E[B_i] - B = -T^(i+1) B falls at least as fast as the largest reflectance's powers;
  // averaging from the iterate where that is below 1e-3 leaves a bias under 1e-3 / (1 - rho).
  if (options.burn_in >= 0) {
    sr.burn_in_ = options.burn_in;
  } else {
    double rho = 0.0;
    for (size_t e = 0; e < n; ++e) {
      rho = std::max(rho, std::max({sr.surface_.reflectance[e].x, sr.surface_.reflectance[e].y,
                                    sr.surface_.reflectance[e].z}));
    }
    sr.burn_in_ =
        rho > 0.0
            ? int(std::clamp(std::ceil(std::log(1e-3) / std::log(std::min(rho, 0.98))), 0.0, 64.0))
            : 0;
  }
  sr.sum_[0].assign(n, glm::dvec3(0.0));
  sr.sum_[1].assign(n, glm::dvec3(0.0));
  // Each element's pieces, for the near pairs' exact form factor.
  sr.piece_first_.assign(n + 1, 0);
  {
    std::vector<std::array<glm::dvec3, 8>> polys;
    std::vector<int> counts;
    for (size_t e = 0; e < n; ++e) {
      sr.surface_.atlas.elementPieces(e, sr.surface_.flat.positions, sr.surface_.flat.triangles,
                                      polys, counts);
      for (size_t q = 0; q < polys.size(); ++q) {
        if (counts[q] >= 3) sr.pieces_.emplace_back(polys[q], counts[q]);
      }
      sr.piece_first_[e + 1] = uint32_t(sr.pieces_.size());
    }
  }
  sr.buildLocal();
  sr.buildSums();
  return sr;
}

bool StochasticRadiosity::facing(size_t r, uint32_t j, double* d2) const {
  const ChartAtlas& atlas = surface_.atlas;
  if (r == j) return false;
  // A planar chart does not light itself (progressive.cpp: its texels see each other edge-on).
  const uint32_t chart = atlas.element_chart[j];
  if (atlas.element_chart[r] == chart && atlas.charts.charts[chart].planar) return false;
  const glm::dvec3 d = atlas.element_position[j] - atlas.element_position[r];
  *d2 = glm::dot(d, d);
  return *d2 > 0.0 && glm::dot(atlas.element_normal[r], d) > 0.0 &&
         glm::dot(atlas.element_normal[j], d) < 0.0;
}

void StochasticRadiosity::buildLocal() {
  // Elements bucketed in a grid of cells kStochasticLocal texel sizes wide: every local pair of
  // receiver r lies in the 27 cells around r's.
  const ChartAtlas& atlas = surface_.atlas;
  const size_t n = elementCount();
  double max_area = 0.0;
  for (size_t e = 0; e < n; ++e) max_area = std::max(max_area, atlas.element_area[e]);
  const double cell = kStochasticLocal * std::sqrt(max_area);
  const glm::dvec3 lo = glm::dvec3(surface_.bounds.lo);
  const auto cellOf = [&](const glm::dvec3& p) {
    return glm::i64vec3(
        glm::clamp(glm::floor((p - lo) / cell), glm::dvec3(-1.0), glm::dvec3(double(1 << 20))));
  };
  const auto key = [](const glm::i64vec3& c) {
    return uint64_t(c.x + 1) << 42 | uint64_t(c.y + 1) << 21 | uint64_t(c.z + 1);
  };
  std::vector<std::pair<uint64_t, uint32_t>> cells(n);
  for (size_t e = 0; e < n; ++e) cells[e] = {key(cellOf(atlas.element_position[e])), uint32_t(e)};
  std::sort(cells.begin(), cells.end());
  // Per block of receivers, their pairs in a fixed order (cells, then element index), visible
  // ones kept; then joined in order: the same operator on any thread count.
  const size_t blocks = (n + kReceiverBlock - 1) / kReceiverBlock;
  std::vector<std::vector<uint32_t>> counts(blocks);
  std::vector<std::vector<StochasticLocalPair>> pairs(blocks);
  const bool jitter = surface_.textures && surface_.textures->hasCutouts();
  parallelRange(blocks, 1, [&](size_t b0, size_t b1) {
    RayBatch batch;
    HitBatch hits;
    std::vector<uint32_t> owner;
    for (size_t b = b0; b < b1; ++b) {
      const size_t begin = b * kReceiverBlock, end = std::min(n, begin + kReceiverBlock);
      std::vector<StochasticLocalPair>& out = pairs[b];
      owner.clear();
      for (size_t r = begin; r < end; ++r) {
        const glm::i64vec3 c = cellOf(atlas.element_position[r]);
        for (int64_t dz = -1; dz <= 1; ++dz) {
          for (int64_t dy = -1; dy <= 1; ++dy) {
            for (int64_t dx = -1; dx <= 1; ++dx) {
              const glm::i64vec3 q = c + glm::i64vec3(dx, dy, dz);
              if (glm::any(glm::lessThan(q, glm::i64vec3(-1)))) continue;
              const uint64_t k = key(q);
              auto it = std::lower_bound(cells.begin(), cells.end(), std::pair{k, 0u});
              for (; it != cells.end() && it->first == k; ++it) {
                const uint32_t j = it->second;
                double d2 = 0.0;
                if (!facing(r, j, &d2)) continue;
                const double aj = atlas.element_area[j];
                if (!(d2 < kStochasticLocal * kStochasticLocal * aj)) continue;
                double f = 0.0;
                for (uint32_t p = piece_first_[j]; p < piece_first_[j + 1]; ++p) {
                  f += pointToPolygonFormFactor<true>(atlas.element_position[r],
                                                      surface_.shading_normal[r],
                                                      pieces_[p].first.data(), pieces_[p].second);
                }
                if (!(f > 0.0)) continue;
                out.push_back({j, float(f)});
                owner.push_back(uint32_t(r));
              }
            }
          }
        }
      }
      if (options_.visibility && !out.empty()) {
        // The shoot's shadow ray (StochasticRadiosity::shoot), for the same pair.
        batch.resize(out.size());
        for (size_t k = 0; k < out.size(); ++k) {
          const uint32_t r = owner[k], j = out[k].element;
          const glm::dvec3 nj = atlas.element_normal[j];
          const glm::dvec3 to = atlas.element_position[j] + nj * surface_.lift;
          const glm::dvec3 fr = atlas.element_position[r] + atlas.element_normal[r] * surface_.lift;
          const glm::dvec3 end_point =
              jitter ? to + cutoutJitter(nj, atlas.element_area[j], uint64_t(r) << 32 | j) : to;
          batch.set(k, Ray{glm::vec3(fr), 1e-4f, glm::vec3(end_point - fr), 1.0f - 1e-4f});
        }
        surface_.engine.intersectSerial(batch, hits);
        for (size_t k = 0; k < out.size(); ++k) {
          if (hits.triangle[k] >= 0) out[k].factor = 0.0f;
        }
      }
      // Hidden pairs dropped; counts per receiver.
      counts[b].assign(end - begin, 0);
      std::vector<double> row(end - begin, 0.0);
      size_t kept = 0;
      for (size_t k = 0; k < out.size(); ++k) {
        if (out[k].factor == 0.0f) continue;
        row[owner[k] - begin] += out[k].factor;
        out[kept++] = out[k];
        ++counts[b][owner[k] - begin];
      }
      out.resize(kept);
      // The form factors from a point to what it sees sum to at most 1 (its hemisphere). A point
      // in contact with a surface (a column standing on the floor, its base's cap on the floor;
      // the same cap modelled twice) sees each overlapping polygon fill its hemisphere, and the
      // one visibility ray to each centre does not separate them: such a row is scaled back to
      // 1, or the iteration's operator has a norm above 1 and B_m grows without bound.
      size_t k = 0;
      for (size_t i = 0; i < row.size(); ++i) {
        const float scale = row[i] > 1.0 ? float(1.0 / row[i]) : 1.0f;
        for (uint32_t c = 0; c < counts[b][i]; ++c) out[k++].factor *= scale;
      }
    }
  });
  local_first_.assign(n + 1, 0);
  size_t total = 0;
  for (size_t b = 0; b < blocks; ++b) total += pairs[b].size();
  local_.clear();
  local_.reserve(total);
  for (size_t b = 0; b < blocks; ++b) {
    for (size_t i = 0; i < counts[b].size(); ++i) {
      const size_t r = b * kReceiverBlock + i;
      local_first_[r + 1] = local_first_[r] + counts[b][i];
    }
    local_.insert(local_.end(), pairs[b].begin(), pairs[b].end());
    std::vector<StochasticLocalPair>().swap(pairs[b]);
  }
}

Status StochasticRadiosity::buildSource(const Scene& scene) {
  // E' = E + rho (E_direct + S): the lights' direct light and the sky's or the environment's
  // (radiosity/outside_light.h) reflected once, deterministic.
  const size_t n = surface_.elementCount();
  source_ = surface_.emission;
  shot_.assign(n, glm::dvec3(0.0));
  if (!scene.lights.empty()) {
    const std::vector<glm::dvec3> direct =
        surface_.lightIrradiance(scene.lights, options_.visibility);
    for (size_t e = 0; e < n; ++e) source_[e] += surface_.reflectance[e] * direct[e];
  }
  if (const OutsideLight outside(scene); outside.active()) {
    const std::vector<glm::dvec3> s = outside.irradiance(surface_);
    for (size_t e = 0; e < n; ++e) source_[e] += surface_.reflectance[e] * s[e];
  }
  return {};
}

Status StochasticRadiosity::shootFirst(const Scene& scene) {
  // Progressive radiosity's shots (progressive.h) over this surface, in its order (the lights,
  // then the shooter with the most unshot power), until at most kStochasticFirstShotRest of the
  // power is unshot or options.first_shots shooters have shot.
  const Timer timer;
  ProgressiveOptions po;
  po.atlas = options_.atlas;
  po.visibility = options_.visibility;
  po.shading_normals = options_.shading_normals;
  Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(std::move(surface_), scene, po);
  if (!pr) return inputError(pr.error().file, "stochastic radiosity", pr.error().message);
  while (first_shots_ < options_.first_shots && pr->unshotFraction() > kStochasticFirstShotRest) {
    if (pr->step().iteration == 0) break;  // nothing left to shoot
    ++first_shots_;
  }
  // B = B_p - dB + Y, Y = dB + T Y: E' = dB. B_p - dB is the light received, and is exact
  // (dB and B take the same increments) but for a shooter's own.
  const size_t n = pr->elementCount();
  shot_.resize(n);
  source_.resize(n);
  for (size_t e = 0; e < n; ++e) {
    source_[e] = glm::max(pr->residual(e), glm::dvec3(0.0));
    shot_[e] = glm::max(pr->radiosity(e) - pr->residual(e), glm::dvec3(0.0));
  }
  surface_ = std::move(*pr).takeSurface();
  first_seconds_ = timer.seconds();
  return {};
}

void StochasticRadiosity::buildSums() {
  // Sec. 3.1's mipmap: lum(B) A per element, then each level's clusters as sums of their
  // children, then the running sum over the charts' roots.
  const SurfaceHierarchy& h = surface_.hierarchy;
  const size_t n = elementCount();
  level_sums_.resize(h.levelCount());
  level_sums_[0].resize(n);
  parallelRange(n, 1 << 14, [&](size_t b, size_t e) {
    for (size_t i = b; i < e; ++i) {
      level_sums_[0][i] = std::max(luminance(b_[i]), 0.0) * surface_.atlas.element_area[i];
    }
  });
  for (size_t l = 1; l < h.levelCount(); ++l) {
    const ClusterLevel& lv = h.level(l);
    std::vector<double>& sums = level_sums_[l];
    sums.assign(lv.size(), 0.0);
    parallelRange(lv.size(), 1 << 12, [&](size_t b, size_t e) {
      for (size_t k = b; k < e; ++k) {
        double s = 0.0;
        for (uint32_t c = lv.child_first[k]; c < lv.child_first[k + 1]; ++c) {
          s += level_sums_[l - 1][c];
        }
        sums[k] = s;
      }
    });
  }
  root_cdf_.resize(h.chartCount());
  double running = 0.0;
  for (uint32_t c = 0; c < h.chartCount(); ++c) {
    const ClusterRef r = h.root(c);
    running += level_sums_[r.level][r.index];
    root_cdf_[c] = running;
  }
  total_ = running;
}

uint32_t StochasticRadiosity::select(double u, double* probability) const {
  PENUMBRA_CHECK(total_ > 0.0);
  const SurfaceHierarchy& h = surface_.hierarchy;
  // The root whose running sum passes u Phi, then down the levels (the paper's descent: the
  // remaining value compared with the running sum of the four texels below).
  double x = std::clamp(u, 0.0, 1.0) * total_;
  size_t c = size_t(std::upper_bound(root_cdf_.begin(), root_cdf_.end(), x) - root_cdf_.begin());
  // u = 1 or rounding at the top end: the last chart with weight.
  const auto weight = [&](size_t chart) {
    const ClusterRef r = h.root(uint32_t(chart));
    return level_sums_[r.level][r.index];
  };
  if (c >= root_cdf_.size()) {
    c = root_cdf_.size() - 1;
    while (c > 0 && weight(c) <= 0.0) --c;
    x = std::min(x, root_cdf_[c] * (1.0 - 1e-16));
  }
  x -= c == 0 ? 0.0 : root_cdf_[c - 1];
  ClusterRef k = h.root(uint32_t(c));
  while (k.level > 0) {
    const ClusterLevel& lv = h.level(k.level);
    const std::vector<double>& below = level_sums_[k.level - 1];
    uint32_t pick = lv.child_first[k.index + 1] - 1;
    // The last child with weight takes what rounding leaves over.
    while (pick > lv.child_first[k.index] && below[pick] <= 0.0) --pick;
    for (uint32_t ch = lv.child_first[k.index]; ch < lv.child_first[k.index + 1]; ++ch) {
      if (below[ch] <= 0.0) continue;
      if (x < below[ch]) {
        pick = ch;
        break;
      }
      x -= below[ch];
    }
    k = ClusterRef{k.level - 1, pick};
  }
  if (probability) *probability = level_sums_[0][k.index] / total_;
  return k.index;
}

uint64_t StochasticRadiosity::shoot(uint32_t j, double p, double weight,
                                    const std::vector<glm::dvec3>& from,
                                    std::vector<glm::dvec3>& out) const {
  // Eq. 3: rho_r B_j F_rj v / P_j, times `weight` (1 / shooters).
  const ChartAtlas& atlas = surface_.atlas;
  const glm::dvec3 pj = atlas.element_position[j], nj = atlas.element_normal[j];
  const double aj = atlas.element_area[j];
  const glm::dvec3 sent = from[j] * (weight / p);
  const double near2 = kStochasticNear * kStochasticNear * aj;
  const double local2 = kStochasticLocal * kStochasticLocal * aj;
  const size_t n = elementCount();
  std::atomic<uint64_t> rays{0};
  parallelRange(n, kReceiverBlock, [&](size_t begin, size_t end) {
    std::vector<uint32_t> receivers;
    std::vector<double> factors;
    RayBatch batch;
    HitBatch hits;
    receivers.reserve(end - begin);
    factors.reserve(end - begin);
    for (size_t r = begin; r < end; ++r) {
      double d2 = 0.0;
      if (!facing(r, j, &d2) || d2 < local2) continue;  // the local operator's pairs
      const glm::dvec3 d = pj - atlas.element_position[r];
      const glm::dvec3 ns = surface_.shading_normal[r];
      double f = 0.0;
      if (d2 < near2) {
        for (uint32_t q = piece_first_[j]; q < piece_first_[j + 1]; ++q) {
          f += pointToPolygonFormFactor<true>(atlas.element_position[r], ns,
                                              pieces_[q].first.data(), pieces_[q].second);
        }
      } else {
        const double inv = 1.0 / std::sqrt(d2);
        const double cos_r = glm::dot(ns, d) * inv, cos_s = -glm::dot(nj, d) * inv;
        if (cos_r <= 0.0 || cos_s <= 0.0) continue;
        f = discFormFactor(aj, cos_s, cos_r, d2);
      }
      if (!(f > 0.0)) continue;
      receivers.push_back(uint32_t(r));
      factors.push_back(f);
    }
    if (receivers.empty()) return;
    if (options_.visibility) {
      batch.resize(receivers.size());
      const glm::dvec3 to = pj + nj * surface_.lift;
      // Cut-outs: each pair's ray leaves from a spot of j's disc (cutout_jitter.h).
      const bool jitter = surface_.textures && surface_.textures->hasCutouts();
      for (size_t k = 0; k < receivers.size(); ++k) {
        const uint32_t r = receivers[k];
        const glm::dvec3 fr = atlas.element_position[r] + atlas.element_normal[r] * surface_.lift;
        const glm::dvec3 target =
            jitter ? to + cutoutJitter(nj, aj, uint64_t(r) << 32 | uint64_t(j)) : to;
        batch.set(k, Ray{glm::vec3(fr), 1e-4f, glm::vec3(target - fr), 1.0f - 1e-4f});
      }
      surface_.engine.intersectSerial(batch, hits);
      rays += receivers.size();
    }
    for (size_t k = 0; k < receivers.size(); ++k) {
      if (options_.visibility && hits.triangle[k] >= 0) continue;
      const uint32_t r = receivers[k];
      out[r] += surface_.reflectance[r] * sent * factors[k];
    }
  });
  return rays.load();
}

StochasticIteration StochasticRadiosity::step() {
  const Timer timer;
  StochasticIteration it;
  it.iteration = ++iterations_;
  it.power = total_;
  if (dark_) return it;  // nothing to shoot: the solution stays black
  // B_m = E' + T* B_{m-1}: the shooters chosen from B_{m-1} (its sums are current).
  // B_m = E' + L B_{m-1} (the local operator, deterministic) + R* B_{m-1}.
  std::vector<glm::dvec3> next(source_.size());
  parallelRange(next.size(), 1 << 12, [&](size_t b, size_t e) {
    for (size_t r = b; r < e; ++r) {
      glm::dvec3 in(0.0);
      for (uint32_t k = local_first_[r]; k < local_first_[r + 1]; ++k) {
        in += double(local_[k].factor) * b_[local_[k].element];
      }
      next[r] = source_[r] + surface_.reflectance[r] * in;
    }
  });
  // A generator per (seed, iteration), started at a well-mixed state. Taking (seed, iteration)
  // as PCG's (start, stream) made runs with neighbouring seeds pick correlated shooters at each
  // iteration: 32 "independent" runs spread less than their means differed (furnace charts at
  // z = 9).
  Rng rng(mixBits(mixBits(options_.seed) ^ uint64_t(iterations_)), 0x5eedu);
  const double weight = 1.0 / double(options_.shooters);
  // An iterate without light (every first shot absorbed) sends nothing: T* 0 = 0.
  for (int s = 0; s < options_.shooters && total_ > 0.0; ++s) {
    const double u = double(rng.nextU32()) * 0x1p-32 + double(rng.nextU32()) * 0x1p-64;
    double p = 0.0;
    const uint32_t j = select(u, &p);
    if (s == 0) it.shooter = j;
    it.rays += shoot(j, p, weight, b_, next);
  }
  b_ = std::move(next);
  // Eq. 2: the running average after the burn-in, kept as sums by parity (for the error
  // estimate).
  if (averaged() > 0) {
    std::vector<glm::dvec3>& sum = sum_[averaged() & 1];
    parallelRange(b_.size(), 1 << 14, [&](size_t b, size_t e) {
      for (size_t i = b; i < e; ++i) sum[i] += b_[i];
    });
  }
  buildSums();
  it.seconds = timer.seconds();
  return it;
}

Expected<StochasticStats> iterateStochastic(
    const StochasticOptions& options, const std::function<int()>& iterations,
    const std::function<Expected<StochasticIteration>()>& step,
    const std::function<void(const StochasticIteration&)>& after,
    const std::function<bool()>& stop) {
  const Timer timer;
  StochasticStats st;
  while (iterations() < options.iterations) {
    if (stop && stop()) {
      st.interrupted = true;
      break;
    }
    if (options.time_limit > 0.0 && timer.seconds() >= options.time_limit) {
      st.timed_out = true;
      break;
    }
    Expected<StochasticIteration> it = step();
    if (!it) return it.error();
    ++st.iterations;
    st.rays += it->rays;
    if (after) after(*it);
  }
  st.total_iterations = iterations();
  st.seconds = timer.seconds();
  return st;
}

StochasticStats StochasticRadiosity::solve(
    const std::function<void(const StochasticIteration&)>& after,
    const std::function<bool()>& stop) {
  Expected<StochasticStats> st = iterateStochastic(
      options_, [&] { return iterations_; },
      [&]() -> Expected<StochasticIteration> { return step(); }, after, stop);
  PENUMBRA_CHECK(bool(st));  // the CPU's iterations do not fail
  st->error = errorEstimate();
  return *st;
}

glm::dvec3 StochasticRadiosity::radiosity(size_t e) const {
  if (averaged() == 0) return shot_[e] + b_[e];
  return shot_[e] + (sum_[0][e] + sum_[1][e]) / double(averaged());
}

std::vector<glm::dvec3> StochasticRadiosity::radiosity() const {
  std::vector<glm::dvec3> out(elementCount());
  for (size_t e = 0; e < out.size(); ++e) out[e] = radiosity(e);
  return out;
}

double StochasticRadiosity::errorEstimate() const {
  // Half the difference of the odd and even iterations' means estimates the standard error of
  // the mean of all (each half has half the samples). Summed in fixed blocks, then in order, so
  // that the estimate does not depend on the threads.
  const int odd = (averaged() + 1) / 2, even = averaged() / 2;
  if (odd == 0 || even == 0) return 1.0;
  constexpr size_t kBlock = 4096;
  const size_t n = elementCount(), blocks = (n + kBlock - 1) / kBlock;
  std::vector<glm::dvec2> part(blocks, glm::dvec2(0.0));
  parallelRange(blocks, 1, [&](size_t b0, size_t b1) {
    for (size_t b = b0; b < b1; ++b) {
      for (size_t e = b * kBlock; e < std::min(n, (b + 1) * kBlock); ++e) {
        const double a = surface_.atlas.element_area[e];
        const double d = 0.5 * luminance(sum_[1][e] / double(odd) - sum_[0][e] / double(even));
        const double m = luminance(radiosity(e));
        part[b] += glm::dvec2(a * d * d, a * m * m);
      }
    }
  });
  glm::dvec2 sum(0.0);
  for (const glm::dvec2& p : part) sum += p;
  return sum.y > 0.0 ? std::sqrt(sum.x / sum.y) : 0.0;
}

StochasticState StochasticRadiosity::state() const {
  return StochasticState{b_, sum_[1], sum_[0], iterations_};
}

Status StochasticRadiosity::setState(StochasticState state) {
  const size_t n = elementCount();
  if (state.iterate.size() != n || state.sum_odd.size() != n || state.sum_even.size() != n) {
    return inputError(
        "", "stochastic radiosity",
        fmt::format("the state has {} elements, the solver {}", state.iterate.size(), n));
  }
  if (state.iterations < 0) return inputError("", "stochastic radiosity", "negative iterations");
  for (size_t e = 0; e < n; ++e) {
    for (const glm::dvec3* v : {&state.iterate[e], &state.sum_odd[e], &state.sum_even[e]}) {
      for (int c = 0; c < 3; ++c) {
        if (!std::isfinite((*v)[c]) || (*v)[c] < 0.0) {
          return inputError("", "stochastic radiosity",
                            fmt::format("element {}: radiosity must be finite and >= 0", e));
        }
      }
    }
  }
  b_ = std::move(state.iterate);
  sum_[1] = std::move(state.sum_odd);
  sum_[0] = std::move(state.sum_even);
  iterations_ = state.iterations;
  buildSums();
  if (!(total_ > 0.0) && source_power_ > 0.0) {
    return inputError("", "stochastic radiosity", "the state's iterate holds no light");
  }
  return {};
}

Image StochasticRadiosity::radianceImage() const {
  return surface_.radianceImage(radiosity());
}

}  // namespace penumbra
