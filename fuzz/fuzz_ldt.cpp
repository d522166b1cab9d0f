// EULUMDAT: the input's bytes as an .ldt file, parsed from memory (no file is written).
#include "fuzz_util.h"
#include "penumbra/io/photometry.h"

#include <cmath>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace penumbra;
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  const Expected<Photometry> p = parseEulumdat(in, "fuzz.ldt");
  fuzz::expectContract(p, "fuzz.ldt");
  // What loads must evaluate: finite intensities and flux.
  if (p.ok() && !std::isfinite(p->integratedFlux() + p->intensity(30.0, 60.0))) std::abort();
  return 0;
}
