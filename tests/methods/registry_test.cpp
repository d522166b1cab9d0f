// The methods' option descriptions (methods/registry.h): one check for every source of a value,
// the scene file's settings under the command line's, and docs/cli.md made from them.
#include "penumbra/methods/registry.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <set>
#include <sstream>

namespace penumbra {
namespace {

const OptionSpec& spec(const char* name) {
  const OptionSpec* s = findOption(renderOptionSpecs(), name);
  EXPECT_NE(s, nullptr) << name;
  return *s;
}

TEST(MethodRegistry, EveryOptionNamesKnownMethodsOnce) {
  std::set<std::string> methods;
  std::vector<std::string> in_order;
  for (const MethodInfo& m : methodInfos()) {
    EXPECT_TRUE(methods.insert(m.name).second) << m.name;
    in_order.push_back(m.name);
  }
  EXPECT_EQ(spec("method").choices, in_order);
  for (const auto* specs : {&renderOptionSpecs(), &bakeOptionSpecs()}) {
    std::set<std::string> names;
    for (const OptionSpec& s : *specs) {
      EXPECT_TRUE(names.insert(s.name).second) << "twice: " << s.name;
      EXPECT_FALSE(s.help.empty()) << s.name;
      std::set<std::string> owners;
      for (const OptionUse& u : s.uses) {
        EXPECT_TRUE(methods.count(u.method)) << s.name << ": " << u.method;
        EXPECT_TRUE(owners.insert(u.method).second) << s.name << ": " << u.method << " twice";
      }
      if (s.kind == OptionKind::kChoice) {
        // A choice's documented default is one of its choices, where it is a plain word.
        for (const OptionUse& u : s.uses) {
          if (u.default_value.find(' ') != std::string::npos || u.default_value.empty()) continue;
          EXPECT_NE(std::find(s.choices.begin(), s.choices.end(), u.default_value), s.choices.end())
              << s.name << ": " << u.default_value;
        }
      }
    }
  }
  // The methods that bake are the bake command's choices.
  std::vector<std::string> bakes;
  for (const MethodInfo& m : methodInfos()) {
    if (m.bakes) bakes.push_back(m.name);
  }
  EXPECT_EQ(findOption(bakeOptionSpecs(), "method")->choices, bakes);
}

TEST(MethodRegistry, OneRangeCheckPerMethod) {
  // --spp: the path tracer takes up to 2^20, the others 4096.
  EXPECT_TRUE(parseOption(spec("spp"), "1048576", "pathtrace", "", "--spp").ok());
  const Expected<OptionValue> over = parseOption(spec("spp"), "5000", "whitted", "", "--spp");
  ASSERT_FALSE(over.ok());
  EXPECT_EQ(over.error().describe(), "--spp: 5000 is out of range [1, 4096]");
  EXPECT_FALSE(parseOption(spec("spp"), "0", "pathtrace", "", "--spp").ok());
  // Numbers must be finite and whole where the kind says so.
  EXPECT_EQ(parseOption(spec("key"), "nan", "pathtrace", "", "--key").error().describe(),
            "--key: 'nan' is not a finite number");
  EXPECT_EQ(parseOption(spec("key"), "0", "pathtrace", "", "--key").error().describe(),
            "--key: 0 is out of range (0, 1]");
  EXPECT_FALSE(parseOption(spec("width"), "6.5", "matrix", "", "--width").ok());
  EXPECT_FALSE(parseOption(spec("seed"), "-1", "pathtrace", "", "--seed").ok());
  EXPECT_FALSE(parseOption(spec("seed"), "18446744073709551616", "pathtrace", "", "--seed").ok());
  EXPECT_EQ(std::get<uint64_t>(
                *parseOption(spec("seed"), "18446744073709551615", "pathtrace", "", "--seed")),
            UINT64_MAX);
  EXPECT_FALSE(parseOption(spec("sampler"), "halton", "pathtrace", "", "--sampler").ok());
  const Expected<OptionValue> boundary =
      parseOption(spec("boundary"), "0.1,0.9", "progressive", "", "--boundary");
  ASSERT_TRUE(boundary.ok());
  EXPECT_EQ(std::get<std::vector<double>>(*boundary), (std::vector<double>{0.1, 0.9}));
  EXPECT_FALSE(parseOption(spec("boundary"), "0.1", "progressive", "", "--boundary").ok());
  EXPECT_FALSE(parseOption(spec("boundary"), "0.1,1.5", "progressive", "", "--boundary").ok());
  EXPECT_FALSE(parseOption(spec("width"), "", "pathtrace", "", "--width").ok());
}

TEST(MethodRegistry, OptionsOfOtherMethodsAreRefused) {
  EXPECT_TRUE(checkOptionsTaken(renderOptionSpecs(), "photons", {"photons", "spp"}).ok());
  const Status s = checkOptionsTaken(renderOptionSpecs(), "pathtrace", {"spp", "light-samples"});
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().describe(),
            "--light-samples: applies to --method whitted and photons only, not pathtrace");
  EXPECT_FALSE(checkOptionsTaken(bakeOptionSpecs(), "matrix", {"seed"}).ok());
}

TEST(MethodRegistry, SceneSettingsAreCheckedAsTheCommandLineIs) {
  RenderOptions o;
  nlohmann::json settings = {{"pathtrace", {{"width", 8}, {"spp", 2}}},
                             {"matrix", {{"elements", 300}}}};
  Expected<std::vector<std::string>> set = applySceneSettings(o, settings, "s.json", {"spp"});
  ASSERT_TRUE(set.ok()) << set.error().describe();
  EXPECT_EQ(o.width, 8);
  EXPECT_FALSE(o.spp.has_value());       // the command line gave --spp: it wins
  EXPECT_FALSE(o.elements.has_value());  // matrix's settings wait for --method matrix
  o.method = "matrix";
  ASSERT_TRUE(applySceneSettings(o, settings, "s.json", {}).ok());
  EXPECT_EQ(o.elements, 300u);

  const auto refused = [&](nlohmann::json s) {
    RenderOptions r;
    const Expected<std::vector<std::string>> out = applySceneSettings(r, s, "s.json", {});
    return out.ok() ? std::string() : out.error().describe();
  };
  // The values a hostile file may carry are refused with the file and the key.
  EXPECT_EQ(refused({{"pathtrace", {{"spp", 0}}}}),
            "s.json: settings.pathtrace.spp: 0 is out of range [1, 1048576]");
  EXPECT_EQ(refused({{"pathtrace", {{"width", 0}}}}),
            "s.json: settings.pathtrace.width: 0 is out of range [1, 65536]");
  EXPECT_EQ(refused({{"pathtrace", {{"spp", uint64_t(1) << 40}}}}),
            "s.json: settings.pathtrace.spp: 1099511627776 is out of range [1, 1048576]");
  EXPECT_EQ(refused({{"pathtrace", {{"spp", 2.5}}}}),
            "s.json: settings.pathtrace.spp: must be an integer, not 2.5");
  EXPECT_NE(refused({{"pathtrace", {{"sppp", 3}}}}).find("settings.pathtrace.sppp: unknown"),
            std::string::npos);
  EXPECT_NE(refused({{"pathtrace", {{"photons", 3}}}}).find("is not a setting of pathtrace"),
            std::string::npos);
  EXPECT_NE(refused({{"raytrace", {{"spp", 3}}}}).find("settings.raytrace: unknown method"),
            std::string::npos);
  EXPECT_NE(refused({{"matrix", {{"solver", "lu"}}}}).find("'lu' is not one of"),
            std::string::npos);
  // Where outputs go is not a setting.
  EXPECT_NE(refused({{"progressive", {{"resume", "x.checkpoint"}}}}).find("unknown setting"),
            std::string::npos);
}

TEST(MethodRegistry, DocsHoldTheOptionReference) {
  std::ifstream in(std::string(PENUMBRA_SOURCE_DIR) + "/docs/cli.md");
  std::stringstream text;
  text << in.rdbuf();
  const std::string docs = text.str();
  const std::string begin = "<!-- options: generated by `penumbra methods --markdown` -->\n";
  const std::string end = "<!-- options: end -->";
  const size_t a = docs.find(begin);
  const size_t b = docs.find(end);
  ASSERT_NE(a, std::string::npos) << "docs/cli.md has no generated option reference";
  ASSERT_NE(b, std::string::npos);
  EXPECT_EQ(docs.substr(a + begin.size(), b - a - begin.size()), optionReferenceMarkdown())
      << "docs/cli.md's option reference is out of date: regenerate it with "
         "`penumbra methods --markdown`";
}

}  // namespace
}  // namespace penumbra
