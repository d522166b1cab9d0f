// Stochastic radiosity (Barsi and Jakab) against progressive radiosity (Wallner) on the same
// lightmap: the relative RMS error per texel (luminance, area-weighted) against a converged
// progressive solution, as a function of iterations (stochastic: the 1/sqrt(m) law) and of
// seconds (both methods), on the Cornell box and the room of scenes/room.json. Prints the
// figures as CSV and writes the plots:
//   build/bin/convergence_plot [OUT_DIR]     (default docs/images)
// Progressive radiosity is measured with its ambient term (eq. 4-6) added, as it is displayed
// while it runs; the clock excludes the error computations.
#include "penumbra/core/timer.h"
#include "penumbra/io/image_io.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/io/tonemap.h"
#include "penumbra/radiosity/progressive.h"
#include "penumbra/radiosity/stochastic.h"
#include "penumbra/render/plot.h"

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

using namespace penumbra;

namespace {

template <typename Get>
double relativeRms(const RadiositySurface& s, const std::vector<glm::dvec3>& reference, Get&& get) {
  double num = 0.0, den = 0.0;
  for (size_t e = 0; e < s.elementCount(); ++e) {
    const double a = s.atlas.element_area[e];
    const double x = residualLuminance(get(e)), y = residualLuminance(reference[e]);
    num += a * (x - y) * (x - y);
    den += a * y * y;
  }
  return std::sqrt(num / den);
}

int fail(const Error& e) {
  std::fprintf(stderr, "%s\n", e.describe().c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string out_dir = argc > 1 ? argv[1] : "docs/images";
  struct Case {
    std::string name, file;
    double seconds;  // how long each method runs
  };
  const Case cases[] = {{"cornell", "cornell", 6.0},
                        {"room", std::string(PENUMBRA_BENCH_SCENES) + "/room.json", 20.0}};
  std::vector<PlotSeries> by_iteration;
  for (const Case& c : cases) {
    Expected<Scene> scene = loadScene(c.file);
    if (!scene) return fail(scene.error());
    const double density = texelDensityFor(*scene, kDefaultLightmapElements);
    // The reference: progressive radiosity to 1e-5 of the emitted power unshot.
    ProgressiveOptions po;
    po.atlas.texel_density = density;
    po.convergence = 1e-5;
    po.max_iterations = 100000;
    Expected<ProgressiveRadiosity> ref = ProgressiveRadiosity::build(*scene, po);
    if (!ref) return fail(ref.error());
    const ProgressiveStats rs = ref->solve();
    std::fprintf(stderr, "%s: reference %zu texels, %d iterations, %.1f s\n", c.name.c_str(),
                 ref->elementCount(), rs.total_iterations, rs.seconds);
    const std::vector<glm::dvec3> reference = ref->state().radiosity;

    // Progressive radiosity against time.
    PlotSeries prog{"progressive", {0.85f, 0.2f, 0.1f}, {}};
    {
      po.convergence = 0.0;
      po.max_iterations = 100000;
      Expected<ProgressiveRadiosity> pr = ProgressiveRadiosity::build(*scene, po);
      if (!pr) return fail(pr.error());
      double clock = 0.0;
      Timer t;
      pr->solve(
          [&](const ProgressiveIteration&) {
            clock += t.seconds();
            const glm::dvec3 ambient = pr->ambient();  // eq. 4-6, once per evaluation
            const double err = relativeRms(pr->surface(), reference, [&](size_t e) {
              return pr->radiosity(e) + pr->reflectance(e) * ambient;
            });
            prog.points.emplace_back(clock, err);
            std::printf("%s,progressive,%d,%.4f,%.6f\n", c.name.c_str(), pr->iterations(), clock,
                        err);
            t = Timer();
          },
          [&] { return clock >= c.seconds; });
    }
    // Stochastic radiosity against time and iterations.
    PlotSeries stoch{"stochastic", {0.1f, 0.3f, 0.85f}, {}};
    PlotSeries iter{
        c.name,
        c.name == "cornell" ? glm::vec3(0.1f, 0.3f, 0.85f) : glm::vec3(0.1f, 0.6f, 0.2f),
        {}};
    {
      StochasticOptions so;
      so.atlas.texel_density = density;
      so.iterations = 1 << 30;
      Expected<StochasticRadiosity> sr = StochasticRadiosity::build(*scene, so);
      if (!sr) return fail(sr.error());
      // The clock starts with the first shots' time (built in build(), before any iteration),
      // as progressive radiosity's counts its own shots.
      double clock = sr->firstShotSeconds();
      int next = sr->burnIn() + 1;
      Timer t;
      sr->solve(
          [&](const StochasticIteration& it) {
            if (it.iteration < next) return;
            next = sr->burnIn() + int(std::ceil((it.iteration - sr->burnIn()) * 1.25));
            clock += t.seconds();
            const double err =
                relativeRms(sr->surface(), reference, [&](size_t e) { return sr->radiosity(e); });
            stoch.points.emplace_back(clock, err);
            iter.points.emplace_back(sr->averaged(), err);
            std::printf("%s,stochastic,%d,%.4f,%.6f\n", c.name.c_str(), it.iteration, clock, err);
            t = Timer();
          },
          [&] { return clock >= c.seconds; });
    }
    by_iteration.push_back(iter);
    const Image plot = logLogPlot({prog, stoch}, c.name + ": error against time (2 threads)",
                                  "seconds", "relative RMS error");
    const std::string path = out_dir + "/stochastic_vs_progressive_" + c.name + ".png";
    ToneMapSettings linear;
    linear.op = ToneMapOperator::kNone;
    if (Status s = writeImage(path, plot, linear); !s.ok()) return fail(s.error());
  }
  // The 1/sqrt(m) law, with a reference line of slope -1/2 through the Cornell box's first point.
  if (!by_iteration.empty() && !by_iteration[0].points.empty()) {
    const glm::dvec2 p0 = by_iteration[0].points.front();
    PlotSeries law{"1/sqrt(m)", {0.5f, 0.5f, 0.5f}, {}, true};
    law.points = {p0, {p0.x * 1e4, p0.y * 1e-2}};
    by_iteration.push_back(law);
  }
  const Image plot = logLogPlot(by_iteration, "stochastic radiosity: error against iterations",
                                "iterations averaged (after the burn-in)", "relative RMS error");
  ToneMapSettings linear;
  linear.op = ToneMapOperator::kNone;
  if (Status s = writeImage(out_dir + "/stochastic_convergence.png", plot, linear); !s.ok()) {
    return fail(s.error());
  }
  return 0;
}
