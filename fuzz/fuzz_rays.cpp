// Ray files (`penumbra trace --rays`).
#include "fuzz_util.h"
#include "penumbra/io/ray_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace penumbra;
  const std::string path =
      fuzz::writeInput("x.bin", std::string_view(reinterpret_cast<const char*>(data), size));
  fuzz::expectContract(readRayFile(path), path);
  return 0;
}
