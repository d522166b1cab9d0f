// The peer of `penumbra trace` (bench/trace_vs_embree.py): the same scene and ray file through
// Embree 3, on all threads, with Embree's single-ray and 8-ray packet entry points, closest hit
// (rtcIntersect1/8) or occlusion (rtcOccluded1/8). Each is run `--reps` times after one warm-up
// pass, and the median seconds printed as JSON; conversion from the file's layout to Embree's
// ray structures and the writing of the answers are inside the timing, as `trace`'s
// are. `--check HITS` compares the answers with a `trace` output (closest hit: the same
// triangle or t within 1e-5 relative; occlusion: the same byte). `--penumbra` adds Penumbra's
// RayEngine, timed the same way in the same process (the library as a caller meets it, warm):
// seconds_penumbra; `--isa avx2|scalar` asks it for a narrower instruction set.
#include "embree_peer.h"
#include "penumbra/core/file_util.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/io/ray_file.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/raytrace/ray_engine.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace {

using namespace penumbra;

template <typename F>
double medianSeconds(int reps, F&& f) {
  f();  // warm-up
  std::vector<double> s;
  for (int r = 0; r < reps; ++r) {
    Timer timer;
    f();
    s.push_back(timer.seconds());
  }
  std::sort(s.begin(), s.end());
  return s[s.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  std::string mesh, rays_path, check;
  bool occlusion = false, with_penumbra = false;
  std::string isa;
  int reps = 5;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--occlusion") {
      occlusion = true;
    } else if (a == "--reps" && i + 1 < argc) {
      reps = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--penumbra") {
      with_penumbra = true;
    } else if (a == "--isa" && i + 1 < argc) {
      isa = argv[++i];
    } else if (a == "--check" && i + 1 < argc) {
      check = argv[++i];
    } else if (mesh.empty()) {
      mesh = a;
    } else {
      rays_path = a;
    }
  }
  if (mesh.empty() || rays_path.empty()) {
    std::fprintf(stderr,
                 "usage: embree_trace MESH RAYS [--occlusion] [--reps N] [--check HITS] "
                 "[--penumbra [--isa avx512|avx2|scalar]]\n");
    return 2;
  }
  Expected<Scene> scene = loadScene(mesh);
  if (!scene) {
    std::fprintf(stderr, "%s\n", scene.error().describe().c_str());
    return 2;
  }
  Expected<RayBatch> rays = readRayFile(rays_path);
  if (!rays) {
    std::fprintf(stderr, "%s\n", rays.error().describe().c_str());
    return 2;
  }
  const FlatTriangles flat = flattenScene(*scene);

  Timer build_timer;
  const bench::EmbreePeer peer(flat.positions, flat.triangles);
  const double build_seconds = build_timer.seconds();
  const int64_t bytes = peer.bytes();

  double s1 = 0.0, s8 = 0.0, sp = 0.0;
  size_t mismatches = 0, penumbra_mismatches = 0;
  RayEngine engine;
  if (with_penumbra) {
    engine = RayEngine::build(flat.positions, flat.triangles);
    if (isa == "scalar") {
      engine.useIsa(CpuIsa::kScalar);
    } else if (isa == "avx2") {
      engine.useIsa(CpuIsa::kAvx2);
    } else if (!isa.empty() && isa != "avx512") {
      std::fprintf(stderr, "embree_trace: --isa %s: not avx512, avx2 or scalar\n", isa.c_str());
      return 2;
    }
  }
  if (occlusion) {
    std::vector<uint8_t> out(rays->size());
    s1 = medianSeconds(reps, [&] { peer.occluded1(*rays, out); });
    s8 = medianSeconds(reps, [&] { peer.occluded8(*rays, out); });
    if (with_penumbra) {
      std::vector<uint8_t> ours(rays->size());
      sp = medianSeconds(reps, [&] { engine.occluded(*rays, ours); });
      for (size_t i = 0; i < out.size(); ++i) penumbra_mismatches += out[i] != ours[i];
    }
    if (!check.empty()) {
      Expected<std::string> theirs = readFile(check);
      if (!theirs || theirs->size() != out.size()) {
        std::fprintf(stderr, "%s: not an occlusion file for these rays\n", check.c_str());
        return 2;
      }
      for (size_t i = 0; i < out.size(); ++i) mismatches += out[i] != uint8_t((*theirs)[i]);
    }
  } else {
    HitBatch out;
    out.resize(rays->size());
    s1 = medianSeconds(reps, [&] { peer.intersect1(*rays, out); });
    s8 = medianSeconds(reps, [&] { peer.intersect8(*rays, out); });
    if (with_penumbra) {
      HitBatch ours;
      ours.resize(rays->size());
      sp = medianSeconds(reps, [&] { engine.intersect(*rays, ours); });
      for (size_t i = 0; i < out.size(); ++i) {
        const Hit a = ours.get(i), b = out.get(i);
        penumbra_mismatches +=
            !(a.triangle == b.triangle ||
              (a.hit() && b.hit() && std::fabs(a.t - b.t) <= 1e-5f * std::max(1.0f, a.t)));
      }
    }
    if (!check.empty()) {
      Expected<HitBatch> theirs = readHitFile(check);
      if (!theirs || theirs->size() != out.size()) {
        std::fprintf(stderr, "%s: not a hit file for these rays\n", check.c_str());
        return 2;
      }
      for (size_t i = 0; i < out.size(); ++i) {
        const Hit a = theirs->get(i), b = out.get(i);
        const bool same =
            a.triangle == b.triangle ||
            (a.hit() && b.hit() && std::fabs(a.t - b.t) <= 1e-5f * std::max(1.0f, a.t));
        mismatches += !same;
      }
    }
  }
  std::printf(
      "{\"rays\": %zu, \"triangles\": %zu, \"threads\": %d, \"build_seconds\": %.6f, "
      "\"bytes\": %lld, \"seconds_1\": %.6f, \"seconds_8\": %.6f, \"seconds_best\": %.6f, "
      "\"mismatches\": %zu, \"seconds_penumbra\": %.6f, \"penumbra_mismatches\": %zu}\n",
      rays->size(), flat.triangles.size(), threadCount(), build_seconds, (long long)bytes, s1, s8,
      std::min(s1, s8), mismatches, sp, penumbra_mismatches);
  return 0;
}
