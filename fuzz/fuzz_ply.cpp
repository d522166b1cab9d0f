// PLY, ASCII and binary.
#include "fuzz_util.h"
#include "penumbra/io/scene_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace penumbra;
  const std::string path =
      fuzz::writeInput("x.ply", std::string_view(reinterpret_cast<const char*>(data), size));
  fuzz::expectContract(loadPly(path), path);
  return 0;
}
