#include "penumbra/radiosity/form_factors.h"

#include "penumbra/core/memory.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/core/timer.h"
#include "penumbra/kernels/form_factor.h"
#include "penumbra/kernels/sampling.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstring>
#include <numbers>

namespace penumbra {

double FormFactorMatrix::rowSum(uint32_t i) const {
  double s = 0.0;
  for (uint32_t j = 0; j < n; ++j) s += (*this)(i, j);
  return s;
}

namespace {

constexpr double kPiD = std::numbers::pi;

// One thread's state while it evaluates pairs.
struct PairEvaluator {
  const RadiositySurface& s;
  const FormFactorOptions& o;
  const ElementPieces& cache;
  std::vector<std::array<glm::dvec3, 8>> polygons;
  std::vector<int> counts;
  std::vector<std::pair<const glm::dvec3*, int>> pieces;  // randomPoint's
  uint64_t rays = 0;
  uint64_t refined = 0;
  int rays_per_pair = o.rays;
  double few_rays_below = kFewRaysBelow;  // 0: every far pair takes rays_per_pair

  // Whether the segment between element points a and b (each lifted off its surface) is free.
  bool visible(uint32_t a, uint32_t b) {
    return visibleBetween(s.atlas.element_position[a], a, s.atlas.element_position[b], b);
  }
  // The same between point p of element a and point q of element b.
  bool visibleBetween(const glm::dvec3& p, uint32_t a, const glm::dvec3& q, uint32_t b) {
    ++rays;
    const glm::dvec3 from = p + s.atlas.element_normal[a] * s.lift;
    const glm::dvec3 to = q + s.atlas.element_normal[b] * s.lift;
    return !s.engine.occluded(Ray{glm::vec3(from), 1e-4f, glm::vec3(to - from), 1.0f - 1e-4f});
  }

  // A point of element e's pieces, uniform by area (its point when it has none). Far pairs' rays
  // run between such points rather than the elements' centres: centres lie on the texel grid,
  // and a regular occluder (a lattice's bars every four texels) then hid or showed whole rows
  // of receivers together (a plaid of +-15% on the textured room's floor).
  glm::dvec3 randomPoint(uint32_t e, Rng& rng) {
    pieces.clear();
    if (!cache.empty()) {
      for (uint32_t p = cache.piece_first[e]; p < cache.piece_first[e + 1]; ++p) {
        pieces.emplace_back(cache.corners.data() + cache.corner_first[p],
                            int(cache.corner_first[p + 1] - cache.corner_first[p]));
      }
    } else {
      s.atlas.elementPieces(e, s.flat.positions, s.flat.triangles, polygons, counts);
      for (size_t k = 0; k < counts.size(); ++k) pieces.emplace_back(polygons[k].data(), counts[k]);
    }
    // A piece by area, then a point of it (the last piece if rounding runs past).
    double total = 0.0;
    for (const auto& [c, count] : pieces) {
      for (int k = 1; k + 1 < count; ++k) total += fanTriangleArea2(c, k);
    }
    if (!(total > 0.0)) return s.atlas.element_position[e];
    double at = double(rng.uniform()) * total;
    for (size_t p = 0; p < pieces.size(); ++p) {
      const auto& [c, count] = pieces[p];
      double twice = 0.0;
      for (int k = 1; k + 1 < count; ++k) twice += fanTriangleArea2(c, k);
      if (at < twice || p + 1 == pieces.size()) {
        return pointOnFan(c, count, at, rng.uniform(), rng.uniform());
      }
      at -= twice;
    }
    return s.atlas.element_position[e];
  }

  // Lambert's form factor from element a's point to element b's pieces (0 when the point is
  // behind b), with angleFast's angles (relative error about 1e-6: far below the discretisation;
  // each pair is evaluated once, so reciprocity is untouched).
  double pointToElement(uint32_t a, uint32_t b) {
    const glm::dvec3 x = s.atlas.element_position[a], n = s.atlas.element_normal[a];
    if (glm::dot(s.atlas.element_normal[b], x - s.atlas.element_position[b]) <= 0.0) return 0.0;
    double f = 0.0;
    if (!cache.empty()) {
      for (uint32_t p = cache.piece_first[b]; p < cache.piece_first[b + 1]; ++p) {
        f += pointToPolygonFormFactor<true>(x, n, cache.corners.data() + cache.corner_first[p],
                                            int(cache.corner_first[p + 1] - cache.corner_first[p]));
      }
      return f;
    }
    s.atlas.elementPieces(b, s.flat.positions, s.flat.triangles, polygons, counts);
    for (size_t k = 0; k < counts.size(); ++k) {
      f += pointToPolygonFormFactor<true>(x, n, polygons[k].data(), counts[k]);
    }
    return f;
  }

  // T = integral over a of F(dA_x -> b) V dA_x (m^2), by the rules of the file comment.
  double transport(ClusterRef a, ClusterRef b, Rng& rng) {
    ++refined;
    const SurfaceHierarchy& h = s.hierarchy;
    const ClusterLevel& la = h.level(a.level);
    const ClusterLevel& lb = h.level(b.level);
    if (la.chart[a.index] == lb.chart[b.index] && s.atlas.charts.charts[la.chart[a.index]].planar) {
      return 0.0;  // coplanar
    }
    const double aa = la.area[a.index], ab = lb.area[b.index];
    const glm::dvec3 d = lb.position[b.index] - la.position[a.index];
    const double d2 = glm::dot(d, d);
    const double reach = o.near * (std::sqrt(aa / kPiD) + std::sqrt(ab / kPiD));
    const bool near = d2 < reach * reach;
    if (near && (a.level > 0 || b.level > 0)) {
      // Refine the larger of the two (an element cannot be).
      const bool split_a = b.level == 0 || (a.level > 0 && aa >= ab);
      const ClusterRef c = split_a ? a : b;
      const ClusterLevel& lc = h.level(c.level);
      const ClusterLevel& below = h.level(c.level - 1);
      double t = 0.0;
      for (uint32_t k = lc.child_first[c.index]; k < lc.child_first[c.index + 1]; ++k) {
        const ClusterRef child{c.level - 1, k};
        if (below.area[k] <= 0.0) continue;
        t += split_a ? transport(child, b, rng) : transport(a, child, rng);
      }
      return t;
    }
    if (near) {
      // Two elements: Lambert's exact form factor each way at the elements' points.
      const double fab = pointToElement(a.index, b.index), fba = pointToElement(b.index, a.index);
      const double t = 0.5 * (aa * fab + ab * fba);
      if (t <= 0.0) return 0.0;
      if (o.visibility && !visible(a.index, b.index)) return 0.0;
      return t;
    }
    // Eq. 2's disc each way, symmetrised.
    const double dist = std::sqrt(d2);
    const glm::dvec3 w = d / dist;
    const double ca = glm::dot(la.normal[a.index], w) * la.flatness[a.index];
    const double cb = -glm::dot(lb.normal[b.index], w) * lb.flatness[b.index];
    if (ca <= 0.0 || cb <= 0.0) return 0.0;
    const double t =
        0.5 * (aa * discFormFactor(ab, cb, ca, d2) + ab * discFormFactor(aa, ca, cb, d2));
    if (!o.visibility) return t;
    const uint32_t a0 = la.first[a.index], na = la.first[a.index + 1] - a0;
    const uint32_t b0 = lb.first[b.index], nb = lb.first[b.index + 1] - b0;
    const int m = (few_rays_below > 0.0 && t < few_rays_below * aa && t < few_rays_below * ab)
                      ? 1
                      : std::max(1, rays_per_pair);
    int free = 0;
    for (int k = 0; k < m; ++k) {
      // Element points in strata of each cluster's Morton range (the two strata sequences
      // shifted, so that ray k pairs different parts of the clusters).
      const uint32_t ea =
          a0 + std::min(na - 1, uint32_t((double(k) + rng.uniform()) / double(m) * double(na)));
      const uint32_t eb = b0 + std::min(nb - 1, uint32_t((double((k + 1) % m) + rng.uniform()) /
                                                         double(m) * double(nb)));
      const glm::dvec3 pa = randomPoint(ea, rng), pb = randomPoint(eb, rng);
      if (visibleBetween(pa, ea, pb, eb)) ++free;
    }
    return t * double(free) / double(m);
  }
};

}  // namespace

ElementPieces ElementPieces::build(const RadiositySurface& s) {
  ElementPieces cache;
  const size_t n = s.elementCount();
  if (n > ElementPieces::kMaxElements) return cache;
  // Chunks in parallel, concatenated in order.
  constexpr size_t kChunk = 1024;
  const size_t chunks = (n + kChunk - 1) / kChunk;
  struct Part {
    std::vector<uint32_t> pieces_per_element, corners_per_piece;
    std::vector<glm::dvec3> corners;
  };
  std::vector<Part> parts(chunks);
  parallelRange(chunks, 1, [&](size_t b, size_t e) {
    std::vector<std::array<glm::dvec3, 8>> polygons;
    std::vector<int> counts;
    for (size_t k = b; k < e; ++k) {
      Part& part = parts[k];
      for (size_t el = k * kChunk; el < std::min(n, (k + 1) * kChunk); ++el) {
        s.atlas.elementPieces(el, s.flat.positions, s.flat.triangles, polygons, counts);
        part.pieces_per_element.push_back(uint32_t(counts.size()));
        for (size_t q = 0; q < counts.size(); ++q) {
          part.corners_per_piece.push_back(uint32_t(counts[q]));
          part.corners.insert(part.corners.end(), polygons[q].begin(),
                              polygons[q].begin() + counts[q]);
        }
      }
    }
  });
  cache.piece_first.push_back(0);
  cache.corner_first.push_back(0);
  for (const Part& part : parts) {
    for (uint32_t c : part.pieces_per_element) {
      cache.piece_first.push_back(cache.piece_first.back() + c);
    }
    for (uint32_t c : part.corners_per_piece) {
      cache.corner_first.push_back(cache.corner_first.back() + c);
    }
    cache.corners.insert(cache.corners.end(), part.corners.begin(), part.corners.end());
  }
  return cache;
}

Share matrixRowBlock(uint64_t n, int rank, int size) {
  // Whole groups of four rows: the solvers' kernels take rows four at a time from row 0
  // (radiosity/matrix_solver.cpp), so each rank's groups are one process's and so are the sums.
  const Share groups = shareOf((n + 3) / 4, rank, size);
  return Share{std::min(n, groups.begin * 4), std::min(n, groups.end * 4)};
}

namespace {

// What a rank sends another after evaluating its pairs: records of a header and floats.
//  - kRowPart: row i's entries F_ij, j in [j0, j0 + count), for the rank holding row i;
//  - kColumnPart: the entries F_ji, j in [j0, j0 + count), of rows the receiver holds.
enum : uint32_t { kRowPart = 0, kColumnPart = 1 };
struct PartHeader {
  uint32_t kind, i, j0, count;
};

void appendPart(std::vector<std::byte>& out, PartHeader h, const float* values) {
  const size_t at = out.size();
  out.resize(at + sizeof(h) + size_t(h.count) * sizeof(float));
  std::memcpy(out.data() + at, &h, sizeof(h));
  std::memcpy(out.data() + at + sizeof(h), values, size_t(h.count) * sizeof(float));
}

// The rows of the matrix over the ranks: those this rank holds, the rank holding each row, and
// how many rows this rank evaluates (rows q * ranks + rank, q < computed).
struct RowShare {
  uint64_t n = 0;
  int rank = 0, ranks = 1;
  Share held;
  std::vector<int> owner;
  size_t computed = 0;
  bool mine(size_t i) const { return owner[i] == rank; }
};

RowShare shareRows(uint64_t n, int rank, int ranks) {
  RowShare rows;
  rows.n = n;
  rows.rank = rank;
  rows.ranks = ranks;
  rows.held = matrixRowBlock(n, rank, ranks);
  rows.owner.resize(n);
  for (int r = 0; r < ranks; ++r) {
    const Share b = matrixRowBlock(n, r, ranks);
    for (uint64_t i = b.begin; i < b.end; ++i) rows.owner[i] = r;
  }
  rows.computed = n > size_t(rank) ? (n - size_t(rank) + size_t(ranks) - 1) / ranks : 0;
  return rows;
}

// The entries this rank evaluates for other ranks, per evaluated row q (row i): row i's part,
// F_ij for j > i (row), and the column part, F_ji (col); empty when not needed.
struct AwayParts {
  std::vector<std::vector<float>> row, col;
};

// Row i's pairs (i, j > i): each entry into the row held here, else into row_out (F_ij, at
// j - i - 1) or col_out (F_ji).
void evaluateRow(PairEvaluator& ev, std::span<const ClusterRef> cut,
                 const FormFactorOptions& options, const RowShare& rows,
                 const std::vector<double>& area, size_t i, FormFactorMatrix& m, float* row_out,
                 float* col_out) {
  const size_t n = rows.n;
  for (size_t j = i + 1; j < n; ++j) {
    Rng rng(mixBits(options.seed), i * n + j);
    const double t = ev.transport(cut[i], cut[j], rng);
    if (t <= 0.0) continue;
    const float fij = float(t / area[i]), fji = float(t / area[j]);
    if (rows.mine(i)) {
      m.f[(i - rows.held.begin) * n + j] = fij;
    } else {
      row_out[j - i - 1] = fij;
    }
    if (rows.mine(j)) {
      m.f[(j - rows.held.begin) * n + i] = fji;
    } else {
      col_out[j - i - 1] = fji;
    }
  }
}

// This rank evaluates the pairs (i, j > i) of rows i = rank mod ranks (all rows on one
// process). Each entry is written by exactly one row: F_ij and F_ji into the rows held here,
// the others into `away`, the entries for other ranks (row i's part, F_ij, in away.row; the
// column part, F_ji, in away.col), sent once every pair is done.
void evaluatePairs(const RadiositySurface& surface, std::span<const ClusterRef> cut,
                   const FormFactorOptions& options, const ElementPieces& cache,
                   const RowShare& rows, const std::vector<double>& area, FormFactorMatrix& m,
                   AwayParts& away, const std::function<void(size_t)>& on_row,
                   std::atomic<uint64_t>& rays, std::atomic<uint64_t>& refined) {
  const size_t n = rows.n, rank = size_t(rows.rank), ranks = size_t(rows.ranks);
  std::atomic<size_t> rows_done{0};
  away.row.resize(ranks > 1 ? rows.computed : 0);
  away.col.resize(ranks > 1 ? rows.computed : 0);
  parallelRange(rows.computed, 1, [&](size_t begin, size_t end) {
    PairEvaluator ev{surface, options, cache, {}, {}, {}, 0, 0, options.rays, kFewRaysBelow};
    for (size_t q = begin; q < end; ++q) {
      const size_t i = q * ranks + rank;
      float* row_out = nullptr;
      float* col_out = nullptr;
      if (ranks > 1) {
        if (!rows.mine(i)) {
          away.row[q].assign(n - i - 1, 0.0f);
          row_out = away.row[q].data();
        }
        // Rows are held in contiguous blocks: rows i + 1 .. n - 1 are all held here when the
        // first and the last are.
        if (i + 1 < n && (!rows.mine(i + 1) || !rows.mine(n - 1))) {
          away.col[q].assign(n - i - 1, 0.0f);
          col_out = away.col[q].data();
        }
      }
      evaluateRow(ev, cut, options, rows, area, i, m, row_out, col_out);
      const size_t done = rows_done.fetch_add(1) + 1;
      if (on_row) on_row(std::min<size_t>(n, done * ranks));
    }
    rays += ev.rays;
    refined += ev.refined;
  });
}

// The entries of other ranks' rows, per destination rank (and `away` freed as it goes).
std::vector<std::vector<std::byte>> packAwayParts(const RowShare& rows, AwayParts& away) {
  const size_t n = rows.n;
  const int rank = rows.rank, ranks = rows.ranks;
  std::vector<std::vector<std::byte>> to(static_cast<size_t>(ranks));
  for (size_t q = 0; q < rows.computed; ++q) {
    const size_t i = q * size_t(ranks) + size_t(rank);
    if (!away.row[q].empty()) {
      appendPart(to[size_t(rows.owner[i])],
                 {kRowPart, uint32_t(i), uint32_t(i + 1), uint32_t(n - i - 1)}, away.row[q].data());
    }
    if (!away.col[q].empty()) {
      for (int r = 0; r < ranks; ++r) {
        if (r == rank) continue;
        const Share b = matrixRowBlock(n, r, ranks);
        const uint64_t j0 = std::max<uint64_t>(b.begin, i + 1);
        if (j0 >= b.end) continue;
        appendPart(to[size_t(r)], {kColumnPart, uint32_t(i), uint32_t(j0), uint32_t(b.end - j0)},
                   away.col[q].data() + (j0 - i - 1));
      }
    }
    std::vector<float>().swap(away.row[q]);
    std::vector<float>().swap(away.col[q]);
  }
  return to;
}

// Another rank's parts for the rows held here, into the matrix.
void unpackParts(const std::vector<std::byte>& bytes, const RowShare& rows, FormFactorMatrix& m) {
  const size_t n = rows.n;
  size_t at = 0;
  while (at + sizeof(PartHeader) <= bytes.size()) {
    PartHeader h;
    std::memcpy(&h, bytes.data() + at, sizeof(h));
    at += sizeof(h);
    const float* v = reinterpret_cast<const float*>(bytes.data() + at);
    for (uint32_t k = 0; k < h.count; ++k) {
      float value;
      std::memcpy(&value, v + k, sizeof(float));
      if (h.kind == kRowPart) {
        m.f[(size_t(h.i) - rows.held.begin) * n + h.j0 + k] = value;
      } else {
        m.f[(size_t(h.j0) + k - rows.held.begin) * n + h.i] = value;
      }
    }
    at += size_t(h.count) * sizeof(float);
  }
}

// Closed rows sum to 1; none sums to more. What a row sends to a cut-out cluster is
// intercepted only in its covered share (RadiositySurface::coverage), the rest reaching what lies
// behind it, which the row also holds: the sum counts each cluster by its coverage.
void closeRows(const RadiositySurface& surface, std::span<const ClusterRef> cut,
               const FormFactorOptions& options, const RowShare& rows, FormFactorMatrix& m,
               std::atomic<uint64_t>& rays, std::atomic<uint64_t>& closed_rows) {
  const size_t n = rows.n;
  const Share held = rows.held;
  std::vector<double> covered(n, 1.0);  // per cluster of the cut, area-weighted
  if (!surface.coverage.empty()) {
    const SurfaceHierarchy& h = surface.hierarchy;
    for (size_t j = 0; j < n; ++j) {
      double c = 0.0, a = 0.0;
      for (uint32_t e = h.elementBegin(cut[j]); e < h.elementEnd(cut[j]); ++e) {
        c += surface.coverage[e] * surface.atlas.element_area[e];
        a += surface.atlas.element_area[e];
      }
      if (a > 0.0) covered[j] = c / a;
    }
  }
  parallelRange(held.size(), 4, [&](size_t begin, size_t end) {
    uint64_t traced = 0, closed = 0;
    for (size_t r = begin; r < end; ++r) {
      const size_t i = held.begin + r;
      float* row = &m.f[r * n];
      double sum = 0.0;
      for (size_t j = 0; j < n; ++j) sum += row[j] * covered[j];
      if (!(sum > 0.0)) continue;
      double target = std::min(sum, 1.0);
      if (options.probe_rays > 0) {
        traced += uint64_t(options.probe_rays);
        const SurfaceHierarchy& h = surface.hierarchy;
        if (surface.seesOnlyElements(h.elementBegin(cut[i]), h.elementEnd(cut[i]),
                                     options.probe_rays, mixBits(options.seed) ^ i)) {
          target = 1.0;
          ++closed;
        }
      }
      if (target == sum) continue;
      const double scale = target / sum;
      m.row_scale[r] = float(scale);
      for (size_t j = 0; j < n; ++j) row[j] = float(double(row[j]) * scale);
    }
    rays += traced;
    closed_rows += closed;
  });
}

}  // namespace

Expected<FormFactorMatrix> computeFormFactors(const RadiositySurface& surface,
                                              std::span<const ClusterRef> cut,
                                              const FormFactorOptions& options,
                                              FormFactorStats* stats,
                                              const std::function<void(size_t)>& on_row,
                                              const ElementPieces* pieces, Communicator* comm) {
  const Timer timer;
  LocalCommunicator local;
  Communicator& c = comm ? *comm : local;
  const int rank = c.rank(), ranks = c.size();
  const uint64_t n = cut.size();
  if (!(options.near > 0.0) || options.rays < 1 || options.probe_rays < 0 ||
      options.probe_rays > (1 << 20)) {
    return inputError("", "form factors",
                      "near must be positive, rays at least 1, probe_rays in [0, 2^20]");
  }
  const Share held = matrixRowBlock(n, rank, ranks);
  PENUMBRA_TRY(checkMemory(held.size() * n * sizeof(float),
                           ranks > 1 ? fmt::format("rows {}-{} of the {} x {} form-factor matrix",
                                                   held.begin, held.end, n, n)
                                     : fmt::format("the {} x {} form-factor matrix", n, n)));
  FormFactorMatrix m;
  m.n = uint32_t(n);
  m.row_begin = uint32_t(held.begin);
  m.f.assign(held.size() * n, 0.0f);
  m.row_scale.assign(held.size(), 1.0f);
  std::vector<double> area(n);
  for (size_t i = 0; i < n; ++i) area[i] = surface.hierarchy.level(cut[i].level).area[cut[i].index];
  const RowShare rows = shareRows(n, rank, ranks);

  const ElementPieces own = pieces ? ElementPieces{} : ElementPieces::build(surface);
  const ElementPieces& cache = pieces ? *pieces : own;
  std::atomic<uint64_t> rays{0}, refined{0}, closed_rows{0};
  // ---- The pairs of this rank's rows ----
  AwayParts away;
  evaluatePairs(surface, cut, options, cache, rows, area, m, away, on_row, rays, refined);
  if (ranks > 1) {
    // The entries of other ranks' rows, to them, in one exchange.
    const std::vector<std::vector<std::byte>> from = c.alltoall(packAwayParts(rows, away));
    for (const std::vector<std::byte>& bytes : from) unpackParts(bytes, rows, m);
  }
  // ---- Closed rows ----
  closeRows(surface, cut, options, rows, m, rays, closed_rows);
  if (stats) {
    const uint64_t counts[3] = {refined.load(), rays.load(), closed_rows.load()};
    const std::vector<uint64_t> total = allreduceSum(c, std::span<const uint64_t>(counts, 3));
    stats->seconds = timer.seconds();
    stats->pairs = n * (n - 1) / 2;
    stats->refined = total[0];
    stats->rays = total[1];
    stats->closed_rows = total[2];
  }
  return m;
}

Expected<std::vector<float>> computeElementFormFactors(
    const RadiositySurface& surface, std::span<const ClusterRef> cut,
    std::span<const uint32_t> sources, const FormFactorOptions& options, FormFactorStats* stats,
    const ElementPieces* pieces, Communicator* comm) {
  const size_t n = surface.elementCount(), s_count = sources.size();
  PENUMBRA_TRY(checkMemory(
      uint64_t(n) * s_count * sizeof(float),
      fmt::format("form factors from {} elements to {} emitting clusters", n, s_count)));
  std::vector<float> out(n * s_count, 0.0f);
  const ElementPieces own = pieces ? ElementPieces{} : ElementPieces::build(surface);
  const ElementPieces& cache = pieces ? *pieces : own;
  // Over several ranks each takes a share of the elements; then all have every row.
  const bool distributed = comm && comm->distributed();
  const Share share = distributed ? shareOf(n, comm->rank(), comm->size()) : Share{0, n};
  std::atomic<uint64_t> rays{0};
  parallelRange(share.size(), 64, [&](size_t begin, size_t end) {
    PairEvaluator ev{surface, options, cache, {}, {}, {}, 0, 0, options.element_rays, 0.0};
    for (size_t e = share.begin + begin; e < share.begin + end; ++e) {
      const double area = surface.atlas.element_area[e];
      if (!(area > 0.0)) continue;
      for (size_t s = 0; s < s_count; ++s) {
        const ClusterRef c = cut[sources[s]];
        if (e >= surface.hierarchy.elementBegin(c) && e < surface.hierarchy.elementEnd(c)) continue;
        Rng rng(mixBits(options.seed ^ 0x2545f4914f6cdd1dull), e * s_count + s);
        const double t = ev.transport(ClusterRef{0, uint32_t(e)}, c, rng);
        out[e * s_count + s] = float(t / area);
      }
    }
    rays += ev.rays;
  });
  uint64_t traced = rays.load();
  if (distributed) {
    out = allgatherValues<float>(
        *comm, std::span<const float>(out.data() + share.begin * s_count, share.size() * s_count));
    traced = allreduceSum(*comm, traced);
  }
  if (stats) stats->rays += traced;
  return out;
}

}  // namespace penumbra
