#include "penumbra/radiosity/progressive.h"

#include "penumbra/geometry/shading_normals.h"
#include "penumbra/kernels/form_factor.h"

#include "penumbra/core/check.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <utility>

namespace penumbra {

namespace {

constexpr double kPi = 3.14159265358979323846;

constexpr uint32_t kNoElement = std::numeric_limits<uint32_t>::max();

// A shooter point: an element, or a block of elements at a coarser mip level (substructuring,
// Wallner sec. 3: the block's mean position, summed area and area-weighted mean dB), with its
// sub-blocks one level finer (elements at the finest).
struct ShooterPoint {
  glm::dvec3 position{0.0};
  double area = 0.0;
  glm::dvec3 residual{0.0};
  glm::dvec3 normal{0.0};          // area-weighted mean shading normal (unit)
  uint32_t element = kNoElement;   // a single element: which
  std::vector<uint32_t> children;  // a block: its sub-blocks (points)
  glm::ivec2 texel{0};             // atlas texel of one member (for grouping into blocks)
  glm::ivec2 lo{0}, hi{0};         // the lattice points of its chart it covers (inclusive)
  bool above_top = false;          // a block coarser than the substructuring's top level
  int32_t polygon = -1;            // hierarchical blocks: index of its polygon
};

// Numbers the blocks of 2^level x 2^level atlas texels that `texels` fall in, in order of first
// appearance, through a dense grid over their range: block[i] is texels[i]'s. Returns the count.
uint32_t groupIntoBlocks(const std::vector<glm::ivec2>& texels, int level,
                         std::vector<uint32_t>& block) {
  glm::ivec2 lo(std::numeric_limits<int>::max()), hi(std::numeric_limits<int>::min());
  for (const glm::ivec2& t : texels) {
    lo = glm::min(lo, t >> level);
    hi = glm::max(hi, t >> level);
  }
  block.resize(texels.size());
  if (texels.empty()) return 0;
  const size_t w = size_t(hi.x - lo.x + 1);
  std::vector<int32_t> grid(w * size_t(hi.y - lo.y + 1), -1);
  uint32_t count = 0;
  for (size_t i = 0; i < texels.size(); ++i) {
    const glm::ivec2 key = (texels[i] >> level) - lo;
    int32_t& slot = grid[size_t(key.y) * w + size_t(key.x)];
    if (slot < 0) slot = int32_t(count++);
    block[i] = uint32_t(slot);
  }
  return count;
}

// Wallner eq. 2 with one disc (m = 1): the form factor from a receiver point to a shooter
// element of area `shooter_area` at squared distance d2, given both cosines.
inline double discFormFactor(double shooter_area, double cos_shooter, double cos_receiver,
                             double d2) {
  return shooter_area * cos_shooter * cos_receiver / (kPi * d2 + shooter_area);
}

// Whether every corner of the triangle lies on or behind the plane (point c, normal n).
bool behindPlane(const glm::dvec3 (&v)[3], const glm::dvec3& c, const glm::dvec3& n) {
  for (const glm::dvec3& p : v) {
    if (glm::dot(n, p - c) > 0.0) return false;
  }
  return true;
}

// Exact coverage of a texel by its chart (lightmap_atlas.h: lattice point (i, j) of a chart with
// legs `leg`): the texel square [i-1/2, i+1/2] x [j-1/2, j+1/2] clipped to the chart triangle
// i, j >= 0, i + j <= leg (Sutherland-Hodgman). Returns the area (lattice units) and centroid.
// The clipped squares of a chart's kInside texels tile the chart exactly.
// More generally, the texels of lattice points [lo, hi] (a block of texels, inclusive) together.
double blockCoverage(glm::ivec2 lo, glm::ivec2 hi, int leg, glm::dvec2& centroid,
                     std::vector<glm::dvec2>* polygon = nullptr) {
  std::vector<glm::dvec2> poly = {{lo.x - 0.5, lo.y - 0.5},
                                  {hi.x + 0.5, lo.y - 0.5},
                                  {hi.x + 0.5, hi.y + 0.5},
                                  {lo.x - 0.5, hi.y + 0.5}};
  // Half-planes a . p <= b.
  const glm::dvec2 normals[3] = {{-1.0, 0.0}, {0.0, -1.0}, {1.0, 1.0}};
  const double offsets[3] = {0.0, 0.0, double(leg)};
  for (int h = 0; h < 3; ++h) {
    std::vector<glm::dvec2> out;
    for (size_t k = 0; k < poly.size(); ++k) {
      const glm::dvec2 a = poly[k], b = poly[(k + 1) % poly.size()];
      const double da = glm::dot(normals[h], a) - offsets[h];
      const double db = glm::dot(normals[h], b) - offsets[h];
      if (da <= 0.0) out.push_back(a);
      if ((da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0))
        out.push_back(a + (b - a) * (da / (da - db)));
    }
    poly = std::move(out);
    if (poly.empty()) break;
  }
  if (polygon) *polygon = poly;
  double area2 = 0.0;
  glm::dvec2 c(0.0);
  for (size_t k = 0; k < poly.size(); ++k) {
    const glm::dvec2 a = poly[k], b = poly[(k + 1) % poly.size()];
    const double cr = a.x * b.y - b.x * a.y;
    area2 += cr;
    c += (a + b) * cr;
  }
  if (area2 <= 0.0) {
    centroid = 0.5 * glm::dvec2(lo + hi);
    return 0.0;
  }
  centroid = c / (3.0 * area2);
  return 0.5 * area2;
}

double texelCoverage(int i, int j, int leg, glm::dvec2& centroid,
                     std::vector<glm::dvec2>* polygon = nullptr) {
  return blockCoverage(glm::ivec2(i, j), glm::ivec2(i, j), leg, centroid, polygon);
}

}  // namespace

constexpr double kNear = kProgressiveNear;
// Hierarchical mode: eq. 2's disc only for points farther than this many of their sizes, and
// Lambert's exact point-to-polygon form factor to the block's polygon nearer (from kNear on; a
// block nearer than kNear sizes is refined). The disc's error falls with the square of
// size / distance: with discs from 3 sizes on, the furnace's worst element was 1.4% off, from 8
// sizes on 0.81% (the flat scheme's), but discs alone needed refining blocks down to 8 sizes,
// which at millions of elements costs hundreds of pairs per receiver; the polygon keeps a
// receiver's pairs near the top level's count.
constexpr double kFar = 8.0;
// Hierarchical mode: blocks coarser than the top level (up to the whole shooter) serve receivers
// farther than this many of their sizes (a small shooter far away shoots as one point).
constexpr double kCoarse = 20.0;
// Receivers gathered together: their pairs, rays and hits (about 12 pairs per receiver) fit in
// the L2 cache.
constexpr size_t kReceiverBlock = 256;

int ProgressiveRadiosity::elementPolygon(uint32_t e, std::array<glm::dvec3, 8>& out) const {
  return blockPolygon(tri_of_[e], lattice_[e], lattice_[e], out);
}

int ProgressiveRadiosity::blockPolygon(uint32_t t, glm::ivec2 lo, glm::ivec2 hi,
                                       std::array<glm::dvec3, 8>& out) const {
  const glm::uvec3 tri = flat_.triangles[t];
  const glm::dvec3 p[3] = {glm::dvec3(flat_.positions[tri.x]), glm::dvec3(flat_.positions[tri.y]),
                           glm::dvec3(flat_.positions[tri.z])};
  const AtlasChart& chart = atlas_.charts[t];
  const uint32_t r0 = chart.right, r1 = (chart.right + 1) % 3, r2 = (chart.right + 2) % 3;
  glm::dvec2 c;
  std::vector<glm::dvec2> poly;
  blockCoverage(lo, hi, chart.leg, c, &poly);
  const int count = int(std::min<size_t>(poly.size(), out.size()));
  for (int k = 0; k < count; ++k) {
    out[size_t(k)] = p[r0] + (poly[size_t(k)].x / chart.leg) * (p[r1] - p[r0]) +
                     (poly[size_t(k)].y / chart.leg) * (p[r2] - p[r0]);
  }
  return count;
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
  if (options.shooter_top_points < 0) {
    return inputError("", "progressive radiosity", "shooter_top_points must not be negative");
  }
  ProgressiveRadiosity pr;
  pr.options_ = options;
  pr.flat_ = flattenScene(scene);
  Expected<LightmapAtlas> atlas =
      buildLightmapAtlas(pr.flat_.positions, pr.flat_.triangles, options.atlas);
  if (!atlas.ok()) return atlas.error();
  pr.atlas_ = std::move(*atlas);
  pr.engine_ = RayEngine::build(pr.flat_.positions, pr.flat_.triangles);
  const Bounds3 box = pr.engine_.bounds();
  pr.lift_ = 1e-5 * double(glm::length(box.hi - box.lo));  // as radiosity/form_factors.cpp

  // Elements: kInside texels, grouped by triangle (counting sort over the atlas).
  const size_t nt = pr.flat_.triangles.size();
  const LightmapAtlas& a = pr.atlas_;
  std::vector<uint32_t> count(nt + 1, 0);
  for (size_t i = 0; i < a.texel_kind.size(); ++i) {
    if (a.texel_kind[i] == AtlasTexelKind::kInside) ++count[size_t(a.texel_triangle[i]) + 1];
  }
  pr.tri_first_.assign(nt + 1, 0);
  for (size_t t = 0; t < nt; ++t) pr.tri_first_[t + 1] = pr.tri_first_[t] + count[t + 1];
  const size_t n = pr.tri_first_[nt];
  pr.texel_.resize(n);
  pr.tri_of_.resize(n);
  {
    std::vector<uint32_t> next(pr.tri_first_.begin(), pr.tri_first_.end() - 1);
    for (size_t i = 0; i < a.texel_kind.size(); ++i) {
      if (a.texel_kind[i] != AtlasTexelKind::kInside) continue;
      const uint32_t t = uint32_t(a.texel_triangle[i]);
      pr.texel_[next[t]] = uint32_t(i);
      pr.tri_of_[next[t]++] = t;
    }
  }
  pr.tri_area_.resize(nt);
  pr.tri_normal_.resize(nt);
  for (size_t t = 0; t < nt; ++t) {
    const glm::uvec3 tri = pr.flat_.triangles[t];
    const glm::dvec3 p0 = pr.flat_.positions[tri.x], p1 = pr.flat_.positions[tri.y],
                     p2 = pr.flat_.positions[tri.z];
    const glm::dvec3 c = glm::cross(p1 - p0, p2 - p0);
    const double len = glm::length(c);
    pr.tri_area_[t] = 0.5 * len;
    pr.tri_normal_[t] = len > 0.0 ? c / len : glm::dvec3(0.0);
  }
  pr.area_.resize(n);
  pr.position_.resize(n);
  pr.lattice_.resize(n);
  pr.rho_.resize(n);
  pr.e_.resize(n);
  pr.normal_.resize(n);
  const std::vector<glm::vec3> corner_normals =
      options.shading_normals ? cornerShadingNormals(scene) : std::vector<glm::vec3>();
  glm::dvec3 rho_area(0.0);
  for (size_t e = 0; e < n; ++e) {
    const uint32_t t = pr.tri_of_[e];
    const glm::uvec3 tri = pr.flat_.triangles[t];
    const glm::dvec3 p0 = pr.flat_.positions[tri.x], p1 = pr.flat_.positions[tri.y],
                     p2 = pr.flat_.positions[tri.z];
    // Exact coverage (the CPU variant of the paper's occlusion-query count): the
    // element is the part of the triangle its texel square covers; its point is that part's
    // centroid. (Texel centres themselves sit on the triangle's edges along the chart's
    // boundary, where a point sees the neighbouring faces edge-on.)
    const AtlasChart& chart = a.charts[t];
    const glm::vec2 bw = a.texel_barycentric[pr.texel_[e]];
    const double w[3] = {1.0 - double(bw.x) - double(bw.y), double(bw.x), double(bw.y)};
    const glm::dvec3 p[3] = {p0, p1, p2};
    const uint32_t r0 = chart.right, r1 = (chart.right + 1) % 3, r2 = (chart.right + 2) % 3;
    const int i = int(std::lround(w[r1] * chart.leg)), j = int(std::lround(w[r2] * chart.leg));
    glm::dvec2 c;
    const double cover = texelCoverage(i, j, chart.leg, c);
    pr.lattice_[e] = glm::ivec2(i, j);
    pr.position_[e] =
        p[r0] + (c.x / chart.leg) * (p[r1] - p[r0]) + (c.y / chart.leg) * (p[r2] - p[r0]);
    pr.area_[e] = pr.tri_area_[t] * cover / (0.5 * double(chart.leg) * double(chart.leg));
    pr.normal_[e] = pr.tri_normal_[t];
    if (!corner_normals.empty() && pr.tri_area_[t] > 0.0) {
      // The corners' shading normals interpolated at the element's point (sec. 3).
      double cw[3];
      cw[r1] = c.x / chart.leg;
      cw[r2] = c.y / chart.leg;
      cw[r0] = 1.0 - cw[r1] - cw[r2];
      glm::dvec3 sn(0.0);
      for (int k = 0; k < 3; ++k)
        sn += cw[k] * glm::dvec3(corner_normals[3 * size_t(t) + size_t(k)]);
      const double len = glm::length(sn);
      if (len > 0.0 && glm::dot(sn, pr.tri_normal_[t]) > 0.0) pr.normal_[e] = sn / len;
    }
    const Material& m = scene.materials[pr.flat_.material_ids[t]];
    pr.rho_[e] = glm::dvec3(m.reflectance);
    pr.e_[e] = pr.tri_area_[t] > 0.0 ? kPi * glm::dvec3(m.emission) : glm::dvec3(0.0);
    pr.total_area_ += pr.area_[e];
    rho_area += pr.rho_[e] * pr.area_[e];
    pr.balance_.emitted += pr.e_[e] * pr.area_[e];
  }
  if (residualLuminance(pr.balance_.emitted) <= 0.0) {
    return inputError(scene.source, "progressive radiosity", "the scene emits no light");
  }
  // Eq. 6, per channel.
  pr.ambient_factor_ = 1.0 / (1.0 - rho_area / pr.total_area_);
  pr.b_ = pr.e_;
  pr.db_ = pr.e_;
  pr.refreshTrianglePowers();
  pr.balance_.unshot = pr.balance_.emitted;
  return pr;
}

double ProgressiveRadiosity::residualPower(uint32_t triangle) const {
  PENUMBRA_CHECK(triangle < triangleCount());
  const uint32_t first = tri_first_[triangle], last = tri_first_[triangle + 1];
  if (first == last) return 0.0;
  // The CPU twin of the paper's reduction over occupied texels only: the paper averages the
  // texels with equal weights and multiplies by the triangle's area; with exact coverage the
  // texels' areas differ along the chart's edges, so each is weighted by its own area.
  double sum = 0.0;
  for (uint32_t e = first; e < last; ++e) sum += residualLuminance(db_[e]) * area_[e];
  return sum;
}

void ProgressiveRadiosity::refreshTrianglePowers() {
  tri_power_.resize(triangleCount());
  parallelRange(triangleCount(), 256, [&](size_t b, size_t e) {
    for (size_t t = b; t < e; ++t) tri_power_[t] = residualPower(uint32_t(t));
  });
}

uint32_t ProgressiveRadiosity::selectShooter() const {
  uint32_t best = kNoShooter;
  double best_power = 0.0;
  for (uint32_t t = 0; t < triangleCount(); ++t) {
    const double p = tri_power_[t];  // residualPower(t), kept up to date by shoot()
    if (p > best_power) {
      best_power = p;
      best = t;
    }
  }
  return best;
}

std::vector<std::vector<uint32_t>> ProgressiveRadiosity::shooterBlocks(uint32_t t,
                                                                       int level) const {
  std::vector<uint32_t> elements, block;
  std::vector<glm::ivec2> texels;
  for (uint32_t e = tri_first_[t]; e < tri_first_[t + 1]; ++e) {
    if (!(area_[e] > 0.0)) continue;
    elements.push_back(e);
    texels.emplace_back(int(texel_[e] % uint32_t(atlas_.width)),
                        int(texel_[e] / uint32_t(atlas_.width)));
  }
  std::vector<std::vector<uint32_t>> blocks(groupIntoBlocks(texels, level, block));
  for (size_t i = 0; i < elements.size(); ++i) blocks[block[i]].push_back(elements[i]);
  return blocks;
}

ProgressiveIteration ProgressiveRadiosity::shoot(uint32_t shooter) {
  PENUMBRA_CHECK(shooter < triangleCount());
  const Timer timer;
  ProgressiveIteration it;
  it.iteration = ++iterations_;
  it.shooter = shooter;
  const uint32_t first = tri_first_[shooter], last = tri_first_[shooter + 1];
  const glm::dvec3 ns = tri_normal_[shooter];

  // Shooter points (sec. 3). Flat mode (shooter_top_points = 0, the paper's): blocks of
  // 2^level x 2^level atlas texels. Hierarchical mode: every level from the elements up to the
  // first with at most shooter_top_points blocks; receivers start from that level's blocks and
  // descend where a block is near (below).
  std::vector<ShooterPoint> points;
  std::vector<uint32_t> top;    // the substructuring's points (at most shooter_top_points)
  std::vector<uint32_t> roots;  // what receivers start from: top, or blocks of it above
  std::vector<std::pair<std::array<glm::dvec3, 8>, int>> polygons;
  const bool hierarchical = options_.shooter_top_points > 0;
  glm::dvec3 shot(0.0);
  {
    // Groups the points `from` into blocks of the level `level` (their parents, appended).
    std::vector<glm::ivec2> texels;
    std::vector<uint32_t> block;
    auto group = [&](const std::vector<uint32_t>& from, int level) {
      texels.clear();
      for (uint32_t c : from) texels.push_back(points[c].texel);
      const uint32_t first_block = uint32_t(points.size());
      points.resize(first_block + groupIntoBlocks(texels, level, block));
      std::vector<uint32_t> out(points.size() - first_block);
      for (size_t k = 0; k < out.size(); ++k) out[k] = first_block + uint32_t(k);
      for (size_t i = 0; i < from.size(); ++i) {
        ShooterPoint& p = points[first_block + block[i]];
        const ShooterPoint& q = points[from[i]];
        if (p.children.empty()) {
          p.texel = q.texel;
          p.lo = q.lo;
          p.hi = q.hi;
        }
        p.lo = glm::min(p.lo, q.lo);
        p.hi = glm::max(p.hi, q.hi);
        p.position += q.position * q.area;
        p.normal += q.normal * q.area;
        p.residual += q.residual * q.area;
        p.area += q.area;
        p.children.push_back(from[i]);
      }
      for (uint32_t b : out) {
        points[b].normal = glm::normalize(points[b].normal);
        points[b].position /= points[b].area;
        points[b].residual /= points[b].area;
      }
      return out;
    };
    std::vector<uint32_t> level0;
    for (uint32_t e = first; e < last; ++e) {
      shot += db_[e] * area_[e];
      if (!(area_[e] > 0.0)) continue;
      ShooterPoint p;
      p.position = position_[e];
      p.area = area_[e];
      p.residual = db_[e];
      p.normal = normal_[e];
      p.element = e;
      p.lo = p.hi = lattice_[e];
      p.texel = glm::ivec2(int(texel_[e] % uint32_t(atlas_.width)),
                           int(texel_[e] / uint32_t(atlas_.width)));
      level0.push_back(uint32_t(points.size()));
      points.push_back(std::move(p));
    }
    if (hierarchical) {
      top = level0;
      int level = 1;
      for (; top.size() > size_t(options_.shooter_top_points) && level <= 16; ++level) {
        top = group(top, level);
      }
      // Above the top level, up to one block: coarser points for receivers far from the whole
      // shooter (below).
      roots = top;
      for (; roots.size() > 1 && level <= 24; ++level) {
        roots = group(roots, level);
        for (uint32_t b : roots) points[b].above_top = true;
      }
      // The blocks' polygons: the chart's part their texels cover together.
      std::vector<uint32_t> blocks;
      for (uint32_t k = 0; k < points.size(); ++k) {
        if (!points[k].children.empty()) blocks.push_back(k);
      }
      polygons.resize(blocks.size());
      parallelRange(blocks.size(), 256, [&](size_t b0, size_t b1) {
        for (size_t b = b0; b < b1; ++b) {
          ShooterPoint& p = points[blocks[b]];
          p.polygon = int32_t(b);
          polygons[b].second = blockPolygon(shooter, p.lo, p.hi, polygons[b].first);
        }
      });
    } else {
      // Flat mode: the blocks of one level, whose elements are their children.
      top = options_.shooter_level > 0 ? group(level0, options_.shooter_level) : level0;
      roots = top;
    }
    for (std::vector<uint32_t>* list : {&top, &roots}) {
      list->erase(std::remove_if(list->begin(), list->end(),
                                 [&](uint32_t p) { return points[p].residual == glm::dvec3(0.0); }),
                  list->end());
    }
  }
  it.shooter_points = uint32_t(top.size());

  // Receiver triangles: not wholly behind the shooter's plane, and facing it (the shooter not
  // wholly behind theirs). Coplanar triangles drop out here or through a zero cosine.
  std::vector<uint8_t> receives(triangleCount(), 0);
  if (tri_area_[shooter] > 0.0) {
    const glm::uvec3 st = flat_.triangles[shooter];
    const glm::dvec3 sv[3] = {glm::dvec3(flat_.positions[st.x]), glm::dvec3(flat_.positions[st.y]),
                              glm::dvec3(flat_.positions[st.z])};
    for (uint32_t t = 0; t < triangleCount(); ++t) {
      if (t == shooter || tri_area_[t] <= 0.0) continue;
      const glm::uvec3 rt = flat_.triangles[t];
      const glm::dvec3 rv[3] = {glm::dvec3(flat_.positions[rt.x]),
                                glm::dvec3(flat_.positions[rt.y]),
                                glm::dvec3(flat_.positions[rt.z])};
      if (behindPlane(rv, sv[0], ns) || behindPlane(sv, rv[0], tri_normal_[t])) continue;
      receives[t] = 1;
    }
  }

  // Gather at every receiver element the irradiance sum_s dB_s F_rs (W m^-2); in parallel over
  // chunks of receivers, each writing only its own entries. A receiver's pairs come from the top
  // points: a point farther than kNear of its sizes is one pair; a nearer one descends to its
  // sub-blocks (hierarchical mode) or, at the elements or in flat mode, is a near pair whose
  // members each contribute Lambert's exact point-to-polygon form factor. Each
  // pair has one shadow ray; a chunk's rays are traced together, so the rays from one receiver
  // to the points of one shooter (or from neighbouring texels to one point) travel as packets of
  // eight (raytrace/cpu_packet.h). Each receiver sums its pairs in a fixed order, so the result
  // does not depend on the chunking.
  enum class Kernel : uint8_t {
    kDisc,     // eq. 2 with the point's area, position and mean residual
    kPolygon,  // Lambert's point-to-polygon form factor to a block's polygon, mean residual
    kMembers,  // the same to each member element's own polygon, with its own residual
  };
  struct Pair {
    uint32_t receiver;
    uint32_t point;
    Kernel kernel;
  };
  const size_t n = elementCount();
  std::vector<glm::dvec3>& incident = incident_;
  incident.resize(n);
  parallelRange(n, 1 << 16, [&](size_t b, size_t e) {
    std::fill(incident.begin() + std::ptrdiff_t(b), incident.begin() + std::ptrdiff_t(e),
              glm::dvec3(0.0));
  });
  std::atomic<uint64_t> rays{0};
  parallelRange(n, 256, [&](size_t begin, size_t end) {
    std::vector<Pair> pairs;
    std::vector<uint32_t> stack;
    std::vector<uint64_t> order;  // (point, pair index): sorted, the pairs by point, stably
    std::vector<uint8_t> occluded;
    RayBatch batch;
    HitBatch hits;
    // Blocks of receivers small enough that their pairs and rays stay in the caches.
    for (size_t block = begin; block < end; block += kReceiverBlock) {
      pairs.clear();
      for (size_t r = block; r < std::min(end, block + kReceiverBlock); ++r) {
        const uint32_t t = tri_of_[r];
        if (!receives[t]) continue;
        const glm::dvec3 nr = tri_normal_[t], pr = position_[r];
        stack.assign(roots.rbegin(), roots.rend());
        while (!stack.empty()) {
          const uint32_t k = stack.back();
          stack.pop_back();
          const ShooterPoint& s = points[k];
          const glm::dvec3 d = s.position - pr;
          const double d2 = glm::dot(d, d);
          const bool near = d2 < kNear * kNear * s.area;
          // Blocks above the top level stand for their sub-blocks only for receivers farther than
          // kCoarse of their sizes: to those the whole block subtends a few degrees at most, so one
          // visibility ray loses no penumbra worth resolving.
          if (hierarchical && (near || (s.above_top && d2 < kCoarse * kCoarse * s.area)) &&
              !s.children.empty()) {
            for (auto c = s.children.rbegin(); c != s.children.rend(); ++c) {
              if (points[*c].residual != glm::dvec3(0.0)) stack.push_back(*c);
            }
            continue;
          }
          if (d2 <= 0.0) continue;
          if (glm::dot(nr, d) <= 0.0 || glm::dot(ns, d) >= 0.0) continue;  // culled by either plane
          Kernel kernel = near ? Kernel::kMembers : Kernel::kDisc;
          if (hierarchical && d2 < kFar * kFar * s.area) {
            kernel = s.children.empty() ? Kernel::kMembers : Kernel::kPolygon;
          }
          pairs.push_back(Pair{uint32_t(r), k, kernel});
        }
      }
      if (options_.visibility && !pairs.empty()) {
        // Rays in shooter-point order (stable: receivers in texel order within a point), so that
        // each aligned group of eight goes from neighbouring texels to one point: a packet.
        order.resize(pairs.size());
        for (size_t k = 0; k < pairs.size(); ++k) order[k] = uint64_t(pairs[k].point) << 32 | k;
        std::sort(order.begin(), order.end());
        batch.resize(pairs.size());
        for (size_t k = 0; k < pairs.size(); ++k) {
          const Pair& pair = pairs[uint32_t(order[k])];
          const glm::dvec3 from = position_[pair.receiver] +
                                  tri_normal_[tri_of_[pair.receiver]] * lift_,
                           to = points[pair.point].position + ns * lift_;
          batch.set(k, Ray{glm::vec3(from), 1e-4f, glm::vec3(to - from), 1.0f - 1e-4f});
        }
        engine_.intersectSerial(batch, hits);
        occluded.assign(pairs.size(), 0);
        for (size_t k = 0; k < pairs.size(); ++k)
          occluded[uint32_t(order[k])] = hits.triangle[k] >= 0;
        rays += pairs.size();
      }
      for (size_t k = 0; k < pairs.size(); ++k) {
        if (options_.visibility && occluded[k]) continue;
        const size_t r = pairs[k].receiver;
        const ShooterPoint& s = points[pairs[k].point];
        // Form factors take the shading normals; culling and shadow rays the triangles' own.
        const glm::dvec3 nr = normal_[r], pr = position_[r];
        if (pairs[k].kernel == Kernel::kPolygon) {
          const auto& [poly, count] = polygons[size_t(s.polygon)];
          if (count >= 3)
            incident[r] += s.residual * pointToPolygonFormFactor<true>(pr, nr, poly.data(), count);
          continue;
        }
        if (pairs[k].kernel == Kernel::kMembers) {
          // Near pairs (across an edge, in a corner): eq. 2's disc is a poor stand-in for a
          // neighbour seen edge-on, so each of the point's elements contributes Lambert's exact
          // point-to-polygon form factor (kernels/form_factor.h) to its own polygon.
          auto add = [&](uint32_t m) {
            std::array<glm::dvec3, 8> poly;
            const int count = elementPolygon(m, poly);
            if (count >= 3) {
              incident[r] += db_[m] * pointToPolygonFormFactor<true>(pr, nr, poly.data(), count);
            }
          };
          if (s.element != kNoElement) add(s.element);
          for (uint32_t c : s.children) add(points[c].element);  // flat mode's blocks
          continue;
        }
        const glm::dvec3 d = s.position - pr;
        const double d2 = glm::dot(d, d);
        const double inv = 1.0 / std::sqrt(d2);
        const double cos_r = glm::dot(nr, d) * inv, cos_s = -glm::dot(s.normal, d) * inv;
        if (cos_r <= 0.0 || cos_s <= 0.0) continue;
        incident[r] += s.residual * discFormFactor(s.area, cos_s, cos_r, d2);
      }
    }
  });

  // Update (progressive eq. 1), per triangle in parallel: each triangle's elements in order, its
  // residual power (for the next shooter selection) and its share of the energy books; the books
  // are then summed over triangles in order, so they do not depend on the threads.
  for (uint32_t e = first; e < last; ++e) db_[e] = glm::dvec3(0.0);
  struct Books {
    glm::dvec3 arrived{0.0}, absorbed{0.0}, reflected{0.0};
  };
  std::vector<Books> books(triangleCount());
  parallelRange(triangleCount(), 64, [&](size_t t_begin, size_t t_end) {
    for (size_t t = t_begin; t < t_end; ++t) {
      Books& k = books[t];
      const bool changed = receives[t] || t == shooter;
      if (!changed) continue;
      for (uint32_t r = tri_first_[t]; r < tri_first_[t + 1]; ++r) {
        if (incident[r] == glm::dvec3(0.0)) continue;
        const glm::dvec3 gain = rho_[r] * incident[r];
        b_[r] += gain;
        db_[r] += gain;
        k.arrived += incident[r] * area_[r];
        k.absorbed += (glm::dvec3(1.0) - rho_[r]) * incident[r] * area_[r];
        k.reflected += gain * area_[r];
      }
      tri_power_[t] = residualPower(uint32_t(t));
    }
  });
  glm::dvec3 arrived(0.0);
  for (const Books& k : books) {
    arrived += k.arrived;
    balance_.absorbed += k.absorbed;
    balance_.unshot += k.reflected;
  }
  balance_.unshot -= shot;
  balance_.escaped += shot - arrived;

  it.shot_power = residualLuminance(shot);
  it.unshot_fraction = unshotFraction();
  it.rays = rays.load();
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
  return ProgressiveState{b_, db_, balance_, iterations_};
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
  b_ = std::move(state.radiosity);
  db_ = std::move(state.residual);
  refreshTrianglePowers();
  balance_ = state.balance;
  iterations_ = state.iterations;
  return {};
}

glm::dvec3 ProgressiveRadiosity::unshotPower() const {
  glm::dvec3 sum(0.0);
  for (size_t e = 0; e < elementCount(); ++e) sum += db_[e] * area_[e];
  return sum;
}

double ProgressiveRadiosity::unshotFraction() const {
  return residualLuminance(balance_.unshot) / residualLuminance(balance_.emitted);
}

glm::dvec3 ProgressiveRadiosity::ambient() const {
  // Eq. 4 with F'_ij = A_j / sum_k A_k (eq. 5) and R of eq. 6.
  return ambient_factor_ * unshotPower() / total_area_;
}

glm::dvec3 ProgressiveRadiosity::displayRadiosity(size_t element) const {
  return b_[element] + rho_[element] * ambient();
}

Image ProgressiveRadiosity::radianceImage(bool with_ambient) const {
  const LightmapAtlas& a = atlas_;
  Image img(a.width, a.height);
  std::vector<uint8_t> known(a.texel_kind.size(), 0);
  const glm::dvec3 amb = with_ambient ? ambient() : glm::dvec3(0.0);
  for (size_t e = 0; e < elementCount(); ++e) {
    img.pixels[texel_[e]] = glm::vec3((b_[e] + rho_[e] * amb) / kPi);
    known[texel_[e]] = 1;
  }
  // Border texels (the row past each chart's hypotenuse, lattice points i + j = leg + 1): the
  // plane through the three inside texels before it, v(i-1, j) + v(i, j-1) - v(i-1, j-1), so
  // that bilinear lookups near the hypotenuse continue the chart's gradient instead of
  // flattening it (with copies, the two triangles of a quad meet in a faint seam along their
  // diagonal); clamped at 0.
  for (uint32_t t = 0; t < triangleCount(); ++t) {
    if (tri_first_[t] == tri_first_[t + 1]) continue;
    const int leg = a.charts[t].leg;
    auto at = [&](int i, int j) {
      const glm::ivec2 p = a.chartTexel(t, i, j);
      return a.texelIndex(p.x, p.y);
    };
    for (int i = 1; i <= leg; ++i) {
      const int j = leg + 1 - i;
      const size_t border = at(i, j), u = at(i - 1, j), v = at(i, j - 1), w = at(i - 1, j - 1);
      if (a.texel_kind[border] != AtlasTexelKind::kBorder || !known[u] || !known[v] || !known[w]) {
        continue;
      }
      img.pixels[border] = glm::max(img.pixels[u] + img.pixels[v] - img.pixels[w], glm::vec3(0.0f));
      known[border] = 1;
    }
  }
  // Dilated texels (and any border texel left): rounds of the mean of known 8-neighbours of the
  // same triangle.
  for (int round = 0; round <= a.gutter + 1; ++round) {
    std::vector<size_t> filled;
    for (int y = 0; y < a.height; ++y) {
      for (int x = 0; x < a.width; ++x) {
        const size_t i = a.texelIndex(x, y);
        if (known[i] || a.texel_kind[i] == AtlasTexelKind::kEmpty) continue;
        glm::vec3 sum(0.0f);
        int k = 0;
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            const int xx = x + dx, yy = y + dy;
            if (xx < 0 || yy < 0 || xx >= a.width || yy >= a.height) continue;
            const size_t j = a.texelIndex(xx, yy);
            if (!known[j] || a.texel_triangle[j] != a.texel_triangle[i]) continue;
            sum += img.pixels[j];
            ++k;
          }
        }
        if (k == 0) continue;
        img.pixels[i] = sum / float(k);
        filled.push_back(i);
      }
    }
    if (filled.empty()) break;
    for (size_t i : filled) known[i] = 1;
  }
  return img;
}

std::vector<glm::dvec3> ProgressiveRadiosity::triangleRadiosity() const {
  std::vector<glm::dvec3> out(triangleCount(), glm::dvec3(0.0));
  for (uint32_t t = 0; t < triangleCount(); ++t) {
    double area = 0.0;
    for (uint32_t e = tri_first_[t]; e < tri_first_[t + 1]; ++e) {
      out[t] += b_[e] * area_[e];
      area += area_[e];
    }
    if (area > 0.0) out[t] /= area;
  }
  return out;
}

}  // namespace penumbra
