#include "support/test_util.h"

#include "penumbra/gpu/context.h"

#include <sys/wait.h>
#include <array>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <random>

#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>

namespace penumbra::test {

std::string glbBytes(const nlohmann::json& doc, const std::string& bin) {
  auto append32 = [](std::string& out, uint32_t v) {
    out.append(reinterpret_cast<const char*>(&v), 4);
  };
  std::string json_chunk = doc.dump();
  while (json_chunk.size() % 4 != 0) json_chunk += ' ';
  std::string bin_chunk = bin;
  while (bin_chunk.size() % 4 != 0) bin_chunk += '\0';
  std::string out = "glTF";
  append32(out, 2u);
  append32(out, uint32_t(12 + 8 + json_chunk.size() + 8 + bin_chunk.size()));
  append32(out, uint32_t(json_chunk.size()));
  append32(out, 0x4E4F534Au);
  out += json_chunk;
  append32(out, uint32_t(bin_chunk.size()));
  append32(out, 0x004E4942u);
  out += bin_chunk;
  return out;
}

double testLuminaireCandela(double c_degrees, double gamma_degrees) {
  const double c = glm::radians(c_degrees), g = glm::radians(gamma_degrees);
  if (gamma_degrees <= 90.0) {
    return 1000.0 * (1.0 + 0.5 * std::cos(c) * std::sin(g)) * std::pow(std::cos(g), 1.5);
  }
  return 150.0 * std::sin(g - 0.5 * std::numbers::pi);
}

LuminaireLight testLuminaire(glm::vec3 position, glm::vec3 nadir, glm::vec3 c0) {
  static const std::shared_ptr<const LuminaireDistribution> distribution = [] {
    constexpr int kC = 36, kG = 37;
    std::vector<double> cd;
    for (int c = 0; c < kC; ++c) {
      for (int g = 0; g < kG; ++g) cd.push_back(testLuminaireCandela(10.0 * c, 5.0 * g));
    }
    auto t = std::make_shared<LuminaireDistribution>();
    std::string why;
    if (!LuminaireDistribution::fromCandela(kC, kG, cd, "test", *t, why)) std::abort();
    return t;
  }();
  LuminaireLight l;
  l.position = position;
  l.nadir = glm::normalize(nadir);
  l.c0 = glm::normalize(c0 - glm::dot(c0, l.nadir) * l.nadir);
  l.scale = glm::vec3(float(distribution->max_candela / kLumensPerWatt));
  l.distribution = distribution;
  return l;
}

TempDir::TempDir() {
  std::random_device rd;
  for (;;) {
    path_ = std::filesystem::temp_directory_path() /
            ("penumbra-test-" + std::to_string(rd()) + std::to_string(rd()));
    if (std::filesystem::create_directory(path_)) break;
  }
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

std::string TempDir::write(const std::string& name, const std::string& contents) const {
  const std::string p = file(name);
  std::ofstream out(p, std::ios::binary);
  out << contents;
  return p;
}

GlContext* glContext(std::string& why) {
  static std::string failure;
  static std::unique_ptr<GlContext> context = [] {
    Expected<std::unique_ptr<GlContext>> c = GlContext::createHeadless();
    if (!c) {
      failure = c.error().describe();
      return std::unique_ptr<GlContext>();
    }
    return std::move(*c);
  }();
  why = failure;
  if (context) context->makeCurrent();
  return context.get();
}

nlohmann::json readJson(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

CliResult runCli(const std::string& args, const std::string& env) {
  return runShell((env.empty() ? "" : "env " + env + " ") + std::string(PENUMBRA_CLI) + " " + args +
                  " 2>&1");
}

CliResult runShell(const std::string& cmd) {
  CliResult result;
  FILE* pipe = ::popen(cmd.c_str(), "r");
  if (!pipe) return result;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = std::fread(buf.data(), 1, buf.size(), pipe)) > 0) result.output.append(buf.data(), n);
  const int status = ::pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

}  // namespace penumbra::test
