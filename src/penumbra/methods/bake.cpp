// `penumbra bake SCENE --method matrix|progressive -o DIR`: solves radiosity and writes the
// solution as files other tools read: a glTF mesh with per-corner radiance, and a lightmap atlas
// as EXR (exact, linear) and PNG (tone mapped, referenced by the glTF on the second UV set).
// Both methods write the scene's triangles and the chart atlas's lightmap (its occupied texels
// are the elements), border texels filled for bilinear lookups (Wallner sec. 3.1):
//  - matrix (Carr, Hall, Hart 2003, sec. 3): the clusters' solution interpolated to the texels;
//  - progressive (Wallner sec. 2-3): the solver's own texels.
// Conventions: docs/algorithms.md, "Baked output".
//
// All outputs are staged in a hidden directory inside DIR and renamed into place only once every
// file is complete, so a failed run leaves no output (and removes DIR if it created it).
#include "penumbra/cluster/communicator.h"
#include "penumbra/core/file_util.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/timer.h"
#include "penumbra/io/gltf_writer.h"
#include "penumbra/io/image_io.h"
#include "penumbra/io/scene_io.h"
#include "penumbra/methods/bake_output.h"
#include "penumbra/methods/matrix_build.h"
#include "penumbra/methods/progressive_run.h"
#include "penumbra/methods/registry.h"
#include "penumbra/methods/render.h"
#include "penumbra/methods/run_context.h"
#include "penumbra/methods/scene_inputs.h"
#include "penumbra/methods/stats_file.h"
#include "penumbra/methods/stochastic_run.h"
#include "penumbra/radiosity/lightmap_seams.h"
#include "penumbra/radiosity/matrix_radiosity.h"
#include "penumbra/radiosity/texel_path_trace.h"
#include "penumbra/render/lightmap_mesh.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <mutex>
#include <optional>

namespace penumbra {

namespace {

namespace fs = std::filesystem;

fs::path normalDirectory(const std::string& dir) {
  fs::path p = fs::path(dir).lexically_normal();
  if (p.filename().empty() && p.has_parent_path()) p = p.parent_path();  // "out/" -> "out"
  return p.empty() ? fs::path(".") : p;
}

// The directories `dir` needs created, outermost first (empty when it exists); an input error
// when it exists as something else or cannot be created or written.
Expected<std::vector<fs::path>> checkOutputDirectory(const std::string& dir) {
  std::error_code ec;
  fs::path p = normalDirectory(dir);
  std::vector<fs::path> missing;
  while (!fs::exists(p, ec)) {
    missing.insert(missing.begin(), p);
    if (!p.has_parent_path() || p.parent_path() == p) {
      p = ".";
      break;
    }
    p = p.parent_path();
  }
  if (!fs::is_directory(p, ec)) {
    return inputError(dir, "",
                      missing.empty() ? std::string("exists and is not a directory")
                                      : fmt::format("cannot create the output directory: '{}' is "
                                                    "not a directory",
                                                    p.string()));
  }
  if (::access(p.c_str(), W_OK | X_OK) != 0) {
    return inputError(
        dir, "",
        missing.empty()
            ? std::string("the output directory is not writable")
            : fmt::format("cannot create the output directory: '{}' is not writable", p.string()));
  }
  return missing;
}

// COLOR_0 = min(1, scale * radiance): 1 at the 99th percentile of the brightest channel of the
// non-emissive elements' radiance (emitters, a few hot spots and the light's neighbourhood clip).
float colorScale(std::span<const glm::vec3> radiance, std::span<const uint8_t> emissive) {
  std::vector<float> peaks;
  for (int pass = 0; pass < 2 && peaks.empty(); ++pass) {
    for (size_t e = 0; e < radiance.size(); ++e) {
      if (pass == 0 && emissive[e]) continue;
      const glm::vec3 l = radiance[e];
      const float peak = std::max({l.x, l.y, l.z});
      if (peak > 0.0f && std::isfinite(peak)) peaks.push_back(peak);
    }
  }
  if (peaks.empty()) return 1.0f;
  const size_t k = std::min(peaks.size() - 1, size_t(0.99 * double(peaks.size())));
  std::nth_element(peaks.begin(), peaks.begin() + std::ptrdiff_t(k), peaks.end());
  return 1.0f / peaks[k];
}

// What a solver hands to the writer.
struct BakeProduct {
  BakedMesh mesh;
  Image lightmap;        // outgoing radiance B / pi per texel
  Image irradiance;      // irradiance E per texel (the asset output's lightmap), seams stitched
  nlohmann::json seams;  // what the stitching did (radiosity/lightmap_seams.h)
  size_t anchored = 0;   // texels whose point moved to their side (radiosity/texel_footprint.h)
  std::vector<SurfaceFace> faces;  // the atlas's faces and their corners' UVs
  std::vector<glm::vec2> uvs;
  int atlas_width = 0, atlas_height = 0;
  double texel_density = 0.0;
  size_t triangles = 0;
  float color_scale = 1.0f;
  nlohmann::json extras;  // method-specific asset.extras.penumbra entries
  nlohmann::json stats;   // method-specific --stats entries
  bool interrupted = false;
  bool dry_run = false;     // --dry-run: planned and checked, nothing solved
  bool other_rank = false;  // a rank > 0 of a distributed run: solved, rank 0 writes
};

// The asset output's lightmap: irradiance from the solved radiance, its seams stitched.
void stitchedIrradiance(const RadiositySurface& surface, bool stitch, BakeProduct& out) {
  out.irradiance = irradianceImage(surface, out.lightmap);
  const SeamStats st =
      stitch ? stitchSeams(surface, out.irradiance) : measureSeams(surface, out.irradiance);
  out.anchored = surface.anchored;
  out.seams = {{"edges", st.edges},
               {"samples", st.samples},
               {"texels", st.texels},
               {"largest_jump_before", st.jump_before},
               {"largest_jump_after", st.jump_after},
               {"rms_jump_before", st.rms_before},
               {"rms_jump_after", st.rms_after}};
  if (st.edges > 0 && stitch) {
    spdlog::info(
        "seams: {} edges stitched, largest jump {:.3g} -> {:.3g} W/m^2 (RMS {:.3g} -> "
        "{:.3g})",
        st.edges, st.jump_before, st.jump_after, st.rms_before, st.rms_after);
  }
}

Expected<BakeProduct> solveMatrix(const BakeOptions& options, const CommonOptions& common,
                                  const Scene& scene, ReadyGate& gate) {
  Communicator& comm = currentCommunicator();
  MatrixRadiosityOptions mo;
  mo.elements = options.elements.value_or(kMatrixDefaultElements);
  mo.lightmap.texel_density = options.texel_density;
  mo.lightmap.asset_uvs = options.lightmap_uv == "asset";
  mo.lightmap.size = options.lightmap_size;
  if (options.ff_rays) mo.form_factors.rays = *options.ff_rays;
  mo.shading_normals = options.normals == "interpolated";
  PENUMBRA_TRY(checkMatrixRadiosity(scene, mo, comm.size()));
  PENUMBRA_TRY(gate.open());
  if (common.dry_run) {
    BakeProduct planned;
    planned.dry_run = true;
    return planned;
  }
  const Timer build_timer;
  Expected<MatrixRadiosity> built = buildMatrixWithProgress(scene, mo, common);
  if (!built) return built.error();
  MatrixRadiosity& mr = *built;
  const double build_seconds = build_timer.seconds();
  const size_t n = mr.size();
  spdlog::info(
      "{}: {} elements (clusters of {} lightmap texels), form factors in {:.2f} s ({} rays)",
      scene.source, n, mr.surface.elementCount(), mr.form_factor_stats.seconds,
      mr.form_factor_stats.rays);

  SolveOptions so;
  so.solver = options.solver == "jacobi" ? MatrixSolver::kJacobi : MatrixSolver::kGaussSeidel;
  so.max_iterations = iterationCap(options.iterations);
  so.tolerance = options.tolerance.value_or(1e-6);
  Progress progress("solving", uint64_t(so.max_iterations),
                    !common.quiet && comm.root() && Progress::stderrIsTerminal());
  const SolveStats solved = mr.solve(so, [&](int k, double) { progress.reach(uint64_t(k + 1)); });
  progress.finish();
  if (!solved.converged) {
    spdlog::warn("not converged: residual {:.3g} after {} iterations (tolerance {:.3g})",
                 solved.residual, solved.iterations, so.tolerance);
  }
  spdlog::info("{} iterations ({}), residual {:.3g}, {:.3f} s", solved.iterations,
               matrixSolverName(so.solver), solved.residual, solved.seconds);

  // The solution interpolated to the lightmap's elements, the same layout as every method's.
  BakeProduct out;
  const std::vector<glm::dvec3> b = mr.elementRadiosity();
  if (!comm.root()) {
    out.other_rank = true;  // rank 0 writes the outputs
    return out;
  }
  out.lightmap = mr.surface.radianceImage(b);
  stitchedIrradiance(mr.surface, options.seams == "stitch", out);
  out.faces = mr.surface.atlas.faces;
  out.uvs = mr.surface.atlas.uvs;
  out.mesh = buildLightmapMesh(scene, mr.surface.atlas, out.lightmap);
  std::vector<glm::vec3> radiance(b.size());
  std::vector<uint8_t> emissive(b.size());
  for (size_t e = 0; e < b.size(); ++e) {
    radiance[e] = glm::vec3(b[e] / 3.14159265358979323846);
    emissive[e] = mr.surface.emission[e] != glm::dvec3(0.0) ? 1 : 0;
  }
  out.color_scale = colorScale(radiance, emissive);
  out.atlas_width = mr.surface.atlas.width;
  out.atlas_height = mr.surface.atlas.height;
  out.texel_density = mr.surface.atlas.texel_density;
  out.triangles = mr.surface.flat.triangles.size();
  out.extras = {{"elements", n},
                {"lightmap_elements", mr.surface.elementCount()},
                {"iterations", solved.iterations},
                {"residual", solved.residual}};
  out.stats = {{"solver", matrixSolverName(so.solver)},
               {"elements", n},
               {"lightmap_elements", mr.surface.elementCount()},
               {"form_factor_seconds", mr.form_factor_stats.seconds},
               {"form_factor_rays", mr.form_factor_stats.rays},
               {"rays", mr.form_factor_stats.rays},
               {"build_seconds", build_seconds},
               {"solve_seconds", solved.seconds},
               {"iterations", solved.iterations},
               {"residual", solved.residual},
               {"converged", solved.converged},
               {"tolerance", so.tolerance},
               {"history", solved.history}};
  if (comm.distributed()) {
    out.stats["ranks"] = comm.size();
    out.stats["mpi"] = comm.describe();
    out.stats["matrix_bytes_per_rank"] = mr.system->matrixBytes();
  }
  return out;
}

// A method whose lightmap is the solution itself (progressive and stochastic radiosity): the
// baked mesh and the colour scale from the lightmap and the radiosity per element.
void fillFromLightmap(const Scene& scene, const RadiositySurface& surface, const Image& lightmap,
                      const std::vector<glm::dvec3>& radiosity, bool stitch, BakeProduct& out) {
  out.lightmap = lightmap;
  stitchedIrradiance(surface, stitch, out);
  out.faces = surface.atlas.faces;
  out.uvs = surface.atlas.uvs;
  out.mesh = buildLightmapMesh(scene, surface.atlas, out.lightmap);
  std::vector<glm::vec3> radiance(radiosity.size());
  std::vector<uint8_t> emissive(radiosity.size());
  for (size_t e = 0; e < radiosity.size(); ++e) {
    radiance[e] = glm::vec3(radiosity[e] / 3.14159265358979323846);
    emissive[e] = surface.emission[e] != glm::dvec3(0.0) ? 1 : 0;
  }
  out.color_scale = colorScale(radiance, emissive);
  out.atlas_width = surface.atlas.width;
  out.atlas_height = surface.atlas.height;
  out.texel_density = surface.atlas.texel_density;
  out.triangles = surface.flat.triangles.size();
}

// Stochastic radiosity (Barsi and Jakab): the running average in the lightmap.
Expected<BakeProduct> solveStochastic(const CommonOptions& common, const Scene& scene,
                                      const StochasticRunOptions& so, bool stitch) {
  Expected<StochasticRun> run = runStochastic(scene, so, common);
  if (!run) return run.error();
  BakeProduct out;
  if (run->dry_run) {
    out.dry_run = true;
    return out;
  }
  const StochasticRadiosity& sr = *run->solver;
  out.interrupted = run->interrupted;
  fillFromLightmap(scene, sr.surface(), *run->lightmap, sr.radiosity(), stitch, out);
  out.extras = {{"elements", sr.elementCount()},
                {"iterations", run->stats.total_iterations},
                {"error_estimate", run->stats.error}};
  out.stats = stochasticStatsJson(*run);
  return out;
}

// Progressive radiosity (Wallner sec. 2-3): the lightmap is the solution itself, its occupied
// texels the elements; border texels are filled for bilinear lookups (sec. 3.1).
Expected<BakeProduct> solveProgressive(const CommonOptions& common, const Scene& scene,
                                       const ProgressiveRunOptions& ro, bool stitch,
                                       ReadyGate& gate) {
  Expected<ProgressiveRun> run = runProgressive(scene, ro, common, &gate);
  if (!run) return run.error();
  BakeProduct out;
  if (run->dry_run) {
    out.dry_run = true;
    return out;
  }
  const ProgressiveRadiosity& pr = *run->solver;
  out.interrupted = run->interrupted;
  if (!currentCommunicator().root()) {
    out.other_rank = true;  // rank 0 writes the outputs
    return out;
  }
  fillFromLightmap(scene, pr.surface(), *run->lightmap, pr.state().radiosity, stitch, out);
  out.extras = {{"elements", pr.elementCount()},
                {"iterations", run->stats.total_iterations},
                {"unshot_fraction", run->stats.unshot_fraction}};
  out.stats = progressiveStatsJson(*run, ro.tolerance);
  return out;
}

// The path-traced lightmap (radiosity/texel_path_trace.h): the same atlas as the radiosity
// methods' for the same --texel-density, every texel by unbiased path tracing.
Expected<BakeProduct> solvePathTrace(const BakeOptions& options, const CommonOptions& common,
                                     const Scene& scene, ReadyGate& gate) {
  // One process (registry: bake_over_ranks), on the CPU.
  if (options.device == "gpu") {
    return inputError("", "--device", "bake --method pathtrace runs on the cpu");
  }
  LightmapResolution resolution;
  resolution.texel_density = options.texel_density;
  resolution.size = options.lightmap_size;
  resolution.asset_uvs = options.lightmap_uv == "asset";
  resolution.elements = options.elements.value_or(kDefaultLightmapElements);
  Expected<ChartAtlasOptions> atlas = lightmapAtlasOptions(scene, resolution);
  if (!atlas) return atlas.error();
  PENUMBRA_TRY(checkLightmapPlan(scene, resolution, std::nullopt, "the path-traced bake", 400));
  TexelPathTraceOptions to;
  to.max_samples = options.texel_samples.value_or(to.max_samples);
  to.min_samples = std::min(to.min_samples, to.max_samples);
  to.target_error = options.tolerance.value_or(to.target_error);
  to.seed = options.seed.value_or(0);
  const bool shading_normals = true;
  Expected<RadiositySurface> surface = RadiositySurface::build(scene, *atlas, shading_normals);
  if (!surface) return surface.error();
  PENUMBRA_TRY(gate.open());
  if (common.dry_run) {
    BakeProduct planned;
    planned.dry_run = true;
    return planned;
  }
  spdlog::info(
      "{}: {} lightmap texels in a {}x{} atlas ({:.1f} texels/m), path-traced until "
      "each is within {:g} (at most {} samples)",
      scene.source, surface->elementCount(), surface->atlas.width, surface->atlas.height,
      surface->atlas.texel_density, to.target_error, to.max_samples);
  const InterruptScope interrupt;
  Progress progress("texels", uint64_t(surface->elementCount()),
                    !common.quiet && Progress::stderrIsTerminal());
  std::mutex progress_mutex;
  TexelPathTraceStats st;
  Expected<std::vector<glm::dvec3>> b =
      pathTraceTexels(scene, *surface, to, &st, [&](size_t done, size_t) {
        const std::lock_guard<std::mutex> lock(progress_mutex);
        progress.reach(uint64_t(done));
      });
  if (!b) return b.error();
  progress.finish();
  spdlog::info(
      "{:.1f} samples per texel on average, {} texels at the cap, worst relative error "
      "{:.3g}, {:.2f} s",
      st.mean_samples, st.texels_at_cap, st.worst_relative_error, st.seconds);
  BakeProduct out;
  fillFromLightmap(scene, *surface, surface->radianceImage(*b), *b, options.seams == "stitch", out);
  out.extras = {{"elements", surface->elementCount()},
                {"samples_per_texel", st.mean_samples},
                {"target_error", to.target_error}};
  out.stats = {{"elements", surface->elementCount()},
               {"samples", st.samples},
               {"samples_per_texel", st.mean_samples},
               {"texels_at_cap", st.texels_at_cap},
               {"worst_relative_error", st.worst_relative_error},
               {"target_error", to.target_error},
               {"max_samples", to.max_samples},
               {"rays", st.rays},
               {"solve_seconds", st.seconds}};
  return out;
}

// The outputs: temporaries in DIR, placed together by the transaction's commit, in the order
// written: the glTF last, so that what it references is in place before it is.
Status writeBakeOutputs(const BakeOptions& options, const Scene& scene, const BakeProduct& product,
                        const fs::path& out_dir, const std::string& stem, double seconds) {
  const bool asset = options.gltf == "asset";
  const std::string gltf_name = stem + ".gltf", bin_name = stem + ".bin",
                    exr_name = stem + "_lightmap.exr", png_name = stem + "_lightmap.png";
  // The lightmap the EXR holds: irradiance for the asset output, radiance for the emissive one.
  emitImage(asset ? product.irradiance : product.lightmap);
  // The scene by its file name only: the bake may be published (--web), and the path as typed
  // names the user's folders.
  nlohmann::json extras = {{"method", options.method},
                           {"scene", fs::path(scene.source).filename().string()},
                           {"units", {{"length", "m"}}}};
  extras.update(product.extras);
  if (asset) {
    extras["lights_baked"] = true;
    extras["lightmap"] = {
        {"uv", options.lightmap_uv},
        {"width", product.atlas_width},
        {"height", product.atlas_height},
        {"texel_density", product.texel_density},
        {"exr", exr_name},
        {"png", png_name},
        {"content",
         "irradiance E, W m^-2, linear Rec. 709 RGB; outgoing radiance is E * "
         "baseColor / pi + emission"},
        {"png_encoding", "RGBM, linear: E = scale * rgb * a (materials' PENUMBRA_lightmap.scale)"}};
  } else {
    extras["units"]["radiance"] = "W m^-2 sr^-1";
    extras["radiance_attribute"] = "_RADIANCE";
    extras["color_0"] = "min(1, color_0_scale * _RADIANCE) per channel, linear";
    extras["lightmap"] = {
        {"texcoord", 1},
        {"width", product.atlas_width},
        {"height", product.atlas_height},
        {"texel_density", product.texel_density},
        {"exr", exr_name},
        {"png", png_name},
        {"exr_content", "outgoing radiance B/pi, W m^-2 sr^-1, linear Rec. 709 RGB"},
        {"png_content",
         "the EXR tone mapped (Reinhard 2002, automatic key), sRGB encoded; for display"}};
  }
  if (wantsStats(options.stats)) {
    nlohmann::json j = {{"method", options.method},
                        {"device", "cpu"},
                        {"scene", scene.source},
                        {"seconds", seconds},
                        {"threads", threadCount()},
                        {"gltf", options.gltf},
                        {"atlas",
                         {{"width", product.atlas_width},
                          {"height", product.atlas_height},
                          {"texel_density", product.texel_density},
                          {"triangles", product.triangles}}},
                        {"color_0_scale", product.color_scale},
                        {"outputs",
                         {(out_dir / gltf_name).string(), (out_dir / bin_name).string(),
                          (out_dir / exr_name).string(), (out_dir / png_name).string()}}};
    j.update(product.stats);
    if (asset) j["seams"] = product.seams;
    j["anchored_texels"] = product.anchored;
    PENUMBRA_TRY(emitStats(options.stats, j));
  }
  if (asset) {
    const std::vector<TriangleLightmapUvs> uvs =
        triangleLightmapUvs(scene, product.faces, product.uvs, product.irradiance);
    AssetBakeFiles files{(out_dir / gltf_name).string(), (out_dir / bin_name).string(),
                         (out_dir / exr_name).string(), (out_dir / png_name).string(),
                         AssetPolicy{options.allow_outside_files}};
    PENUMBRA_TRY(writeAssetBake(scene, product.irradiance, uvs, extras, files));
  } else {
    PENUMBRA_TRY(writeMethodImage((out_dir / exr_name).string(), product.lightmap));
    PENUMBRA_TRY(
        writeMethodImage((out_dir / png_name).string(), product.lightmap, ToneMapSettings{}));
    BakedGltfInfo info;
    info.name = stem;
    info.bin_uri = bin_name;
    info.lightmap_uri = png_name;
    info.color_0_scale = product.color_scale;
    info.extras = extras;
    PENUMBRA_TRY(
        writeBakedGltf((out_dir / gltf_name).string(), product.mesh, scene.materials, info));
  }
  if (!options.web.empty()) {
    std::vector<std::string> files = {(out_dir / gltf_name).string(), (out_dir / bin_name).string(),
                                      (out_dir / png_name).string(), (out_dir / exr_name).string()};
    PENUMBRA_TRY(writeWebViewer(normalDirectory(options.web).string(), files));
  }

  return {};
}

Status bake(const BakeOptions& options, const CommonOptions& common, bool* interrupted);

// --lightmap-uv asset: which meshes keep their own layout.
void sayWhichLightmapUvs(const Scene& scene) {
  const std::optional<AssetLightmapUvs> asset = assetLightmapUvs(scene);
  if (!asset) {
    spdlog::warn(
        "{}: --lightmap-uv asset: no mesh has a second UV set (TEXCOORD_1); every mesh "
        "gets generated charts",
        scene.source);
    return;
  }
  std::string names;
  for (size_t b = 0; b < asset->block_name.size() && b < 8; ++b) {
    names += (b ? ", " : "") + asset->block_name[b];
  }
  if (asset->block_name.size() > 8) names += ", ...";
  spdlog::info(
      "{}: lightmap UVs: TEXCOORD_1 of {} of {} meshes ({}); generated charts for the "
      "rest",
      scene.source, asset->block_name.size(), scene.meshes.size(), names);
}

// --preview: the same bake at a quarter of the texel density into DIR/preview (its own web page
// in WEB/preview), placed before the full bake starts.
Status bakePreview(const BakeOptions& options, const CommonOptions& common,
                   const fs::path& out_dir) {
  if (currentCommunicator().distributed()) {
    return inputError("", "--preview", "a preview is baked in one process, not over ranks");
  }
  const Scene& scene = runScene();
  BakeOptions p = options;
  p.preview = false;
  p.output = (out_dir / "preview").string();
  if (!options.web.empty()) p.web = (normalDirectory(options.web) / "preview").string();
  p.stats.clear();
  p.resume.clear();
  p.checkpoint.clear();
  p.keep_checkpoint = false;
  if (options.texel_density) {
    p.texel_density = *options.texel_density / 4.0;
  } else if (options.lightmap_size) {
    p.lightmap_size = std::max(8, *options.lightmap_size / 4);
  } else {
    // The density the full bake's texel count gives (matrix: four texels per cluster).
    const uint32_t elements = options.method == "matrix"
                                  ? std::max(kDefaultLightmapElements,
                                             4 * options.elements.value_or(kMatrixDefaultElements))
                                  : options.elements.value_or(kDefaultLightmapElements);
    p.texel_density = texelDensityFor(scene, elements) / 4.0;
  }
  if (options.method == "matrix") {
    p.elements = std::max(1u, options.elements.value_or(kMatrixDefaultElements) / 16);
  } else {
    p.elements.reset();
  }
  const Timer timer;
  bool interrupted = false;
  PENUMBRA_TRY(bake(p, common, &interrupted));
  if (interrupted || common.dry_run) return {};
  PENUMBRA_TRY(OutputTransaction::current()->placeSoFar());
  spdlog::info("preview: {} in {:.2f} s",
               (fs::path(p.output) / (sceneStem(options.scene) + ".gltf")).string(),
               timer.seconds());
  return {};
}

Status bake(const BakeOptions& options, const CommonOptions& common, bool* interrupted) {
  // Over several processes (mpirun): every rank loads and checks, then they agree to start.
  Communicator& comm = currentCommunicator();
  ReadyGate gate(comm);
  PENUMBRA_TRY(checkDistributedMethod(comm, "bake", options.method));
  // Everything is checked before any work or output.
  const bool stochastic = options.method == "stochastic";
  const bool progressive = options.method == "progressive" || stochastic;
  // Which options apply, and their ranges: methods/registry.cpp.
  Expected<std::vector<fs::path>> missing = checkOutputDirectory(options.output);
  if (!missing) return missing.error();
  const fs::path out_dir = normalDirectory(options.output);
  const std::string stem = sceneStem(options.scene);
  // The directory is made now (and removed again if the bake fails or is stopped before its
  // outputs are placed), so that every output path, the checkpoint's included, is checked as it
  // will be written.
  OutputTransaction& transaction = *OutputTransaction::current();
  PENUMBRA_TRY(transaction.createDirectories(out_dir.string()));
  ProgressiveRunOptions ro;
  StochasticRunOptions so;
  if (stochastic) {
    so = stochasticRunOptions(options);
    if (so.checkpoint.empty()) so.checkpoint = (out_dir / (stem + ".checkpoint")).string();
    PENUMBRA_TRY(checkStochasticRunOptions(so));
  } else if (progressive) {
    ro = progressiveRunOptions(options);
    if (ro.checkpoint.empty()) ro.checkpoint = (out_dir / (stem + ".checkpoint")).string();
    PENUMBRA_TRY(checkProgressiveRunOptions(ro));
  }
  const std::string gltf_name = stem + ".gltf", bin_name = stem + ".bin",
                    exr_name = stem + "_lightmap.exr", png_name = stem + "_lightmap.png";
  for (const std::string& name : {gltf_name, bin_name, exr_name, png_name}) {
    PENUMBRA_TRY(checkOutputPath((out_dir / name).string()));
  }
  if (!options.stats.empty()) PENUMBRA_TRY(checkOutputPath(options.stats));
  if (!options.web.empty()) {
    Expected<std::string> viewer = webViewerDirectory();
    if (!viewer) return viewer.error();
    Expected<std::vector<fs::path>> web_missing = checkOutputDirectory(options.web);
    if (!web_missing) return web_missing.error();
    // Made now, as the output directory is, and removed again if the bake does not complete.
    PENUMBRA_TRY(transaction.createDirectories(normalDirectory(options.web).string()));
    for (const char* name : {"index.html", "bake.json"}) {
      PENUMBRA_TRY(checkOutputPath((normalDirectory(options.web) / name).string()));
    }
  }

  const Scene* const scene = &runScene();
  // The preview says what there is to say about the scene; the full bake does not repeat it.
  if (options.preview) {
    PENUMBRA_TRY(bakePreview(options, common, out_dir));
  } else {
    if (options.lightmap_uv == "asset") sayWhichLightmapUvs(*scene);
    for (const std::string& w : scene->warnings) spdlog::warn("{}", w);
    for (const std::string& w : diffuseStandInWarnings(*scene, options.method)) {
      spdlog::warn("{}", w);
    }
    bool any_emitter = hasLightOtherThanSurfaces(*scene);
    for (const Material& m : scene->materials) any_emitter |= m.isEmissive() && !m.unlit;
    if (!any_emitter) return noLightError(*scene, options.method);
  }
  const Timer total_timer;
  const bool stitch = options.seams == "stitch";
  Expected<BakeProduct> product = stochastic    ? solveStochastic(common, *scene, so, stitch)
                                  : progressive ? solveProgressive(common, *scene, ro, stitch, gate)
                                  : options.method == "pathtrace"
                                      ? solvePathTrace(options, common, *scene, gate)
                                      : solveMatrix(options, common, *scene, gate);
  if (!product) return product.error();
  if (product->dry_run) return {};
  if (product->other_rank) {
    *interrupted = product->interrupted;
    return {};
  }
  if (product->interrupted) {
    *interrupted = true;
    // The checkpoint is part of what this run leaves, also if the outputs fail.
    transaction.keepCreatedDirectories();
  }
  const double seconds = total_timer.seconds();

  PENUMBRA_TRY(writeBakeOutputs(options, *scene, *product, out_dir, stem, seconds));
  spdlog::info("baked in {:.2f} s: {} ({}x{} lightmap, {:.0f} texels/m)", total_timer.seconds(),
               (out_dir / gltf_name).string(), product->atlas_width, product->atlas_height,
               product->texel_density);
  return {};
}

}  // namespace

Expected<RunResult> bakeScene(BakeOptions options, const CommonOptions& common,
                              const RunContext& context) {
  // The run sees the scene as its settings and the options make it (methods/scene_inputs.h).
  Expected<RunContext> run = prepareRun(options, context);
  if (!run) return run.error();
  return runInScope(*run, common, [&](bool* interrupted) -> Status {
    return bake(options, common, interrupted);
  });
}

}  // namespace penumbra
