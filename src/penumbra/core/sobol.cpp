#include "penumbra/core/sobol.h"

namespace penumbra {

SobolX4Kernel sobolX4Kernel() {
#if PENUMBRA_SOBOL_X86
  if (__builtin_cpu_supports("sse4.1") && __builtin_cpu_supports("ssse3")) {
    if (__builtin_cpu_supports("gfni")) return &sobol_simd::x4Gfni;
    return &sobol_simd::x4Sse41;
  }
#endif
  return &owenSobol2DBitsReversedX4Scalar;
}

}  // namespace penumbra
