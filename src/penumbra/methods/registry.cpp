// The descriptions of every method's options (methods/registry.h). Defaults shown here are the
// ones the methods apply (each method's settings struct holds the value); docs/cli.md's option
// reference is generated from this file.
#include "penumbra/methods/registry.h"

#include "penumbra/radiosity/matrix_radiosity.h"
#include "penumbra/radiosity/progressive.h"
#include "penumbra/radiosity/progressive_receivers.h"
#include "penumbra/radiosity/stochastic.h"
#include "penumbra/raytrace/path_tracer.h"
#include "penumbra/raytrace/photon_map.h"
#include "penumbra/raytrace/whitted.h"
#include "penumbra/subsurface/lpv.h"
#include "penumbra/subsurface/sss.h"
#include "penumbra/subsurface/sss_links.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <functional>
#include <map>
#include <type_traits>

namespace penumbra {

namespace {

using K = OptionKind;

// The methods, as `render --method` lists them.
const std::vector<std::string> kAll = {"pathtrace",   "whitted",    "photons", "matrix",
                                       "progressive", "stochastic", "sss",     "lpv"};
const std::vector<std::string> kLightmap = {"matrix", "progressive", "stochastic"};
const std::vector<std::string> kLux = {"pathtrace", "matrix", "progressive"};
const std::vector<std::string> kCheckpointed = {"progressive", "stochastic"};
// What `bake --method` takes: the radiosity methods and the path-traced reference.
const std::vector<std::string> kBakes = {"pathtrace", "matrix", "progressive", "stochastic"};

// A default as the docs show it, from the value the method's settings hold.
template <typename T>
std::string text(T value) {
  return fmt::format("{}", value);
}

OptionRange range(double lo, double hi, bool open_lo = false, bool open_hi = false) {
  return OptionRange{lo, hi, open_lo, open_hi};
}

// Each of `methods` takes the option with the same default.
std::vector<OptionUse> all(const std::vector<std::string>& methods, const std::string& def = {}) {
  std::vector<OptionUse> uses;
  for (const std::string& m : methods) uses.push_back(OptionUse{m, def, std::nullopt});
  return uses;
}

// ---- Setting a field of the options structs from a checked value ----

template <typename Field>
void assign(Field& field, const OptionValue& value) {
  const auto number = [&]() -> double {
    return std::visit(
        [](const auto& v) -> double {
          if constexpr (std::is_arithmetic_v<std::decay_t<decltype(v)>>) {
            return double(v);
          } else {
            return 0.0;
          }
        },
        value);
  };
  if constexpr (std::is_same_v<Field, bool>) {
    field = std::get<bool>(value);
  } else if constexpr (std::is_same_v<Field, std::string>) {
    field = std::get<std::string>(value);
  } else if constexpr (std::is_same_v<Field, std::vector<std::string>>) {
    field.push_back(std::get<std::string>(value));
  } else if constexpr (std::is_same_v<Field, std::vector<double>>) {
    field = std::get<std::vector<double>>(value);
  } else if constexpr (std::is_same_v<Field, std::optional<std::string>>) {
    field = std::get<std::string>(value);
  } else if constexpr (std::is_same_v<Field, uint64_t> ||
                       std::is_same_v<Field, std::optional<uint64_t>>) {
    field = std::holds_alternative<uint64_t>(value) ? std::get<uint64_t>(value)
                                                    : uint64_t(std::get<int64_t>(value));
  } else if constexpr (std::is_same_v<Field, double> ||
                       std::is_same_v<Field, std::optional<double>>) {
    field = number();
  } else if constexpr (std::is_same_v<Field, std::optional<int>> ||
                       std::is_same_v<Field, std::optional<uint32_t>>) {
    field = typename Field::value_type(std::get<int64_t>(value));
  } else {
    static_assert(std::is_integral_v<Field>);
    field = Field(std::get<int64_t>(value));
  }
}

template <typename Options>
using Setter = std::function<void(Options&, const OptionValue&)>;

template <typename Options, typename Owner, typename Field>
Setter<Options> field(Field Owner::*member) {
  return [member](Options& o, const OptionValue& v) { assign(o.*member, v); };
}

template <typename Options>
struct Bound {
  OptionSpec spec;
  Setter<Options> set;
};

// ---- Options both render and bake take for the lightmap methods ----

template <typename Options>
void addReceiverOptions(std::vector<Bound<Options>>& out) {
  out.push_back({{.name = "adaptive",
                  .kind = K::kFlag,
                  .help = "Wallner sec. 4: receivers start coarse (--receiver-level, default 2) "
                          "and are split at shadow boundaries before each shooter first shoots",
                  .uses = all({"progressive"}, "off")},
                 field<Options>(&LightmapMethodOptions::adaptive)});
  out.push_back({{.name = "receiver-level",
                  .kind = K::kInt,
                  .range = range(0, 16),
                  .help = "receivers are blocks of 2^L x 2^L lightmap texels, gathering at one "
                          "point each",
                  .uses = all({"progressive"}, "0 (2 with --adaptive)")},
                 field<Options>(&LightmapMethodOptions::receiver_level)});
  out.push_back({{.name = "boundary",
                  .kind = K::kRealList,
                  .range = range(0, 1),
                  .count = 2,
                  .help = "LOW,HIGH: a receiver whose share of visible samples lies in [LOW, "
                          "HIGH] holds a shadow boundary",
                  .uses = all({"progressive"}, "0.05,0.95")},
                 field<Options>(&LightmapMethodOptions::boundary)});
  out.push_back({{.name = "finest-level",
                  .kind = K::kInt,
                  .range = range(0, 16),
                  .help = "--adaptive: receivers are split down to this level at most",
                  .uses = all({"progressive"}, "0")},
                 field<Options>(&LightmapMethodOptions::finest_level)});
  out.push_back({{.name = "min-share",
                  .kind = K::kReal,
                  .range = range(0, 1),
                  .help = "--adaptive: split only where the shooter brings at least this share "
                          "of a receiver's irradiance (0: the paper's test alone)",
                  .uses = all({"progressive"}, text(SubdivisionOptions{}.min_share))},
                 field<Options>(&LightmapMethodOptions::min_share)});
  out.push_back({{.name = "time-limit",
                  .kind = K::kReal,
                  .range = range(0, 1e9, /*open_lo=*/true),
                  .unit = "s",
                  .help = "stop after this many seconds of iterating; without --iterations the "
                          "iteration cap is lifted",
                  .uses = all({"stochastic"})},
                 field<Options>(&LightmapMethodOptions::time_limit)});
  out.push_back({{.name = "shooters",
                  .kind = K::kInt,
                  .range = range(1, 4096),
                  .help = "independent shooters per iteration, averaged (an iteration costs N "
                          "times as much and has 1/N of the variance)",
                  .uses = all({"stochastic"}, "1")},
                 field<Options>(&LightmapMethodOptions::shooters)});
  out.push_back({{.name = "first-shots",
                  .kind = K::kInt,
                  .range = range(0, 4096),
                  .help = "up to N shooters shoot once, deterministically, by progressive "
                          "radiosity's shot (the lights, the emitters, then the brightest "
                          "reflectors, while more than a tenth of the power is unshot) before the "
                          "random iteration carries the rest; 0: all by the random operator, as "
                          "in the paper",
                  .uses = all({"stochastic"}, text(kStochasticFirstShots))},
                 field<Options>(&LightmapMethodOptions::first_shots)});
}

// ---- penumbra render ----

template <typename Options>
struct Adder {
  std::vector<Bound<Options>>& b;
  void operator()(OptionSpec spec, Setter<Options> set) const {
    b.push_back({std::move(spec), std::move(set)});
  }
};

// ---- Options render and bake take alike for the lightmap methods ----

// The solve: elements, the iteration cap, the tolerance, the form factors' rays, the shooters'
// points and the normals.
template <typename Options>
void addSolveOptions(std::vector<Bound<Options>>& b) {
  const Adder<Options> add{b};
  add({.name = "elements",
       .kind = K::kInt,
       .range = range(1, 1 << 28),
       .help = "matrix: unknowns (clusters of the lightmap's hierarchy); progressive, "
               "stochastic: about this many lightmap texels",
       .uses = {{"matrix", text(kMatrixDefaultElements), {}},
                {"progressive", text(kProgressiveDefaultElements), {}},
                {"stochastic", text(kProgressiveDefaultElements), {}}}},
      field<Options>(&Options::elements));
  if constexpr (std::is_same_v<Options, BakeOptions>) {
    // bake --method pathtrace: about this many lightmap texels, as stochastic radiosity.
    b.back().spec.uses.push_back({"pathtrace", text(kDefaultLightmapElements), {}});
  }
  add({.name = "iterations",
       .kind = K::kInt,
       .range = range(1, 1 << 20),
       .help = "iteration cap (progressive: shooters; stochastic: random operators after the "
               "first shots, whose error falls as one over the square root of their number; "
               "counted over resumed runs); with --time-limit stochastic radiosity runs as long "
               "as it allows",
       .uses = {{"matrix", text(kIterationCapDefault), {}},
                {"progressive", text(kIterationCapDefault), {}},
                {"stochastic", text(kStochasticIterationCap) + ", none with --time-limit", {}}}},
      field<Options>(&Options::iterations));
  add({.name = "tolerance",
       .kind = K::kReal,
       .range = range(0, 1e30, /*open_lo=*/true),
       .help = "matrix: stop when the mean squared residual of MB - E over the mean squared "
               "emission is at most this; progressive: when the unshot fraction of the emitted "
               "power is",
       .uses = {{"matrix", "1e-6", {}}, {"progressive", "1e-3", {}}}},
      field<Options>(&Options::tolerance));
  if constexpr (std::is_same_v<Options, BakeOptions>) {
    // bake --method pathtrace: each texel's relative standard error.
    b.back().spec.help += "; bake --method pathtrace: when each texel's relative standard error is";
    b.back().spec.uses.push_back({"pathtrace", "0.02", range(0, 1, true, true)});
  }
  add({.name = "ff-rays",
       .kind = K::kInt,
       .range = range(1, 1024),
       .help = "shadow rays per pair that needs more than one: matrix, clusters exchanging a "
               "noticeable share of their light; progressive (CPU), a receiver and a shooter "
               "point in a penumbra or behind a cut-out",
       .uses = {{"matrix", "4", {}}, {"progressive", "16", {}}}},
      field<Options>(&Options::ff_rays));
  add({.name = "shooter-points",
       .kind = K::kInt,
       .range = range(1, 4096),
       .help = "points a shooter starts from (its texels grouped in blocks; nearer receivers "
               "refine them)",
       .uses = all({"progressive"}, "16")},
      field<Options>(&Options::shooter_points));
  add({.name = "normals",
       .kind = K::kChoice,
       .choices = {"interpolated", "triangle"},
       .help = "interpolated (shading normals across triangles) or triangle (each triangle's "
               "own normal)",
       .uses = all(kLightmap, "interpolated")},
      field<Options>(&Options::normals));
}

// Checkpoints of progressive and stochastic radiosity; `where` is the checkpoint's default place.
template <typename Options>
void addCheckpointOptions(std::vector<Bound<Options>>& b, const std::string& where) {
  const Adder<Options> add{b};
  add({.name = "resume",
       .kind = K::kText,
       .help = "continue from this checkpoint (written on Ctrl-C)",
       .uses = all(kCheckpointed)},
      field<Options>(&Options::resume));
  add({.name = "keep-checkpoint",
       .kind = K::kFlag,
       .help = "keep the --resume checkpoint after the run completes",
       .uses = all(kCheckpointed, "off")},
      field<Options>(&Options::keep_checkpoint));
  add({.name = "checkpoint",
       .kind = K::kText,
       .help = "where Ctrl-C writes the checkpoint",
       .uses = all(kCheckpointed, where)},
      field<Options>(&Options::checkpoint));
}

// The scene, the method, the device, the outputs and the image.
void renderOutputOptions(const Adder<RenderOptions>& add) {
  using R = RenderOptions;
  add({.name = "scene",
       .kind = K::kText,
       .help = "built-in scene name (cornell, furnace, sss, lpv, blobs) or a .json, .obj, .gltf, "
               ".glb or .ply file",
       .positional = true},
      field<R>(&R::scene));
  add({.name = "method",
       .kind = K::kChoice,
       .choices = kAll,
       .help = "the method (docs/cli.md; penumbra methods): pathtrace (the reference path "
               "tracer), whitted (direct light, mirrors and glass only: no diffuse "
               "interreflection, so indirectly lit rooms come out darker), photons, matrix, "
               "progressive, stochastic, sss or lpv"},
      field<R>(&R::method));
  add({.name = "device",
       .kind = K::kChoice,
       .choices = {"cpu", "gpu", "hybrid", "auto"},
       .help = "cpu, gpu, hybrid (the Ray Engine's CPU/GPU split) or auto"},
      field<R>(&R::device));
  add({.name = "output",
       .kind = K::kText,
       .help = "output image (.exr .hdr .pfm linear, .png tone mapped); may repeat",
       .short_name = "-o",
       .repeatable = true},
      field<R>(&R::outputs));
  add({.name = "stats", .kind = K::kText, .help = "write statistics to this JSON file"},
      field<R>(&R::stats));
  add({.name = "width",
       .kind = K::kInt,
       .range = range(1, 65536),
       .unit = "pixels",
       .help = "image width",
       .uses = all(kAll, "512")},
      field<R>(&R::width));
  add({.name = "height",
       .kind = K::kInt,
       .range = range(1, 65536),
       .unit = "pixels",
       .help = "image height",
       .uses = all(kAll, "512")},
      field<R>(&R::height));
  {
    OptionSpec spp{.name = "spp",
                   .kind = K::kInt,
                   .range = range(1, 4096),
                   .help = "samples (camera rays, stratified within the pixel) per pixel",
                   .uses = all(kAll)};
    for (OptionUse& u : spp.uses) u.default_value = text(WhittedSettings{}.spp);
    spp.uses[0] = OptionUse{"pathtrace", text(PathTracerSettings{}.spp), range(1, 1 << 20)};
    add(spp, field<R>(&R::spp));
  }
  add({.name = "max-depth",
       .kind = K::kInt,
       .range = range(0, 64),
       .help = "pathtrace: bounce limit, 0 = unlimited (Russian roulette ends paths without "
               "bias); whitted, photons: mirror and glass generations after the camera ray",
       .uses = {{"pathtrace", text(PathTracerSettings{}.max_depth), range(0, 65536)},
                {"whitted", text(WhittedSettings{}.max_depth), {}},
                {"photons", text(WhittedSettings{}.max_depth), {}}}},
      field<R>(&R::max_depth));
}

// Whitted ray tracing and photon mapping.
void rayTracedOptions(const Adder<RenderOptions>& add) {
  using R = RenderOptions;
  add({.name = "light-samples",
       .kind = K::kInt,
       .range = range(0, 1024),
       .help = "shadow rays per diffuse point to the emissive surfaces, and as many to the "
               "environment",
       .uses = all({"whitted", "photons"}, text(WhittedSettings{}.light_samples))},
      field<R>(&R::light_samples));
  add({.name = "photons",
       .kind = K::kUnsigned,
       .range = range(1, 4294967296.0),
       .help = "photons emitted for the global map",
       .uses = all({"photons"}, text(PhotonSettings{}.photons))},
      field<R>(&R::photons));
  add({.name = "caustic-photons",
       .kind = K::kUnsigned,
       .range = range(0, 4294967296.0),
       .help = "photons emitted towards mirrors and glass for the caustic map (0: none)",
       .uses = all({"photons"}, text(PhotonSettings{}.caustic_photons))},
      field<R>(&R::caustic_photons));
  add({.name = "gather-count",
       .kind = K::kInt,
       .range = range(1, 10000),
       .help = "photons per density estimate",
       .uses = all({"photons"}, text(PhotonSettings{}.gather_count))},
      field<R>(&R::gather_count));
  add({.name = "gather-radius",
       .kind = K::kReal,
       .range = range(0, 1e6, true, true),
       .unit = "m",
       .help = "the photons' largest distance from the point",
       .uses = all({"photons"}, "1% of the scene's diagonal")},
      field<R>(&R::gather_radius));
  add({.name = "final-gather",
       .kind = K::kInt,
       .range = range(0, 4096),
       .help = "gather rays per diffuse point; 0 reads the global map at the point itself",
       .uses = all({"photons"}, text(PhotonSettings{}.final_gather))},
      field<R>(&R::final_gather));
}

// Random numbers and tone mapping.
void samplingOptions(const Adder<RenderOptions>& add) {
  using R = RenderOptions;
  add({.name = "seed",
       .kind = K::kUnsigned,
       .help = "random seed: the image is a function of the seed, not of the thread count",
       .uses = all(kAll, "0")},
      field<R>(&R::seed));
  add({.name = "sampler",
       .kind = K::kChoice,
       .choices = {"sobol", "independent"},
       .help = "sobol (Owen-scrambled Sobol points) or independent (one random stream per "
               "sample)",
       .uses = all({"pathtrace"}, "sobol")},
      field<R>(&R::sampler));
  add({.name = "tonemap",
       .kind = K::kChoice,
       .choices = {"reinhard", "exposure"},
       .help = "PNG tone mapping: reinhard (Reinhard et al. 2002, automatic key) or exposure",
       .uses = all(kAll, "reinhard")},
      [](R& o, const OptionValue& v) {
        o.tonemap.op = std::get<std::string>(v) == "exposure" ? ToneMapOperator::kExposure
                                                              : ToneMapOperator::kReinhard;
      });
  add({.name = "exposure",
       .kind = K::kReal,
       .range = range(-64, 64),
       .unit = "stops",
       .help = "brightens by 2^STOPS before tone mapping",
       .uses = all(kAll, "0")},
      [](R& o, const OptionValue& v) { o.tonemap.exposure_stops = float(std::get<double>(v)); });
  add({.name = "key",
       .kind = K::kReal,
       .range = range(0, 1, /*open_lo=*/true),
       .help = "Reinhard key value, the mean image brightness aimed at",
       .uses = all(kAll, "estimated from the image")},
      [](R& o, const OptionValue& v) { o.tonemap.key = float(std::get<double>(v)); });
}

// The radiosity methods: solver, elements, iterations, the lightmap.
void radiosityOptions(const Adder<RenderOptions>& add) {
  using R = RenderOptions;
  add({.name = "solver",
       .kind = K::kChoice,
       .choices = {"jacobi", "gauss-seidel"},
       .help = "jacobi (Carr et al. 2003 eq. 4, rows in parallel) or gauss-seidel (sequential, "
               "CPU only)",
       .uses = all({"matrix"}, "gauss-seidel on the CPU, jacobi on the GPU")},
      field<R>(&R::solver));
  add({.name = "precision",
       .kind = K::kChoice,
       .choices = {"fp32", "fp16"},
       .help = "form-factor storage: fp32, or fp16 as the paper stores them",
       .uses = all({"matrix"}, "fp32")},
      field<R>(&R::precision));
  add({.name = "relight-frames",
       .kind = K::kInt,
       .range = range(0, 10000),
       .help = "N > 1: N frames with the emitters' colour going round the hue circle, each "
               "solved from the previous one with the same form factors (out_0000.png ...)",
       .uses = all({"matrix"}, "0")},
      field<R>(&R::relight_frames));
  add({.name = "shading",
       .kind = K::kChoice,
       .choices = {"smooth", "flat"},
       .help = "smooth (clusters' light interpolated to every texel) or flat (one value per "
               "cluster)",
       .uses = all({"matrix"}, "smooth")},
      field<R>(&R::shading));
  add({.name = "texel-density",
       .kind = K::kReal,
       .range = range(0, 1e9, /*open_lo=*/true),
       .unit = "texels/m",
       .help = "lightmap texels per metre, instead of the density from --elements "
               "(sss: from --lightmap-size)",
       .uses = all({"matrix", "progressive", "stochastic", "sss"})},
      field<R>(&R::texel_density));
  addSolveOptions(add.b);
  addReceiverOptions(add.b);
}

// Normals of the lightmap methods, subsurface scattering and volumes.
void subsurfaceOptions(const Adder<RenderOptions>& add) {
  using R = RenderOptions;
  add({.name = "lightmap-size",
       .kind = K::kInt,
       .range = range(8, 16384),
       .unit = "texels",
       .help = "the atlas's width and height",
       .uses = all({"sss"}, text(kSssDefaultAtlas))},
      field<R>(&R::lightmap_size));
  add({.name = "links",
       .kind = K::kInt,
       .range = range(1, 1024),
       .help = "links per texel, refined adaptively from the object's root",
       .uses = all({"sss"}, text(SssLinkOptions{}.links))},
      field<R>(&R::links));
  add({.name = "links-level",
       .kind = K::kInt,
       .range = range(0, 30),
       .help = "the non-adaptive scheme instead: a link to every cluster of this level",
       .uses = all({"sss"})},
      field<R>(&R::links_level));
  add({.name = "frames",
       .kind = K::kInt,
       .range = range(0, 100000),
       .help = "N frames with the lights orbiting the scene once, or an animation's N times "
               "(out_0000.png ...)",
       .uses = all({"sss", "lpv"}, "0")},
      field<R>(&R::frames));
  add({.name = "grid",
       .kind = K::kInt,
       .range = range(4, 128),
       .unit = "cells",
       .help = "cells along each translucent object's longest side",
       .uses = all({"lpv"}, text(LpvOptions{}.grid))},
      field<R>(&R::grid));
  add({.name = "steps",
       .kind = K::kInt,
       .range = range(1, 4096),
       .help = "propagation steps (the paper's Table 1 runs 8 and 32)",
       .uses = all({"lpv"}, text(LpvOptions{}.steps))},
      field<R>(&R::steps));
  add({.name = "skip-steps",
       .kind = K::kInt,
       .range = range(0, 4095),
       .help = "first steps left out of the accumulation",
       .uses = all({"lpv"}, text(LpvOptions{}.skip_steps))},
      field<R>(&R::skip_steps));
  add({.name = "rsm-resolution",
       .kind = K::kInt,
       .range = range(1, 4096),
       .unit = "texels",
       .help = "injection texels per side of each light's reflective shadow map",
       .uses = all({"lpv"}, text(LpvOptions{}.rsm_resolution))},
      field<R>(&R::rsm_resolution));
  add({.name = "surface-samples",
       .kind = K::kInt,
       .range = range(0, 1 << 20),
       .help = "points of each translucent surface that gather the light of emitting surfaces "
               "and the environment (0: none)",
       .uses = all({"lpv"}, text(LpvOptions{}.surface_samples))},
      field<R>(&R::surface_samples));
  add({.name = "surface-rays",
       .kind = K::kInt,
       .range = range(0, 256),
       .help = "cosine-distributed rays per surface point",
       .uses = all({"lpv"}, text(LpvOptions{}.surface_rays))},
      field<R>(&R::surface_rays));
}

// The SSS link cache and the checkpoints.
void cacheAndCheckpointOptions(const Adder<RenderOptions>& add) {
  using R = RenderOptions;
  addCheckpointOptions(add.b, "the first output with the extension .checkpoint");
  add({.name = "no-cache",
       .kind = K::kFlag,
       .help = "build the links even if the cache holds them, and do not store them",
       .uses = all({"sss"}, "off")},
      field<R>(&R::no_cache));
  add({.name = "no-shadows",
       .kind = K::kFlag,
       .help = "pass 1 without shadow rays, as the paper's vertex-program lighting",
       .uses = all({"sss"}, "off")},
      field<R>(&R::no_shadows));
}

// Lighting design: lux images and calculation points.
void luxOptions(const Adder<RenderOptions>& add) {
  using R = RenderOptions;
  add({.name = "output-quantity",
       .kind = K::kChoice,
       .choices = {"radiance", "illuminance"},
       .help = "radiance, or illuminance: lux on the surfaces the camera sees",
       .uses = all(kLux, "radiance")},
      field<R>(&R::output_quantity));
  add({.name = "false-colour",
       .kind = K::kFlag,
       .help = "illuminance: PNG outputs in false colour, blue to red, with a legend in lux",
       .uses = all(kLux, "off")},
      field<R>(&R::false_colour));
  add({.name = "lux-max",
       .kind = K::kReal,
       .range = range(0, 1e12, true),
       .unit = "lx",
       .help = "illuminance: the lux at the top of the false-colour scale",
       .uses = all(kLux, "a round number above the 99th percentile")},
      field<R>(&R::lux_max));
  add({.name = "work-plane",
       .kind = K::kReal,
       .range = range(-1e6, 1e6),
       .unit = "m",
       .help = "a horizontal grid of calculation points this high above the scene's lowest "
               "point: average, minimum, maximum lux and uniformity U0",
       .uses = all(kLux)},
      field<R>(&R::work_plane));
  add({.name = "grid-surface",
       .kind = K::kText,
       .help = "calculation points on the front of the mesh of this name",
       .uses = all(kLux)},
      field<R>(&R::grid_surface));
  add({.name = "grid-spacing",
       .kind = K::kReal,
       .range = range(0, 1e6, true),
       .unit = "m",
       .help = "work plane or surface: metres between points",
       .uses = all(kLux, "0.25")},
      field<R>(&R::grid_spacing));
  add({.name = "grid-margin",
       .kind = K::kReal,
       .range = range(0, 1e6),
       .unit = "m",
       .help = "work plane: metres left out along the walls",
       .uses = all(kLux, "0")},
      field<R>(&R::grid_margin));
  add({.name = "grid-csv",
       .kind = K::kText,
       .help = "work plane or surface: x, y, z, direct and total lux per point to this CSV",
       .uses = all(kLux)},
      field<R>(&R::grid_csv));
  add({.name = "calc",
       .kind = K::kText,
       .help = "calculation objects from this JSON file (work planes, grids on any plane, "
               "surfaces, points; docs/scene-format.md); may repeat",
       .uses = all(kLux),
       .repeatable = true},
      field<R>(&R::calc_files));
  add({.name = "points",
       .kind = K::kText,
       .help = "calculation points from this CSV (x,y,z[,nx,ny,nz[,name]]) or JSON file; may "
               "repeat",
       .uses = all(kLux),
       .repeatable = true},
      field<R>(&R::points_files));
  add({.name = "report",
       .kind = K::kText,
       .help = "a folder for the calculation objects' reports: NAME.csv, NAME.json and, for "
               "grids, a plan-view false-colour NAME.png with the values printed",
       .uses = all(kLux)},
      field<R>(&R::report_dir));
  add({.name = "illuminance-rays",
       .kind = K::kInt,
       .range = range(1, 65536),
       .help = "hemisphere rays per calculation point (a quarter of it per pixel, 64 by "
               "default); by default as many as 4 million rays an object allow, 256 to 65536",
       .uses = all(kLux, "auto")},
      field<R>(&R::illuminance_rays));
}

// How the scene is read and what it is given (methods/scene_inputs.h), alike for render and bake;
// `sky_methods` and `environment_methods` are the methods that take a sky and an environment.
template <typename Options>
void addSceneInputOptions(std::vector<Bound<Options>>& b,
                          const std::vector<std::string>& sky_methods,
                          const std::vector<std::string>& environment_methods) {
  const Adder<Options> add{b};
  add({.name = "allow-outside-files",
       .kind = K::kFlag,
       .help = "read files a glTF or OBJ file names outside its own folder (absolute paths, "
               "'..', links); by default they are refused, so a downloaded file cannot copy the "
               "machine's files into a bake"},
      field<Options>(&Options::allow_outside_files));
  add({.name = "max-texture-size",
       .kind = K::kInt,
       .range = range(1, 16384),
       .unit = "texels",
       .help = "the largest side a texture keeps; larger images are reduced as they are "
               "decoded, with a warning (default 8192)"},
      field<Options>(&Options::max_texture_size));
  add({.name = "gltf-scene",
       .kind = K::kInt,
       .range = range(0, 1 << 20),
       .help = "which scene of a glTF file holding several (default: the file's own `scene`, "
               "else the first)"},
      field<Options>(&Options::gltf_scene));
  add({.name = "scale",
       .kind = K::kReal,
       .range = range(1e-6, 1e6),
       .unit = "m per unit",
       .help = "the length of one unit of the scene's files: 0.001 for millimetres, 0.0254 for "
               "inches; lightmap density, light positions and lux follow"},
      field<Options>(&Options::scale));
  add({.name = "sky",
       .kind = K::kChoice,
       .choices = {"overcast", "uniform", "clear", "sunny"},
       .help = "light the scene with a CIE sky: overcast (the traditional CIE overcast sky), "
               "uniform, clear (CIE clear sky, type 12) or sunny (the clear sky and the sun's "
               "beam, 45 degrees high in the south, the scene's +z), over a ground of "
               "reflectance 0.2",
       .uses = all(sky_methods)},
      field<Options>(&Options::sky));
  add({.name = "sky-illuminance",
       .kind = K::kReal,
       .range = range(0, 1e6, true),
       .unit = "lx",
       .help = "--sky's horizontal illuminance (sunny: of the sky alone; the beam adds 60,000 "
               "lx square to it)",
       .uses = all(sky_methods, "10000")},
      field<Options>(&Options::sky_illuminance));
  add({.name = "environment",
       .kind = K::kRealList,
       .range = range(0, 1e6),
       .count = 3,
       .unit = "W m^-2 sr^-1",
       .help = "light the scene with a uniform environment of this RGB radiance from every "
               "direction the scene does not block (as a viewer's neutral environment)",
       .uses = all(environment_methods)},
      field<Options>(&Options::environment));
}

std::vector<Bound<RenderOptions>> renderBindings() {
  std::vector<Bound<RenderOptions>> b;
  const Adder<RenderOptions> add{b};
  renderOutputOptions(add);
  addSceneInputOptions(b, {"pathtrace", "matrix", "progressive", "stochastic"},
                       {"pathtrace", "whitted", "photons", "matrix", "progressive", "stochastic"});
  rayTracedOptions(add);
  samplingOptions(add);
  radiosityOptions(add);
  subsurfaceOptions(add);
  cacheAndCheckpointOptions(add);
  luxOptions(add);
  return b;
}

// ---- penumbra bake ----

std::vector<Bound<BakeOptions>> bakeBindings() {
  using B = BakeOptions;
  std::vector<Bound<B>> b;
  const auto add = [&](OptionSpec spec, Setter<B> set) { b.push_back({std::move(spec), set}); };
  add({.name = "scene",
       .kind = K::kText,
       .help = "built-in scene name or a scene file",
       .positional = true},
      field<B>(&B::scene));
  add({.name = "method",
       .kind = K::kChoice,
       .choices = kBakes,
       .help = "matrix (matrix radiosity), progressive (progressive radiosity), stochastic "
               "(stochastic radiosity) or pathtrace (every texel path-traced: the reference)"},
      field<B>(&B::method));
  add({.name = "device",
       .kind = K::kChoice,
       .choices = {"cpu", "gpu", "auto"},
       .help = "progressive and stochastic: cpu, gpu or auto (matrix bakes on the CPU)"},
      field<B>(&B::device));
  add({.name = "output",
       .kind = K::kText,
       .help = "output directory (created if missing)",
       .short_name = "-o"},
      field<B>(&B::output));
  add({.name = "stats", .kind = K::kText, .help = "write statistics to this JSON file"},
      field<B>(&B::stats));
  addSceneInputOptions(b, kBakes, kBakes);
  add({.name = "gltf",
       .kind = K::kChoice,
       .choices = {"asset", "emissive"},
       .help = "asset: the input's own glTF with its materials, textures and nodes, the "
               "lightmap added as HDR irradiance on a UV set of its own (PENUMBRA_lightmap); "
               "emissive: a self-contained file that shows the baked light as emission in any "
               "glTF viewer",
       .uses = all(kBakes, "asset")},
      field<B>(&B::gltf));
  add({.name = "web",
       .kind = K::kText,
       .help = "also write the web viewer (index.html and three.js) into this directory, "
               "showing the bake (asset output only)",
       .uses = all(kBakes)},
      field<B>(&B::web));
  add({.name = "lightmap-uv",
       .kind = K::kChoice,
       .choices = {"generate", "asset"},
       .help = "generate: Penumbra's own chart atlas; asset: a mesh's second UV set "
               "(TEXCOORD_1) where it has one, its islands kept as the artist laid them out "
               "(in [0, 1], without overlaps), generated charts for the rest",
       .uses = all(kBakes, "generate")},
      field<B>(&B::lightmap_uv));
  add({.name = "seams",
       .kind = K::kChoice,
       .choices = {"stitch", "off"},
       .help = "stitch: texels on both sides of a seam on a smooth surface agree (least squares "
               "over the seam edges, the asset output's lightmap); off: the solution as it is",
       .uses = all(kBakes, "stitch")},
      field<B>(&B::seams));
  add({.name = "preview",
       .kind = K::kFlag,
       .help = "first a quick bake at a quarter of the texel density (a sixteenth of the "
               "texels) into DIR/preview, placed as soon as it is done, then the full bake",
       .uses = all(kBakes, "off")},
      field<B>(&B::preview));
  add({.name = "solver",
       .kind = K::kChoice,
       .choices = {"jacobi", "gauss-seidel"},
       .help = "jacobi (eq. 4 of the paper) or gauss-seidel",
       .uses = all({"matrix"}, "gauss-seidel")},
      field<B>(&B::solver));
  add({.name = "texel-density",
       .kind = K::kReal,
       .range = range(0, 1e9, /*open_lo=*/true),
       .unit = "texels/m",
       .help = "lightmap texels per metre (the lightmap is then the smallest power of two that "
               "holds every chart)",
       .uses = all(kBakes)},
      field<B>(&B::texel_density));
  add({.name = "lightmap-size",
       .kind = K::kInt,
       .range = range(8, 16384),
       .unit = "texels",
       .help = "without --texel-density: an N x N lightmap at the largest density that fits",
       .uses = all(kBakes)},
      field<B>(&B::lightmap_size));
  add({.name = "texel-samples",
       .kind = K::kInt,
       .range = range(1, 1 << 20),
       .help = "the most samples a texel takes (each takes at least 64, or this if fewer, and "
               "stops once its error is within --tolerance)",
       .uses = all({"pathtrace"}, "4096")},
      field<B>(&B::texel_samples));
  addSolveOptions(b);
  addReceiverOptions(b);
  addCheckpointOptions(b, "DIR/SCENE.checkpoint");
  add({.name = "seed",
       .kind = K::kUnsigned,
       .help = "random seed",
       .uses = all({"stochastic", "pathtrace"}, "0")},
      field<B>(&B::seed));
  return b;
}

std::vector<Bound<CommonOptions>> commonBindings() {
  using C = CommonOptions;
  std::vector<Bound<C>> b;
  b.push_back({{.name = "threads",
                .kind = K::kInt,
                .range = range(0, 1024),
                .help = "worker threads (0 = all cores)"},
               field<C>(&C::threads)});
  b.push_back({{.name = "quiet",
                .kind = K::kFlag,
                .help = "no progress or information, only warnings and errors"},
               field<C>(&C::quiet)});
  b.push_back({{.name = "dry-run",
                .kind = K::kFlag,
                .help = "check options, inputs, output paths and memory, then stop before the "
                        "work (nothing is written)"},
               field<C>(&C::dry_run)});
  return b;
}

template <typename Options>
const std::vector<Bound<Options>>& bindings();
template <>
const std::vector<Bound<RenderOptions>>& bindings() {
  static const std::vector<Bound<RenderOptions>> b = renderBindings();
  return b;
}
template <>
const std::vector<Bound<BakeOptions>>& bindings() {
  static const std::vector<Bound<BakeOptions>> b = bakeBindings();
  return b;
}
template <>
const std::vector<Bound<CommonOptions>>& bindings() {
  static const std::vector<Bound<CommonOptions>> b = commonBindings();
  return b;
}

template <typename Options>
const std::vector<OptionSpec>& specsOf() {
  static const std::vector<OptionSpec> specs = [] {
    std::vector<OptionSpec> s;
    for (const Bound<Options>& b : bindings<Options>()) s.push_back(b.spec);
    return s;
  }();
  return specs;
}

template <typename Options>
void setOption(Options& options, const OptionSpec& spec, const OptionValue& value) {
  for (const Bound<Options>& b : bindings<Options>()) {
    if (b.spec.name == spec.name) {
      b.set(options, value);
      return;
    }
  }
}

}  // namespace

const std::vector<MethodInfo>& methodInfos() {
  static const std::vector<MethodInfo> methods = {
      {"pathtrace",
       "the unbiased reference path tracer (bake: every lightmap texel path-traced, the "
       "reference for the radiosity bakes)",
       "Kajiya 1986; Owen-scrambled Sobol", true, true, /*bake_over_ranks=*/false},
      {"whitted",
       "Whitted ray tracing: mirrors, glass and direct light by shadow rays; no diffuse "
       "interreflection (photons and pathtrace add it), so rooms lit indirectly come out darker",
       "Carr et al. 2002, the Ray Engine's applications", false, true},
      {"photons", "photon mapping with caustics and final gather", "Jensen 1996; Carr et al. 2002",
       false, true},
      {"matrix", "matrix radiosity: form factors once, Jacobi or Gauss-Seidel",
       "Carr, Hall, Hart 2003, sec. 3", true, true},
      {"progressive", "progressive refinement radiosity in a lightmap atlas", "Wallner", true,
       true},
      {"stochastic",
       "stochastic radiosity by ray-bundle shooting, after deterministic first shots of the "
       "strongest light; --time-limit or more --iterations for less noise",
       "Barsi and Jakab", true},
      {"sss", "subsurface scattering: the dipole through hierarchical links",
       "Carr, Hall, Hart 2003, sec. 4", false},
      {"lpv", "subsurface light propagation volumes", "Borlum et al. 2011", false},
  };
  return methods;
}

const MethodInfo* findMethod(const std::string& name) {
  for (const MethodInfo& m : methodInfos()) {
    if (m.name == name) return &m;
  }
  return nullptr;
}

Status checkDistributedMethod(const Communicator& comm, const std::string& command,
                              const std::string& method) {
  if (!comm.distributed()) return {};
  const auto runs = [&](const MethodInfo& m) {
    return m.over_ranks && (command != "bake" || (m.bakes && m.bake_over_ranks));
  };
  const MethodInfo* info = findMethod(method);
  if (info && runs(*info)) return {};
  std::vector<std::string> names;
  for (const MethodInfo& m : methodInfos()) {
    if (runs(m)) names.push_back(m.name);
  }
  const std::string list =
      names.size() > 1
          ? fmt::format("{} and {}", fmt::join(names.begin(), names.end() - 1, ", "), names.back())
          : names.front();
  return inputError("", "--method",
                    fmt::format("{} {} runs on one process; over {} ranks {} runs {} "
                                "(docs/scaling.md)",
                                command, method, comm.size(), command, list));
}

std::string methodNames(bool bake) {
  std::vector<std::string> names;
  for (const MethodInfo& m : methodInfos()) {
    if (!bake || m.bakes) names.push_back(m.name);
  }
  return fmt::format("{}", fmt::join(names, ", "));
}

const std::vector<OptionSpec>& renderOptionSpecs() {
  return specsOf<RenderOptions>();
}
const std::vector<OptionSpec>& bakeOptionSpecs() {
  return specsOf<BakeOptions>();
}
const std::vector<OptionSpec>& commonOptionSpecs() {
  return specsOf<CommonOptions>();
}

void setRenderOption(RenderOptions& options, const OptionSpec& spec, const OptionValue& value) {
  setOption(options, spec, value);
}
void setBakeOption(BakeOptions& options, const OptionSpec& spec, const OptionValue& value) {
  setOption(options, spec, value);
}
void setCommonOption(CommonOptions& options, const OptionSpec& spec, const OptionValue& value) {
  setOption(options, spec, value);
}

Status checkOptionsTaken(const std::vector<OptionSpec>& specs, const std::string& method,
                         const std::vector<std::string>& given, const std::string& file,
                         const std::string& prefix) {
  for (const std::string& name : given) {
    const OptionSpec* spec = findOption(specs, name);
    if (!spec || spec->takenBy(method)) continue;
    std::vector<std::string> owners;
    for (const OptionUse& u : spec->uses) owners.push_back(u.method);
    std::string list = owners.back();
    if (owners.size() > 1) {
      list = fmt::format("{} and {}", fmt::join(owners.begin(), owners.end() - 1, ", "),
                         owners.back());
    }
    return inputError(file, prefix + name,
                      fmt::format("applies to --method {} only, not {}", list, method));
  }
  return {};
}

namespace {

// applySceneSettings for either command: every method's settings checked against render's
// descriptions (the settings' vocabulary); the running method's applied through `specs`, the
// command's own (bake takes fewer), under the caller's.
template <typename Options>
Expected<std::vector<std::string>> applySettings(
    Options& options, const std::vector<OptionSpec>& specs,
    void (*set_option)(Options&, const OptionSpec&, const OptionValue&),
    const nlohmann::json& settings, const std::string& file,
    const std::vector<std::string>& given) {
  std::vector<std::string> set;
  if (settings.is_null()) return set;
  if (!settings.is_object()) return inputError(file, "settings", "must be an object");
  for (const auto& [method, values] : settings.items()) {
    const std::string where = "settings." + method;
    if (!findMethod(method)) {
      return inputError(file, where, fmt::format("unknown method (methods: {})", methodNames()));
    }
    if (!values.is_object()) return inputError(file, where, "must be an object");
    for (const auto& [key, value] : values.items()) {
      const OptionSpec* spec = findOption(renderOptionSpecs(), key);
      // Settings describe how a method runs; where its results go stays with the caller.
      if (!spec || spec->uses.empty() || spec->kind == OptionKind::kText ||
          key.find('-') != std::string::npos) {
        return inputError(file, where + "." + key,
                          "unknown setting (the options of docs/cli.md, written with '_')");
      }
      if (!spec->takenBy(method)) {
        return inputError(
            file, where + "." + key,
            fmt::format("is not a setting of {} (it is one of {})", method, spec->owners()));
      }
      Expected<OptionValue> v = optionFromJson(*spec, value, method, file, where + "." + key);
      if (!v) return v.error();
      // Every method's settings are checked; the running method's apply, under the caller's.
      if (method != options.method) continue;
      if (std::find(given.begin(), given.end(), spec->name) != given.end()) continue;
      const OptionSpec* own = findOption(specs, spec->name);
      if (!own || !own->takenBy(method)) continue;  // a render setting this command lacks
      Expected<OptionValue> mine = optionFromJson(*own, value, method, file, where + "." + key);
      if (!mine) return mine.error();
      set_option(options, *own, *mine);
      set.push_back(spec->name);
    }
  }
  return set;
}

}  // namespace

Expected<std::vector<std::string>> applySceneSettings(RenderOptions& options,
                                                      const nlohmann::json& settings,
                                                      const std::string& file,
                                                      const std::vector<std::string>& given) {
  return applySettings(options, renderOptionSpecs(), &setRenderOption, settings, file, given);
}

Expected<std::vector<std::string>> applySceneSettings(BakeOptions& options,
                                                      const nlohmann::json& settings,
                                                      const std::string& file,
                                                      const std::vector<std::string>& given) {
  return applySettings(options, bakeOptionSpecs(), &setBakeOption, settings, file, given);
}

std::string optionReferenceMarkdown() {
  std::string out;
  const auto table = [&](const char* command, const std::vector<OptionSpec>& specs, bool bake) {
    out += fmt::format(
        "### `{}`\n\n| option | methods: default | range | meaning |\n"
        "|---|---|---|---|\n",
        command);
    for (const OptionSpec& s : specs) {
      if (s.positional) continue;
      const size_t n = bake ? findOption(specs, "method")->choices.size() : methodInfos().size();
      std::string uses = s.usesText(n);
      if (s.uses.size() == n && uses.find(':') == std::string::npos) {
        uses = uses.empty() ? "all" : "all: " + uses;
      }
      // A method whose range is narrower than the option's says so.
      for (const OptionUse& u : s.uses) {
        if (u.range && s.range && u.range->describe() != s.range->describe()) {
          uses += fmt::format("; {} in {}", u.method, u.range->describe());
        }
      }
      if (s.uses.empty()) uses = "all";
      std::string values;
      if (s.kind == OptionKind::kChoice) {
        values = fmt::format("{}", fmt::join(s.choices, ", "));
      } else if (s.range) {
        values = s.range->describe();
        if (s.kind == OptionKind::kRealList) values = fmt::format("{} x {}", s.count, values);
      } else if (s.kind == OptionKind::kFlag) {
        values = "flag";
      } else if (s.kind == OptionKind::kUnsigned) {
        values = "[0, 2^64)";
      }
      if (!s.unit.empty()) values += " " + s.unit;
      const std::string name = s.short_name.empty() ? "`--" + s.name + "`"
                                                    : "`" + s.short_name + "`, `--" + s.name + "`";
      out += fmt::format("| {} | {} | {} | {} |\n", name, uses, values, s.help);
    }
    out += "\n";
  };
  table("penumbra render", renderOptionSpecs(), false);
  table("penumbra bake", bakeOptionSpecs(), true);
  table("every command that does work", commonOptionSpecs(), false);
  return out;
}

}  // namespace penumbra
