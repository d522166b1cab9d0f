#include "penumbra/interactive/live_settings.h"

#include "penumbra/methods/registry.h"

#include <fmt/format.h>

#include <string>

namespace penumbra {

namespace {

constexpr const char* kLiveOptions[] = {"spp", "seed", "elements", "iterations", "grid", "steps"};

// The live settings' field for an option, typed as its description's kind (int64, or uint64
// for an unsigned option); 0 where the settings leave it to the method.
OptionValue fieldValue(const LiveSettings& s, const OptionSpec& spec) {
  const std::string& name = spec.name;
  const uint64_t v = name == "spp"          ? uint64_t(s.spp)
                     : name == "seed"       ? s.seed
                     : name == "elements"   ? uint64_t(s.elements)
                     : name == "iterations" ? uint64_t(s.iterations)
                     : name == "grid"       ? uint64_t(s.lpv.grid)
                                            : uint64_t(s.lpv.steps);
  if (spec.kind == OptionKind::kUnsigned) return v;
  return int64_t(v);
}

void setField(LiveSettings& s, const std::string& name, const OptionValue& v) {
  const auto whole = [&]() -> int64_t {
    if (const int64_t* i = std::get_if<int64_t>(&v)) return *i;
    return int64_t(std::get<uint64_t>(v));
  };
  if (name == "spp") s.spp = int(whole());
  if (name == "seed") s.seed = uint64_t(whole());
  if (name == "elements") s.elements = uint32_t(whole());
  if (name == "iterations") s.iterations = int(whole());
  if (name == "grid") s.lpv.grid = int(whole());
  if (name == "steps") s.lpv.steps = int(whole());
}

// Whether the settings leave the option to the method (0 means "the method's default" for these;
// the seed's default is 0 and the grid and steps carry theirs).
bool leftToMethod(const LiveSettings& s, const std::string& name) {
  if (name == "spp") return s.spp == 0;
  if (name == "elements") return s.elements == 0;
  if (name == "iterations") return s.iterations == 0;
  if (name == "seed") return s.seed == 0;
  const LpvOptions defaults;
  if (name == "grid") return s.lpv.grid == defaults.grid;
  return s.lpv.steps == defaults.steps;
}

}  // namespace

std::vector<const OptionSpec*> liveOptionSpecs(LiveMethod method) {
  const std::string m(liveMethodName(method));
  std::vector<const OptionSpec*> out;
  for (const char* name : kLiveOptions) {
    const OptionSpec* spec = findOption(renderOptionSpecs(), name);
    if (spec && spec->takenBy(m)) out.push_back(spec);
  }
  return out;
}

OptionValue liveOptionValue(const LiveSettings& settings, LiveMethod method,
                            const OptionSpec& spec) {
  if (leftToMethod(settings, spec.name)) {
    // The method's default as its description gives it, when it is a number.
    if (const OptionUse* use = spec.use(std::string(liveMethodName(method)))) {
      Expected<OptionValue> d = parseOption(spec, use->default_value, use->method, "", spec.name);
      if (d) return *d;
    }
  }
  return fieldValue(settings, spec);
}

Status setLiveOption(LiveSettings& settings, LiveMethod method, const OptionSpec& spec,
                     const OptionValue& value) {
  const std::string m(liveMethodName(method));
  if (!spec.takenBy(m)) {
    return inputError("", "--" + spec.name,
                      fmt::format("applies to --method {} only, not {}", spec.owners(), m));
  }
  PENUMBRA_TRY(checkOption(spec, value, m, "", "--" + spec.name));
  setField(settings, spec.name, value);
  return {};
}

Expected<LiveSettings> resolveLiveSettings(const Scene& scene, LiveMethod method,
                                           LiveSettings settings) {
  const std::string m(liveMethodName(method));
  RenderOptions options;
  options.method = m;
  std::vector<std::string> given;
  for (const OptionSpec* spec : liveOptionSpecs(method)) {
    if (leftToMethod(settings, spec->name)) continue;
    const OptionValue value = fieldValue(settings, *spec);
    PENUMBRA_TRY(checkOption(*spec, value, m, "", "--" + spec->name));
    given.push_back(spec->name);
  }
  // The scene's settings for the options left to the method.
  Expected<std::vector<std::string>> set =
      applySceneSettings(options, scene.settings, scene.source, given);
  if (!set) return set.error();
  for (const std::string& name : *set) {
    if (name == "spp" && options.spp) settings.spp = *options.spp;
    if (name == "seed" && options.seed) settings.seed = *options.seed;
    if (name == "elements" && options.elements) settings.elements = *options.elements;
    if (name == "iterations" && options.iterations) settings.iterations = *options.iterations;
    if (name == "grid" && options.grid) settings.lpv.grid = *options.grid;
    if (name == "steps" && options.steps) settings.lpv.steps = *options.steps;
  }
  return settings;
}

}  // namespace penumbra
