#include "penumbra/methods/option_input.h"

#include "penumbra/methods/registry.h"

#include <fmt/format.h>

#include <algorithm>
#include <functional>
#include <optional>

namespace penumbra {

namespace {

// One value to set: the option's description, where it came from ("--spp", "spp"), and its text
// (words) or JSON value (named values).
struct Pending {
  const OptionSpec* spec = nullptr;
  bool common = false;
  std::string where;
  std::optional<std::string> text;
  nlohmann::json value;
};

// The description of `name` among the command's and the common options, or an error naming it.
Expected<Pending> describe(const std::vector<OptionSpec>& specs, const std::string& name,
                           const std::string& where) {
  Pending p;
  p.where = where;
  for (const OptionSpec& s : specs) {
    if (!s.positional && (s.name == name || (!s.short_name.empty() && s.short_name == name))) {
      p.spec = &s;
      return p;
    }
  }
  for (const OptionSpec& s : commonOptionSpecs()) {
    if (s.name == name) {
      p.spec = &s;
      p.common = true;
      return p;
    }
  }
  return inputError("", where, "is not an option of this command (penumbra methods lists them)");
}

// The words' options, in order: "--name value", "--name=value", "-o value", "--flag".
Expected<std::vector<Pending>> fromWords(const std::vector<OptionSpec>& specs,
                                         const std::vector<std::string>& words) {
  std::vector<Pending> out;
  for (size_t i = 0; i < words.size(); ++i) {
    const std::string& word = words[i];
    if (word.size() < 2 || word[0] != '-') {
      return inputError("", word,
                        "is not an option (the scene is given as the call's scene, not a word)");
    }
    const size_t eq = word.find('=');
    const std::string key = word.substr(0, eq);
    const std::string name = key.starts_with("--") ? key.substr(2) : key;
    Expected<Pending> p = describe(specs, name, key);
    if (!p) return p.error();
    p->where = "--" + p->spec->name;
    if (eq != std::string::npos) {
      p->text = word.substr(eq + 1);
    } else if (p->spec->kind == OptionKind::kFlag) {
      p->text = "true";
    } else if (i + 1 < words.size()) {
      p->text = words[++i];
    } else {
      return inputError("", p->where, "needs a value");
    }
    out.push_back(std::move(*p));
  }
  return out;
}

// The named values, a repeatable option's array as one value per element.
Expected<std::vector<Pending>> fromValues(const std::vector<OptionSpec>& specs,
                                          const std::vector<NamedValue>& values) {
  std::vector<Pending> out;
  for (const auto& [given_name, value] : values) {
    std::string name = given_name;
    std::replace(name.begin(), name.end(), '_', '-');
    Expected<Pending> p = describe(specs, name, given_name);
    if (!p) return p.error();
    if (p->spec->repeatable && value.is_array()) {
      for (const nlohmann::json& v : value) {
        Pending each = *p;
        each.value = v;
        out.push_back(std::move(each));
      }
      continue;
    }
    p->value = value;
    out.push_back(std::move(*p));
  }
  return out;
}

template <typename Options>
using Setter = void (*)(Options&, const OptionSpec&, const OptionValue&);

// Sets `pending` onto `input`: the method first (the other values are checked against its
// ranges), then every other value, then the check that the method takes each one.
template <typename Options>
Expected<CommandInput<Options>> apply(const std::vector<OptionSpec>& specs,
                                      std::vector<Pending> pending, Options defaults,
                                      Setter<Options> set) {
  CommandInput<Options> input;
  input.options = std::move(defaults);
  const auto parse = [&](const Pending& p, const std::string& method) -> Expected<OptionValue> {
    if (p.text) {
      if (p.spec->kind == OptionKind::kFlag) {
        if (*p.text == "true" || *p.text == "1") return OptionValue(true);
        if (*p.text == "false" || *p.text == "0") return OptionValue(false);
        return inputError("", p.where, fmt::format("takes no value ('{}')", *p.text));
      }
      return parseOption(*p.spec, *p.text, method, "", p.where);
    }
    return optionFromJson(*p.spec, p.value, method, "", p.where);
  };
  for (const Pending& p : pending) {
    if (p.common || p.spec->name != "method") continue;
    Expected<OptionValue> v = parse(p, "");
    if (!v) return v.error();
    input.options.method = std::get<std::string>(*v);
  }
  std::vector<std::string> own;
  for (const Pending& p : pending) {
    Expected<OptionValue> v = parse(p, input.options.method);
    if (!v) return v.error();
    if (p.common) {
      setCommonOption(input.common, *p.spec, *v);
    } else {
      set(input.options, *p.spec, *v);
      own.push_back(p.spec->name);
    }
    if (std::find(input.given.begin(), input.given.end(), p.spec->name) == input.given.end()) {
      input.given.push_back(p.spec->name);
    }
  }
  PENUMBRA_TRY(checkOptionsTaken(specs, input.options.method, own));
  return input;
}

}  // namespace

Expected<RenderInput> renderInputFromWords(const std::vector<std::string>& words,
                                           RenderOptions defaults) {
  Expected<std::vector<Pending>> p = fromWords(renderOptionSpecs(), words);
  if (!p) return p.error();
  return apply(renderOptionSpecs(), std::move(*p), std::move(defaults), &setRenderOption);
}

Expected<BakeInput> bakeInputFromWords(const std::vector<std::string>& words,
                                       BakeOptions defaults) {
  Expected<std::vector<Pending>> p = fromWords(bakeOptionSpecs(), words);
  if (!p) return p.error();
  return apply(bakeOptionSpecs(), std::move(*p), std::move(defaults), &setBakeOption);
}

Expected<RenderInput> renderInputFromValues(const std::vector<NamedValue>& values,
                                            RenderOptions defaults) {
  Expected<std::vector<Pending>> p = fromValues(renderOptionSpecs(), values);
  if (!p) return p.error();
  return apply(renderOptionSpecs(), std::move(*p), std::move(defaults), &setRenderOption);
}

Expected<BakeInput> bakeInputFromValues(const std::vector<NamedValue>& values,
                                        BakeOptions defaults) {
  Expected<std::vector<Pending>> p = fromValues(bakeOptionSpecs(), values);
  if (!p) return p.error();
  return apply(bakeOptionSpecs(), std::move(*p), std::move(defaults), &setBakeOption);
}

}  // namespace penumbra
