// Images read back (PNG, EXR, HDR, PFM): the same bytes under each extension.
#include "fuzz_util.h"
#include "penumbra/io/image_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace penumbra;
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  for (const char* name : {"x.png", "x.exr", "x.hdr", "x.pfm"}) {
    const std::string path = fuzz::writeInput(name, in);
    fuzz::expectContract(readImage(path), path);
  }
  return 0;
}
