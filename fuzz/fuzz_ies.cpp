// IES LM-63: the input's bytes as an .ies file, parsed from memory (TILT=<file> is refused).
#include "fuzz_util.h"
#include "penumbra/io/photometry.h"

#include <cmath>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace penumbra;
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  const Expected<Photometry> p = parseIes(in, "fuzz.ies");
  fuzz::expectContract(p, "fuzz.ies");
  // What loads must evaluate: finite intensities and flux, for every photometric type.
  if (p.ok() && !std::isfinite(p->integratedFlux() + p->intensity(30.0, 60.0) +
                               p->intensity(glm::dvec3(0.3, -0.2, 0.9)))) {
    std::abort();
  }
  return 0;
}
