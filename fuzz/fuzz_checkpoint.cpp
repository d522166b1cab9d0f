// Progressive radiosity checkpoints, resumed into the built-in Cornell box at 40 texels per
// metre. The solver is built once; LLVMFuzzerInitialize writes a valid checkpoint of it (after a
// few shots) into the corpus directory, so that mutations start from a file that resumes.
#include "fuzz_util.h"
#include "penumbra/radiosity/progressive.h"
#include "penumbra/radiosity/progressive_checkpoint.h"
#include "penumbra/scene/builtin.h"

#include <filesystem>
#include <string>

namespace {

const penumbra::Scene& scene() {
  static const penumbra::Scene s = *penumbra::builtinScene("cornell");
  return s;
}

penumbra::ProgressiveRadiosity build() {
  penumbra::ProgressiveOptions o;
  o.atlas.texel_density = 40.0;
  return std::move(*penumbra::ProgressiveRadiosity::build(scene(), o));
}

penumbra::ProgressiveRadiosity& solver() {
  static penumbra::ProgressiveRadiosity s = build();
  return s;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
  using namespace penumbra;
  for (int i = 1; i < *argc; ++i) {
    const std::string arg = (*argv)[i];
    if (arg.empty() || arg[0] == '-' || !std::filesystem::is_directory(arg)) continue;
    const std::string seed = arg + "/valid.checkpoint";
    if (!std::filesystem::exists(seed)) {
      ProgressiveRadiosity shot = build();
      for (int k = 0; k < 3; ++k) (void)shot.step();
      (void)writeProgressiveCheckpoint(seed, scene(), shot);
    }
    break;
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace penumbra;
  const std::string path =
      fuzz::writeInput("x.checkpoint", std::string_view(reinterpret_cast<const char*>(data), size));
  const Expected<ProgressiveCheckpointInfo> info = readProgressiveCheckpointInfo(path);
  fuzz::expectContract(info, path);
  if (info) {
    const Status s = resumeProgressiveCheckpoint(path, scene(), solver());
    fuzz::expectContract(s, path);
  }
  return 0;
}
