// Options from a program rather than the command line (methods/option_input.h): the string form's
// words and the typed values, each checked by the descriptions as the command line's are.
#include "penumbra/methods/option_input.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace penumbra {
namespace {

TEST(OptionInput, WordsAndValuesAreCheckedAsTheCommandLinesAre) {
  // The words: the command line's syntax and checks.
  Expected<RenderInput> words =
      renderInputFromWords({"--method", "progressive", "--adaptive", "--iterations=30", "-o",
                            "a.png", "-o", "b.exr", "--threads", "1"});
  ASSERT_TRUE(words.ok()) << words.error().describe();
  EXPECT_TRUE(words->options.adaptive);
  EXPECT_EQ(words->options.iterations, 30);
  EXPECT_EQ(words->options.outputs, (std::vector<std::string>{"a.png", "b.exr"}));
  EXPECT_EQ(words->common.threads, 1);
  const auto refused = [](const Expected<RenderInput>& in, const std::string& part) {
    ASSERT_FALSE(in.ok()) << part;
    EXPECT_EQ(in.error().kind, ErrorKind::kInput);
    EXPECT_NE(in.error().describe().find(part), std::string::npos) << in.error().describe();
  };
  refused(renderInputFromWords({"--spp", "0"}), "--spp");
  refused(renderInputFromWords({"--spp"}), "needs a value");
  refused(renderInputFromWords({"--light-samples", "2"}),
          "applies to --method whitted and photons only, not pathtrace");
  refused(renderInputFromWords({"scene.json"}), "scene.json");
  refused(renderInputFromWords({"--sppp", "4"}), "--sppp");

  // Named values: typed, with '_' or '-', the same ranges for the method named.
  Expected<RenderInput> values = renderInputFromValues(
      {{"method", "whitted"}, {"light_samples", 3}, {"output", {"a.png", "b.exr"}}});
  ASSERT_TRUE(values.ok()) << values.error().describe();
  EXPECT_EQ(values->options.light_samples, 3);
  EXPECT_EQ(values->options.outputs.size(), 2u);
  EXPECT_EQ(values->given, (std::vector<std::string>{"method", "light-samples", "output"}));
  refused(renderInputFromValues({{"spp", "64"}}), "must be an integer");
  refused(renderInputFromValues({{"spp", 1 << 30}}), "spp");
  refused(renderInputFromValues({{"method", "pathtrace"}, {"light_samples", 3}}),
          "applies to --method whitted and photons only");
  refused(renderInputFromValues({{"method", "raytrace"}}), "method");
  Expected<BakeInput> bake = bakeInputFromValues({{"method", "progressive"}, {"adaptive", true}});
  ASSERT_TRUE(bake.ok()) << bake.error().describe();
  EXPECT_TRUE(bake->options.adaptive);
}

}  // namespace
}  // namespace penumbra
