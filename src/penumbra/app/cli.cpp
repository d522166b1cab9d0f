#include "penumbra/app/commands.h"
#include "penumbra/cluster/communicator.h"

#include "penumbra/core/file_util.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/core/log.h"
#include "penumbra/core/parallel.h"
#include "penumbra/methods/registry.h"

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <deque>
#include <functional>
#include <optional>

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
  silenceDistributedEndMessage();
  const Communicator& comm = currentCommunicator();
  if (comm.root()) {
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

// ---- Options from their descriptions (methods/registry.h) ----

// The help line: what the option does, its unit, and the methods that take it with their
// defaults (all `methods` of the command: the default alone).
std::string describedHelp(const OptionSpec& spec, size_t methods) {
  std::string help = spec.help;
  if (!spec.unit.empty()) help += ", " + spec.unit;
  if (spec.uses.empty()) return help;
  const std::string uses = spec.usesText(methods);
  if (spec.uses.size() == methods && uses.find(':') == std::string::npos) {
    return uses.empty() ? help : fmt::format("{} (default {})", help, uses);
  }
  return fmt::format("{} ({})", help, uses);
}

const char* typeName(OptionKind kind) {
  switch (kind) {
    case OptionKind::kInt:
      return "INT";
    case OptionKind::kUnsigned:
      return "UINT";
    case OptionKind::kReal:
      return "NUMBER";
    case OptionKind::kRealList:
      return "X,Y";
    default:
      return "TEXT";
  }
}

// CLI11 collects the words of every described option; the library's parser then checks each
// value for the chosen method, as it checks a scene file's settings (methods/option_spec.h).
class DescribedOptions {
 public:
  // Adds `specs` (those named in `only`, when given) to `cmd`, whose methods number `methods`.
  void add(CLI::App* cmd, const std::vector<OptionSpec>& specs, size_t methods,
           const std::vector<std::string>& only = {}) {
    for (const OptionSpec& spec : specs) {
      if (!only.empty() && std::find(only.begin(), only.end(), spec.name) == only.end()) continue;
      Entry& e = entries_.emplace_back();
      e.spec = &spec;
      if (spec.kind == OptionKind::kFlag) {
        e.option = cmd->add_flag("--" + spec.name, e.flag, describedHelp(spec, methods));
        continue;
      }
      const std::string names = spec.positional           ? spec.name
                                : spec.short_name.empty() ? "--" + spec.name
                                                          : spec.short_name + ",--" + spec.name;
      e.option = cmd->add_option(names, e.texts, describedHelp(spec, methods))->expected(1);
      e.option->type_name(spec.kind == OptionKind::kChoice
                              ? fmt::format("{{{}}}", fmt::join(spec.choices, ","))
                              : std::string(typeName(spec.kind)));
      e.option->multi_option_policy(spec.repeatable ? CLI::MultiOptionPolicy::TakeAll
                                                    : CLI::MultiOptionPolicy::TakeLast);
    }
  }

  std::optional<std::string> text(const std::string& name) const {
    for (const Entry& e : entries_) {
      if (e.spec->name == name && !e.texts.empty()) return e.texts.back();
    }
    return std::nullopt;
  }

  // Parses and checks every option given, for `method`, and hands it to `set`; `given` receives
  // the names of the options set.
  Status apply(const std::string& method,
               const std::function<void(const OptionSpec&, const OptionValue&)>& set,
               std::vector<std::string>* given) const {
    for (const Entry& e : entries_) {
      if (e.spec->kind == OptionKind::kFlag) {
        if (!e.flag) continue;
        set(*e.spec, OptionValue(true));
        given->push_back(e.spec->name);
        continue;
      }
      if (e.texts.empty()) continue;
      const std::string where = e.spec->positional ? e.spec->name : "--" + e.spec->name;
      for (const std::string& text : e.texts) {
        Expected<OptionValue> v = parseOption(*e.spec, text, method, "", where);
        if (!v) return v.error();
        set(*e.spec, *v);
      }
      given->push_back(e.spec->name);
    }
    return {};
  }

 private:
  struct Entry {
    const OptionSpec* spec = nullptr;
    CLI::Option* option = nullptr;
    std::vector<std::string> texts;
    bool flag = false;
  };
  std::deque<Entry> entries_;  // CLI11 keeps references into the entries
};

// A parsed command's options: the described ones, set and checked for the chosen method.
template <typename Options, typename Set>
Status applyDescribed(const DescribedOptions& described, const std::vector<OptionSpec>& specs,
                      Options& options, Set set, std::vector<std::string>* given) {
  // The method first: the other values are checked against its ranges.
  if (const std::optional<std::string> m = described.text("method")) {
    Expected<OptionValue> v = parseOption(*findOption(specs, "method"), *m, "", "", "--method");
    if (!v) return v.error();
    options.method = std::get<std::string>(*v);
  }
  PENUMBRA_TRY(described.apply(
      options.method, [&](const OptionSpec& s, const OptionValue& v) { set(options, s, v); },
      given));
  return checkOptionsTaken(specs, options.method, *given);
}

const std::vector<std::string> kCommonOnly = {"threads", "quiet"};

// Parsed commands: the described options of each and what they fill in.
struct CommandLine {
  CLI::App app{"Penumbra: diffuse and subsurface global illumination", "penumbra"};
  CommonOptions common;
  RenderOptions render;
  BakeOptions bake;
  TraceOptions trace;
  InfoOptions info;
  RaysOptions rays;
  DescribedOptions render_options, bake_options;
  std::deque<DescribedOptions> common_options;  // one per command
  CLI::App* render_cmd = nullptr;
  CLI::App* bake_cmd = nullptr;
  CLI::App* trace_cmd = nullptr;
  CLI::App* info_cmd = nullptr;
  CLI::App* rays_cmd = nullptr;

  DescribedOptions& addCommon(CLI::App* cmd, const std::vector<std::string>& only = {}) {
    DescribedOptions& d = common_options.emplace_back();
    d.add(cmd, commonOptionSpecs(), 0, only);
    return d;
  }
};

void addRenderCommand(CommandLine& c) {
  c.render_cmd = c.app.add_subcommand("render", "render a scene to an image");
  c.render_options.add(c.render_cmd, renderOptionSpecs(), methodInfos().size());
  c.render_cmd->footer(fmt::format(
      "Each option names the methods that take it and their defaults; docs/cli.md has them all. "
      "Methods: {}.",
      methodNames()));
  c.addCommon(c.render_cmd);
}

void addBakeCommand(CommandLine& c) {
  c.bake_cmd = c.app.add_subcommand(
      "bake", "solve radiosity and write a glTF with lightmaps (EXR, PNG) into a directory");
  c.bake_options.add(c.bake_cmd, bakeOptionSpecs(),
                     findOption(bakeOptionSpecs(), "method")->choices.size());
  c.bake_cmd->get_option("scene")->required();
  c.addCommon(c.bake_cmd);
}

void addTraceCommand(CommandLine& c) {
  TraceOptions& trace = c.trace;
  CLI::App* cmd = c.trace_cmd =
      c.app.add_subcommand("trace", "closest hits of a ray file against a mesh (the Ray Engine)");
  cmd->add_option("mesh", trace.mesh, "mesh file or built-in scene")->required();
  cmd->add_option("--rays", trace.rays, "rays: float32 ox oy oz tmin dx dy dz tmax")->required();
  cmd->add_option("-o,--output", trace.output, "hits: int32 triangle, float32 t u v")->required();
  cmd->add_option("--stats", trace.stats, "write statistics to this JSON file");
  cmd->add_flag("--occlusion", trace.occlusion,
                "shadow rays: write one byte per ray, 1 when anything lies within [tmin, tmax] "
                "(any hit), else 0");
  cmd->add_option("--device", trace.device,
                  "cpu, gpu, hybrid (CPU/GPU split of the Ray Engine paper) or auto")
      ->capture_default_str();
  cmd->add_option("--t-min", trace.t_min, "hybrid: fewest triangles in a GPU cell")
      ->check(CLI::Range(1u, 1u << 24))
      ->capture_default_str();
  cmd->add_option("--t-max", trace.t_max, "hybrid: most triangles in a GPU cell")
      ->check(CLI::Range(1u, 1u << 24))
      ->capture_default_str();
  cmd->add_option("--r-min", trace.r_min, "hybrid: rays a cell collects per GPU pass")
      ->check(CLI::Range(1u, 65536u))
      ->capture_default_str();
  cmd->add_option("--cache-rays", trace.cache_rays,
                  "hybrid: rays a cell's ray cache holds before it sends its most coherent "
                  "bucket (default 4 x --r-min)")
      ->check(CLI::Range(1u, 1u << 24));
  c.addCommon(cmd);
}

void addInfoCommand(CommandLine& c) {
  InfoOptions& info = c.info;
  CLI::App* cmd = c.info_cmd =
      c.app.add_subcommand("info", "what a scene holds: sizes, lights, warnings");
  cmd->add_option("scene", info.scene,
                  "built-in scene name or file; a luminaire's .ldt or .ies file shows its "
                  "photometry")
      ->capture_default_str();
  cmd->add_option("--plot", info.plot,
                  "luminaire: write its polar light distribution curve to this PNG");
  cmd->add_flag("--devices", info.devices,
                "list the OpenGL 4.5 contexts that can be made, with their limits");
  c.addCommon(cmd, kCommonOnly);
}

void addRaysCommand(CommandLine& c) {
  RaysOptions& rays = c.rays;
  CLI::App* cmd = c.rays_cmd = c.app.add_subcommand(
      "rays", "write a ray file for trace: a camera's primary rays or diffuse surface rays");
  cmd->add_option("scene", rays.scene, "built-in scene name or file")->required();
  cmd->add_option("-o,--output", rays.output, "ray file (float32 ox oy oz tmin dx dy dz tmax)")
      ->required();
  cmd->add_option("--kind", rays.kind,
                  "camera (one ray per pixel through the scene's camera) or diffuse (from random "
                  "surface points, cosine-distributed, either side)")
      ->capture_default_str();
  cmd->add_option("--width", rays.width, "camera: image width (default 512)")
      ->check(CLI::Range(1, 1 << 16));
  cmd->add_option("--height", rays.height, "camera: image height (default 512)")
      ->check(CLI::Range(1, 1 << 16));
  cmd->add_option("--count", rays.count, "diffuse: number of rays (default 1048576)")
      ->check(CLI::Range(uint64_t(1), uint64_t(1) << 34));
  cmd->add_option("--seed", rays.seed, "diffuse: random seed (default 0)")->check(kUnsigned);
  cmd->add_option("--tmin", rays.t_min,
                  "diffuse: distance the rays start at (default 1e-4 of the scene's diagonal)")
      ->check(finiteIn(0.0, 1e30));
  c.addCommon(cmd);
}

// The common options of the command that was parsed.
Status applyCommon(CommandLine& c) {
  std::vector<std::string> given;
  for (const DescribedOptions& d : c.common_options) {
    PENUMBRA_TRY(d.apply(
        "", [&](const OptionSpec& s, const OptionValue& v) { setCommonOption(c.common, s, v); },
        &given));
  }
  return {};
}

// Runs the command that was parsed.
int runParsed(CommandLine& c) {
  if (Status s = applyCommon(c); !s) return reportError(s.error());
  // Over several processes only rank 0 logs; the others print only what fails on them alone.
  const Communicator& comm = currentCommunicator();
  initLogging(c.common.quiet || !comm.root());
  if (!comm.root()) spdlog::set_level(spdlog::level::err);
  setThisProcessWritesOutputs(comm.root());
  // Signals are the process's: the CLI takes them.
  installInterruptHandlers();
  if (comm.distributed()) interruptSignalsEndDistributedRun(comm.rank(), comm.size());
  auto thread_limit = limitThreads(threadsPerRank(comm, c.common.threads));
  std::vector<std::string> given;
  if (c.render_cmd->parsed()) {
    Status s =
        applyDescribed(c.render_options, renderOptionSpecs(), c.render, setRenderOption, &given);
    if (!s) return reportError(s.error());
    return runRender(c.render, c.common, given);
  }
  if (c.bake_cmd->parsed()) {
    Status s = applyDescribed(c.bake_options, bakeOptionSpecs(), c.bake, setBakeOption, &given);
    if (!s) return reportError(s.error());
    return runBake(c.bake, c.common, given);
  }
  if (c.trace_cmd->parsed()) return runTrace(c.trace, c.common);
  if (c.info_cmd->parsed()) return runInfo(c.info, c.common);
  if (c.rays_cmd->parsed()) return runRays(c.rays, c.common);
  return 2;
}

// `penumbra methods`: every method with its options; --markdown prints the option reference of
// docs/cli.md.
int runMethods(int argc, char** argv) {
  const std::string arg = argc > 2 ? argv[2] : "";
  if (arg == "--markdown" && argc == 3) {
    std::fputs(optionReferenceMarkdown().c_str(), stdout);
    return 0;
  }
  if (!arg.empty()) {
    return reportError(
        inputError("", "", fmt::format("methods: unknown argument '{}' (use --markdown)", arg)));
  }
  for (const MethodInfo& m : methodInfos()) {
    std::vector<std::string> own;
    for (const OptionSpec& s : renderOptionSpecs()) {
      if (!s.uses.empty() && s.use(m.name)) own.push_back("--" + s.name);
    }
    std::printf("%s%s: %s (%s)\n  %s\n", m.name.c_str(), m.bakes ? " (render, bake)" : "",
                m.summary.c_str(), m.source.c_str(),
                fmt::format("{}", fmt::join(own, " ")).c_str());
  }
  return 0;
}

int parseAndRun(int argc, char** argv) {
  CommandLine c;
  c.app.require_subcommand(1);
  c.app.set_version_flag("--version", "penumbra " PENUMBRA_VERSION);
  addRenderCommand(c);
  addTraceCommand(c);
  addInfoCommand(c);
  addBakeCommand(c);
  addRaysCommand(c);
  for (CLI::App* cmd : {c.render_cmd, c.trace_cmd, c.info_cmd, c.bake_cmd, c.rays_cmd}) {
    refuseEmptyValues(cmd);
  }

  const std::string first = argc > 1 ? argv[1] : "";
  if (first == "view") return runView(argc, argv);
  if (first == "methods") return runMethods(argc, argv);
  if (!first.empty() && first[0] != '-' && first != "render" && first != "bake" &&
      first != "trace" && first != "rays" && first != "info") {
    return reportError(inputError(
        "", "",
        fmt::format("unknown command '{}' (commands: render, bake, trace, rays, info, view, "
                    "methods)",
                    first)));
  }
  try {
    c.app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return c.app.exit(e);
  } catch (const CLI::ParseError& e) {
    return reportError(inputError("", "", fmt::format("{} (see penumbra --help)", e.what())));
  }
  return runParsed(c);
}

}  // namespace

namespace {

int runCliCommand(int argc, char** argv) {
  try {
    return parseAndRun(argc, argv);
  } catch (const Interrupted&) {
    // A step without a clean stopping point was stopped (core/interrupt.h); the outputs'
    // temporaries went with the unwinding.
    std::fprintf(stderr,
                 "penumbra: interrupted during a step that cannot be resumed: nothing "
                 "was written\n");
    return InterruptScope::exitCode();
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
