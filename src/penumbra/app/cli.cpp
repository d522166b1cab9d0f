#include "penumbra/app/commands.h"
#include "penumbra/app/session.h"
#include "penumbra/cluster/communicator.h"

#include "penumbra/core/file_util.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/core/log.h"
#include "penumbra/core/parallel.h"

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <charconv>
#include <cmath>
#include <cstdint>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <new>
#include <string>
#include <vector>

#include <unistd.h>

namespace penumbra {

int reportError(const Error& error) {
  const Communicator& comm = currentCommunicator();
  if (CommandSession* session = CommandSession::current()) {
    session->error = error;  // the caller reports it
  } else if (comm.root()) {
    std::fprintf(stderr, "penumbra: error: %s\n", error.describe().c_str());
  } else if (error.report_on_this_rank || thisRankReports()) {
    // An error rank 0 does not have (cluster/communicator.h: agreeReady); rank 0 names this rank.
    std::fprintf(stderr, "penumbra: error: rank %d of %d: %s\n", comm.rank(), comm.size(),
                 error.describe().c_str());
  }
  return error.kind == ErrorKind::kInput ? 2 : 1;
}

int reportDryRun() {
  if (!currentCommunicator().root()) return 0;
  std::printf(
      "penumbra: dry run: options, inputs, output paths and memory are fine; nothing was "
      "written\n");
  return 0;
}

namespace {

// `penumbra view ...` runs the viewer, a separate executable (penumbra-view, next to this one)
// that links the window and panel libraries the library does not: this process becomes it.
int runView(int argc, char** argv) {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  const std::filesystem::path viewer = self.parent_path() / "penumbra-view";
  if (ec || !std::filesystem::exists(viewer)) {
    std::fprintf(stderr, "penumbra: error: %s: the viewer is not installed next to penumbra\n",
                 viewer.string().c_str());
    return 1;
  }
  std::vector<std::string> words = {viewer.string()};
  for (int k = 2; k < argc; ++k) words.emplace_back(argv[k]);
  std::vector<char*> args;
  for (std::string& w : words) args.push_back(w.data());
  args.push_back(nullptr);
  ::execv(args[0], args.data());
  std::fprintf(stderr, "penumbra: error: %s: cannot run the viewer: %s\n", args[0],
               std::strerror(errno));
  return 1;
}

// Option values are checked here, where they are parsed, so that every command refuses the
// same nonsense the same way (exit 2, one line naming the option and the value).

// A number: finite, in [lo, hi] (an open end when `open_lo` / `open_hi`). CLI11's Range lets NaN
// through (every comparison with it is false).
CLI::Validator finiteIn(double lo, double hi, bool open_lo = false, bool open_hi = false) {
  return CLI::Validator(
      [=](std::string& value) -> std::string {
        double v = 0.0;
        if (!CLI::detail::lexical_cast(value, v)) return "'" + value + "' is not a number";
        if (!std::isfinite(v)) return "'" + value + "' is not a finite number";
        const bool below = open_lo ? !(v > lo) : !(v >= lo);
        const bool above = open_hi ? !(v < hi) : !(v <= hi);
        if (below || above) {
          return fmt::format("{} is out of range {}{}, {}{}", value, open_lo ? '(' : '[', lo, hi,
                             open_hi ? ')' : ']');
        }
        return std::string();
      },
      fmt::format("{}{}, {}{}", open_lo ? '(' : '[', lo, hi, open_hi ? ')' : ']'));
}

// Progressive radiosity's receivers and adaptive subdivision (Wallner sec. 4), for render and
// bake alike.
template <typename Options>
void addReceiverOptions(CLI::App* cmd, Options& o) {
  cmd->add_flag("--adaptive", o.adaptive,
                "progressive: receivers start coarse (--receiver-level, default 2) and are "
                "split at shadow boundaries before each shooter first shoots");
  cmd->add_option("--receiver-level", o.receiver_level,
                  "progressive: receivers are blocks of 2^L x 2^L lightmap texels, gathering at "
                  "one point each (default 0: every texel; 2 with --adaptive)")
      ->check(CLI::Range(0, 16));
  cmd->add_option("--boundary", o.boundary,
                  "progressive --adaptive: LOW,HIGH: a receiver whose visible share of samples "
                  "lies in [LOW, HIGH] holds a shadow boundary (default 0.05,0.95)")
      ->delimiter(',')
      ->expected(2)
      ->check(finiteIn(0.0, 1.0));
  cmd->add_option("--finest-level", o.finest_level,
                  "progressive --adaptive: receivers are split down to this level at most")
      ->check(CLI::Range(0, 16))
      ->capture_default_str();
  cmd->add_option("--min-share", o.min_share,
                  "progressive --adaptive: split only where the shooter brings at least this "
                  "share of a receiver's irradiance (default 0.25; 0: the paper's test alone)")
      ->check(finiteIn(0.0, 1.0));
}

// Stochastic radiosity's options (Barsi and Jakab), for render and bake alike.
template <typename Options>
void addStochasticOptions(CLI::App* cmd, Options& o) {
  cmd->add_option("--time-limit", o.time_limit,
                  "stochastic: stop after this many seconds of iterating (--iterations still "
                  "caps them)")
      ->check(finiteIn(0.0, 1e9, /*open_lo=*/true));
  cmd->add_option("--shooters", o.shooters,
                  "stochastic: independent shooters per iteration, averaged")
      ->check(CLI::Range(1, 4096))
      ->capture_default_str();
}

// An unsigned integer written in decimal digits (no sign: "-1" would wrap to 2^64 - 1).
const CLI::Validator kUnsigned(
    [](std::string& value) -> std::string {
      if (value.empty() || value.find_first_not_of("0123456789") != std::string::npos) {
        return "'" + value + "' is not a non-negative integer";
      }
      uint64_t v = 0;
      const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), v);
      if (ec != std::errc() || end != value.data() + value.size()) {
        return value + " is larger than 2^64 - 1";
      }
      return std::string();
    },
    "UINT");

// Every option of `cmd` refuses an empty value ("--spp ''" is a mistake, not the default).
void refuseEmptyValues(CLI::App* cmd) {
  const CLI::Validator non_empty(
      [](std::string& value) -> std::string {
        return value.empty() ? std::string("an empty value is not allowed") : std::string();
      },
      "");
  for (CLI::Option* option : cmd->get_options()) {
    if (option->get_expected_min() > 0) option->check(non_empty);
  }
}

void addCommon(CLI::App* app, CommonOptions& common) {
  app->add_option("--threads", common.threads, "worker threads (0 = all cores)")
      ->check(CLI::Range(0, 1024));
  app->add_flag("--quiet", common.quiet, "no progress or information, only warnings and errors");
}

// For the commands that do work and write files.
void addDryRun(CLI::App* app, CommonOptions& common) {
  app->add_flag("--dry-run", common.dry_run,
                "check options, inputs, output paths and memory, then stop before the work "
                "(nothing is written)");
}

int parseAndRun(int argc, char** argv) {
  CLI::App app{"Penumbra: diffuse and subsurface global illumination", "penumbra"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "penumbra " PENUMBRA_VERSION);
  CommonOptions common;

  RenderOptions render;
  std::string tonemap = "reinhard";
  CLI::App* render_cmd = app.add_subcommand("render", "render a scene to an image");
  render_cmd
      ->add_option("scene", render.scene,
                   "built-in scene name (cornell, furnace) or a .json/.obj/.gltf/.glb/.ply "
                   "file")
      ->capture_default_str();
  render_cmd
      ->add_option("--method", render.method,
                   "pathtrace (the reference path tracer), whitted (Whitted ray tracing: mirrors, "
                   "glass and shadow rays), photons (photon mapping with final gather), matrix "
                   "(matrix radiosity), progressive (progressive radiosity in a lightmap), "
                   "stochastic (stochastic radiosity by ray-bundle shooting), sss (subsurface "
                   "scattering through hierarchical links) or lpv (subsurface light propagation "
                   "volumes)")
      ->capture_default_str();
  render_cmd
      ->add_option("--device", render.device,
                   "cpu, gpu, hybrid (the Ray Engine's CPU/GPU split) or auto")
      ->capture_default_str();
  render_cmd->add_option("-o,--output", render.outputs,
                         "output image (.exr .hdr .pfm linear, .png tone mapped); may repeat");
  render_cmd->add_option("--stats", render.stats, "write statistics to this JSON file");
  render_cmd->add_option("--width", render.width, "image width (default 512)");
  render_cmd->add_option("--height", render.height, "image height (default 512)");
  render_cmd->add_option("--spp", render.spp,
                         "samples per pixel (default 64; whitted, photons, sss, lpv: 4)");
  render_cmd->add_option("--max-depth", render.max_depth,
                         "maximum bounces, 0 = unlimited (Russian roulette); whitted and photons: "
                         "mirror and glass generations (default 8)");
  render_cmd->add_option("--light-samples", render.light_samples,
                         "whitted, photons: shadow rays per diffuse point to the emissive "
                         "surfaces and to the environment (default 8)");
  render_cmd->add_option("--photons", render.photons,
                         "photons: photons emitted for the global map (default 200000)");
  render_cmd->add_option("--caustic-photons", render.caustic_photons,
                         "photons: photons emitted towards mirrors and glass for the caustic map "
                         "(default 200000)");
  render_cmd->add_option("--gather-count", render.gather_count,
                         "photons: photons per density estimate (default 64)");
  render_cmd->add_option("--gather-radius", render.gather_radius,
                         "photons: their largest distance in metres (default 1% of the scene's "
                         "bounding-box diagonal)");
  render_cmd->add_option("--final-gather", render.final_gather,
                         "photons: final-gather rays per diffuse point; 0 reads the global map "
                         "directly (default 32)");
  render_cmd->add_option("--seed", render.seed, "random seed (default 0)")->check(kUnsigned);
  render_cmd
      ->add_option("--sampler", render.sampler,
                   "pathtrace: sobol (Owen-scrambled Sobol points, the default) or independent "
                   "(one random stream per sample)")
      ->check(CLI::IsMember({"sobol", "independent"}));
  render_cmd->add_option("--tonemap", tonemap, "PNG tone mapping: reinhard or exposure")
      ->check(CLI::IsMember({"reinhard", "exposure"}))
      ->capture_default_str();
  render_cmd
      ->add_option("--exposure", render.tonemap.exposure_stops,
                   "exposure in stops before tone mapping")
      ->check(finiteIn(-64.0, 64.0));
  render_cmd
      ->add_option("--key", render.tonemap.key,
                   "Reinhard key value, the mean image brightness aimed at (default: estimated "
                   "from the image)")
      ->check(finiteIn(0.0, 1.0, /*open_lo=*/true));
  render_cmd
      ->add_option("--solver", render.solver,
                   "matrix: jacobi or gauss-seidel (default: gauss-seidel on the CPU, jacobi "
                   "on the GPU)")
      ->check(CLI::IsMember({"jacobi", "gauss-seidel"}));
  render_cmd
      ->add_option("--elements", render.elements,
                   "matrix: about this many elements (default 2000); progressive: about this "
                   "many lightmap texels (default 40000)")
      ->check(CLI::Range(1u, 1u << 28));
  render_cmd
      ->add_option("--iterations", render.iterations,
                   "iteration cap (progressive: shooters; stochastic: random operators; counted "
                   "over resumed runs)")
      ->check(CLI::Range(1, 1 << 20))
      ->capture_default_str();
  render_cmd
      ->add_option("--tolerance", render.tolerance,
                   "matrix: stop when the mean squared residual of MB - E ((W m^-2)^2) is at "
                   "most this (default 1e-6); progressive: when the unshot fraction of the "
                   "emitted power is (default 1e-3)")
      ->check(finiteIn(0.0, 1e30, /*open_lo=*/true));
  render_cmd
      ->add_option("--precision", render.precision,
                   "matrix: form-factor storage, fp32 or fp16 (as the paper stores them)")
      ->check(CLI::IsMember({"fp32", "fp16"}))
      ->capture_default_str();
  render_cmd
      ->add_option("--ff-rays", render.ff_rays,
                   "matrix: shadow rays per pair of elements that exchange a noticeable share "
                   "of their light (default 4)")
      ->check(CLI::Range(1, 1024));
  render_cmd
      ->add_option("--relight-frames", render.relight_frames,
                   "matrix: render this many frames with the emitters' colour changing, "
                   "re-solving from the previous frame without new form factors "
                   "(-o out.png writes out_0000.png ...)")
      ->check(CLI::Range(0, 10000));
  render_cmd
      ->add_option("--shading", render.shading,
                   "matrix: smooth (corner-interpolated radiosity) or flat (one value per "
                   "element)")
      ->check(CLI::IsMember({"smooth", "flat"}))
      ->capture_default_str();
  render_cmd
      ->add_option("--texel-density", render.texel_density,
                   "radiosity: lightmap texels per metre (instead of the default from "
                   "--elements)")
      ->check(finiteIn(0.0, 1e9, /*open_lo=*/true));
  render_cmd
      ->add_option("--shooter-points", render.shooter_points,
                   "progressive: points a shooter starts from (its texels grouped in blocks; "
                   "nearer receivers refine them); more resolve soft shadows finer")
      ->check(CLI::Range(1, 4096))
      ->capture_default_str();
  addReceiverOptions(render_cmd, render);
  addStochasticOptions(render_cmd, render);
  render_cmd
      ->add_option("--normals", render.normals,
                   "progressive: interpolated (shading normals across triangles, smooth curved "
                   "surfaces) or triangle (each triangle's own normal)")
      ->check(CLI::IsMember({"interpolated", "triangle"}))
      ->capture_default_str();
  render_cmd
      ->add_option("--lightmap-size", render.lightmap_size,
                   "sss: atlas width and height (default 512, as the paper's real-time atlas)")
      ->check(CLI::Range(8, 16384));
  render_cmd
      ->add_option("--links", render.links,
                   "sss: links per texel, refined adaptively from the object's root (default "
                   "16, as the paper)")
      ->check(CLI::Range(1, 1024));
  render_cmd
      ->add_option("--links-level", render.links_level,
                   "sss: the non-adaptive scheme instead: a link to every cluster of this "
                   "hierarchy level")
      ->check(CLI::Range(0, 30));
  render_cmd
      ->add_option("--frames", render.frames,
                   "sss, lpv: render this many frames with the lights orbiting the scene once "
                   "(-o out.png writes out_0000.png ...); sss builds its links once, lpv needs "
                   "nothing built")
      ->check(CLI::Range(0, 100000));
  render_cmd
      ->add_option("--grid", render.grid,
                   "lpv: light propagation volume cells along each translucent object's longest "
                   "side (default 32, the paper's; at most 128)")
      ->check(CLI::Range(4, 128));
  render_cmd
      ->add_option("--steps", render.steps,
                   "lpv: propagation steps (default 8; the paper's Table 1 runs 8 and 32)")
      ->check(CLI::Range(1, 4096));
  render_cmd
      ->add_option("--skip-steps", render.skip_steps,
                   "lpv: first steps left out of the accumulation (default 2, the paper's)")
      ->check(CLI::Range(0, 4095));
  render_cmd
      ->add_option("--rsm-resolution", render.rsm_resolution,
                   "lpv: injection texels per side of each light's reflective shadow map "
                   "(default 256, the paper's)")
      ->check(CLI::Range(1, 4096));
  render_cmd
      ->add_option("--surface-samples", render.surface_samples,
                   "lpv: points of each translucent surface that gather the light of emitting "
                   "surfaces and the environment (default 16384; 0: none)")
      ->check(CLI::Range(0, 1 << 20));
  render_cmd
      ->add_option("--surface-rays", render.surface_rays,
                   "lpv: rays per surface point (default 16)")
      ->check(CLI::Range(0, 256));
  render_cmd->add_flag("--no-cache", render.no_cache,
                       "sss: build the links even if the cache ($PENUMBRA_CACHE_DIR, else "
                       "~/.cache/penumbra) holds them, and do not write them there");
  render_cmd->add_flag("--no-shadows", render.no_shadows,
                       "sss: light pass 1 without shadow rays, as the paper's vertex-program "
                       "lighting did (faster; light then reaches surfaces that face it through "
                       "the object)");
  render_cmd->add_option("--resume", render.resume,
                         "progressive: continue from this checkpoint (written on Ctrl-C)");
  render_cmd->add_flag("--keep-checkpoint", render.keep_checkpoint,
                       "progressive: keep the --resume checkpoint after the run completes "
                       "(it is removed by default: the outputs supersede it)");
  render_cmd->add_option("--checkpoint", render.checkpoint,
                         "progressive: where Ctrl-C writes the checkpoint (default: the first "
                         "output with the extension .checkpoint)");
  render_cmd
      ->add_option("--output-quantity", render.output_quantity,
                   "radiance (default) or illuminance: lux on the surfaces the camera sees "
                   "(pathtrace, progressive, matrix)")
      ->check(CLI::IsMember({"radiance", "illuminance"}));
  render_cmd->add_flag("--false-colour", render.false_colour,
                       "illuminance: PNG outputs in false colour, blue to red, with a legend "
                       "in lux");
  render_cmd->add_option("--lux-max", render.lux_max,
                         "illuminance: the lux at the top of the false-colour scale (default: a "
                         "round number above the 99th percentile)");
  render_cmd->add_option("--work-plane", render.work_plane,
                         "a horizontal grid of calculation points this many metres above the "
                         "scene's lowest point: average, minimum, maximum lux and uniformity U0 "
                         "in the log and the stats");
  render_cmd->add_option("--grid-surface", render.grid_surface,
                         "calculation points on the front of the mesh of this name (a JSON "
                         "scene's mesh \"name\"): lux figures as for --work-plane, area-weighted");
  render_cmd->add_option("--grid-spacing", render.grid_spacing,
                         "work plane or surface: metres between points (default 0.25)");
  render_cmd->add_option("--grid-margin", render.grid_margin,
                         "work plane: metres left out along the walls (default 0)");
  render_cmd->add_option(
      "--grid-csv", render.grid_csv,
      "work plane or surface: write x, y, z, direct and total lux per point to this CSV");
  render_cmd
      ->add_option("--illuminance-rays", render.illuminance_rays,
                   "hemisphere rays per grid point (default 256; a quarter of it per pixel)")
      ->check(CLI::Range(1, 65536));
  addCommon(render_cmd, common);
  addDryRun(render_cmd, common);

  TraceOptions trace;
  CLI::App* trace_cmd =
      app.add_subcommand("trace", "closest hits of a ray file against a mesh (the Ray Engine)");
  trace_cmd->add_option("mesh", trace.mesh, "mesh file or built-in scene")->required();
  trace_cmd->add_option("--rays", trace.rays, "rays: float32 ox oy oz tmin dx dy dz tmax")
      ->required();
  trace_cmd->add_option("-o,--output", trace.output, "hits: int32 triangle, float32 t u v")
      ->required();
  trace_cmd->add_option("--stats", trace.stats, "write statistics to this JSON file");
  trace_cmd->add_flag("--occlusion", trace.occlusion,
                      "shadow rays: write one byte per ray, 1 when anything lies within "
                      "[tmin, tmax] (any hit), else 0");
  trace_cmd
      ->add_option("--device", trace.device,
                   "cpu, gpu, hybrid (CPU/GPU split of the Ray Engine paper) or auto")
      ->capture_default_str();
  trace_cmd->add_option("--t-min", trace.t_min, "hybrid: fewest triangles in a GPU cell")
      ->check(CLI::Range(1u, 1u << 24))
      ->capture_default_str();
  trace_cmd->add_option("--t-max", trace.t_max, "hybrid: most triangles in a GPU cell")
      ->check(CLI::Range(1u, 1u << 24))
      ->capture_default_str();
  trace_cmd->add_option("--r-min", trace.r_min, "hybrid: rays a cell collects per GPU pass")
      ->check(CLI::Range(1u, 65536u))
      ->capture_default_str();
  trace_cmd
      ->add_option("--cache-rays", trace.cache_rays,
                   "hybrid: rays a cell's ray cache holds before it sends its most coherent "
                   "bucket (default 4 x --r-min)")
      ->check(CLI::Range(1u, 1u << 24));
  addCommon(trace_cmd, common);
  addDryRun(trace_cmd, common);

  InfoOptions info;
  CLI::App* info_cmd = app.add_subcommand("info", "what a scene holds: sizes, lights, warnings");
  info_cmd
      ->add_option("scene", info.scene,
                   "built-in scene name or file; a luminaire's .ldt or .ies file shows its "
                   "photometry")
      ->capture_default_str();
  info_cmd->add_option("--plot", info.plot,
                       "luminaire: write its polar light distribution curve to this PNG");
  info_cmd->add_flag("--devices", info.devices,
                     "list the OpenGL 4.5 contexts that can be made, with their limits");
  addCommon(info_cmd, common);

  BakeOptions bake;
  CLI::App* bake_cmd = app.add_subcommand(
      "bake", "solve radiosity and write a glTF with lightmaps (EXR, PNG) into a directory");
  bake_cmd->add_option("scene", bake.scene, "built-in scene name or file")->required();
  bake_cmd
      ->add_option("--method", bake.method,
                   "matrix (matrix radiosity), progressive (progressive radiosity) or "
                   "stochastic (stochastic radiosity)")
      ->capture_default_str();
  bake_cmd
      ->add_option("--device", bake.device,
                   "progressive: cpu, gpu or auto (matrix bakes on the CPU)")
      ->check(CLI::IsMember({"cpu", "gpu", "auto"}))
      ->capture_default_str();
  bake_cmd->add_option("-o,--output", bake.output, "output directory (created if missing)")
      ->capture_default_str();
  bake_cmd->add_option("--stats", bake.stats, "write statistics to this JSON file");
  bake_cmd
      ->add_option("--elements", bake.elements,
                   "about this many radiosity elements (default 2000; progressive: lightmap "
                   "texels, default 40000)")
      ->check(CLI::Range(1u, 1u << 28));
  bake_cmd->add_option("--iterations", bake.iterations, "iteration cap")
      ->check(CLI::Range(1, 1 << 20))
      ->capture_default_str();
  bake_cmd
      ->add_option("--tolerance", bake.tolerance,
                   "matrix: stop when the mean squared residual of MB - E ((W m^-2)^2) is at "
                   "most this (default 1e-6); progressive: when the unshot fraction of the "
                   "emitted power is (default 1e-3)")
      ->check(finiteIn(0.0, 1e30, /*open_lo=*/true));
  bake_cmd->add_option("--solver", bake.solver, "jacobi or gauss-seidel")
      ->check(CLI::IsMember({"jacobi", "gauss-seidel"}))
      ->capture_default_str();
  bake_cmd
      ->add_option("--ff-rays", bake.ff_rays,
                   "matrix: shadow rays per pair of elements that exchange a noticeable share "
                   "of their light (default 4)")
      ->check(CLI::Range(1, 1024));
  bake_cmd
      ->add_option("--texel-density", bake.texel_density,
                   "lightmap texels per metre (default: the most that fit --lightmap-size)")
      ->check(finiteIn(0.0, 1e9, /*open_lo=*/true));
  bake_cmd
      ->add_option("--lightmap-size", bake.lightmap_size,
                   "lightmap width and height when --texel-density is not given (matrix: "
                   "default 1024; progressive: default from --elements)")
      ->check(CLI::Range(8, 16384));
  bake_cmd
      ->add_option("--shooter-points", bake.shooter_points,
                   "progressive: points a shooter starts from (see render)")
      ->check(CLI::Range(1, 4096))
      ->capture_default_str();
  addReceiverOptions(bake_cmd, bake);
  addStochasticOptions(bake_cmd, bake);
  bake_cmd->add_option("--seed", bake.seed, "stochastic: random seed (default 0)")
      ->check(kUnsigned);
  bake_cmd
      ->add_option("--normals", bake.normals, "progressive: interpolated or triangle (see render)")
      ->check(CLI::IsMember({"interpolated", "triangle"}))
      ->capture_default_str();
  bake_cmd->add_option("--resume", bake.resume,
                       "progressive: continue from this checkpoint (written on Ctrl-C)");
  bake_cmd->add_flag("--keep-checkpoint", bake.keep_checkpoint,
                     "progressive: keep the --resume checkpoint after the bake completes");
  bake_cmd->add_option("--checkpoint", bake.checkpoint,
                       "progressive: where Ctrl-C writes the checkpoint (default: "
                       "DIR/SCENE.checkpoint)");
  addCommon(bake_cmd, common);
  addDryRun(bake_cmd, common);

  RaysOptions rays;
  CLI::App* rays_cmd = app.add_subcommand(
      "rays", "write a ray file for trace: a camera's primary rays or diffuse surface rays");
  rays_cmd->add_option("scene", rays.scene, "built-in scene name or file")->required();
  rays_cmd->add_option("-o,--output", rays.output, "ray file (float32 ox oy oz tmin dx dy dz tmax)")
      ->required();
  rays_cmd
      ->add_option("--kind", rays.kind,
                   "camera (one ray per pixel through the scene's camera) or diffuse (from "
                   "random surface points, cosine-distributed, either side)")
      ->capture_default_str();
  rays_cmd->add_option("--width", rays.width, "camera: image width (default 512)")
      ->check(CLI::Range(1, 1 << 16));
  rays_cmd->add_option("--height", rays.height, "camera: image height (default 512)")
      ->check(CLI::Range(1, 1 << 16));
  rays_cmd->add_option("--count", rays.count, "diffuse: number of rays (default 1048576)")
      ->check(CLI::Range(uint64_t(1), uint64_t(1) << 34));
  rays_cmd->add_option("--seed", rays.seed, "diffuse: random seed (default 0)")->check(kUnsigned);
  rays_cmd
      ->add_option("--tmin", rays.t_min,
                   "diffuse: distance the rays start at (default 1e-4 of the scene's diagonal)")
      ->check(finiteIn(0.0, 1e30));
  addCommon(rays_cmd, common);
  addDryRun(rays_cmd, common);

  for (CLI::App* cmd : {render_cmd, trace_cmd, info_cmd, bake_cmd, rays_cmd}) {
    refuseEmptyValues(cmd);
  }

  const std::string first = argc > 1 ? argv[1] : "";
  const bool session = CommandSession::current() != nullptr;
  if (first == "view" && !session) return runView(argc, argv);
  if (!first.empty() && first[0] != '-' && first != "render" && first != "bake" &&
      first != "trace" && first != "rays" && first != "info") {
    return reportError(inputError(
        "", "",
        fmt::format("unknown command '{}' (commands: render, bake, trace, rays, info, view)",
                    first)));
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    if (session) return reportError(inputError("", "", "--help and --version: see the CLI"));
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    return reportError(inputError("", "", fmt::format("{} (see penumbra --help)", e.what())));
  }

  render.tonemap.op =
      tonemap == "exposure" ? ToneMapOperator::kExposure : ToneMapOperator::kReinhard;
  // Over several processes only rank 0 logs; the others print only what fails on them alone.
  const Communicator& comm = currentCommunicator();
  initLogging(common.quiet || !comm.root());
  if (!comm.root()) spdlog::set_level(spdlog::level::err);
  setThisProcessWritesOutputs(comm.root());
  // Signals and the thread limit are the process's: the CLI takes them; a program calling the
  // library through a session keeps its own signal handlers, and the limit lasts for the call.
  if (!session) {
    installInterruptHandlers();
    if (comm.distributed()) interruptSignalsEndDistributedRun(comm.rank(), comm.size());
  }
  auto thread_limit = limitThreads(threadsPerRank(comm, common.threads));
  if (render_cmd->parsed()) return runRender(render, common);
  if (bake_cmd->parsed()) return runBake(bake, common);
  if (trace_cmd->parsed()) return runTrace(trace, common);
  if (info_cmd->parsed()) return runInfo(info, common);
  if (rays_cmd->parsed()) return runRays(rays, common);
  return 2;
}

}  // namespace

int runCommandLine(const std::vector<std::string>& args) {
  std::vector<std::string> words = args;
  std::vector<char*> argv;
  for (std::string& w : words) argv.push_back(w.data());
  argv.push_back(nullptr);
  return parseAndRun(int(words.size()), argv.data());
}

namespace {

int runCliCommand(int argc, char** argv) {
  try {
    return parseAndRun(argc, argv);
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "penumbra: error: out of memory\n");
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "penumbra: error: %s\n", e.what());
    return 1;
  }
}

}  // namespace

int runCli(int argc, char** argv) {
  // Under mpirun: one rank of an MPI job (cluster/communicator.h); otherwise one process.
  MpiJob job(&argc, &argv);
  if (!job.world() && launchedByMpiLauncher() && launcherWorldSize() > 1) {
    std::fprintf(stderr,
                 "penumbra: error: started as one of %d MPI processes, but this build has no MPI "
                 "(build it with libopenmpi-dev installed)\n",
                 launcherWorldSize());
    return 2;
  }
  std::optional<CommunicatorScope> scope;
  if (job.world()) scope.emplace(*job.world());
  const int code = runCliCommand(argc, argv);
  // A rank that failed ends without MPI_Finalize (which waits for every rank): mpirun sees its
  // exit code and stops the others. A run that all ranks stopped together (a stop request: the
  // checkpoint is written) finalises, so that rank 0 finishes writing before any rank ends.
  const bool agreed = code == 0 || code == 128 + SIGUSR1;
  if (!agreed && job.world() && job.world()->distributed()) job.skipFinalize();
  return code;
}

}  // namespace penumbra
