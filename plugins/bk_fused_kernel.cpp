/* bkflow LAMMPS plugin: run-time choice of the fused kernel's build (bk_fused_kernel.h). */

#include "bk_fused_kernel.h"

#include <cstdlib>
#include <cstring>

namespace bkfused {

#define BK_DECLARE(NS)                                                                        \
  namespace NS {                                                                              \
  long run(const Model &, Arrays &, const Mirror &, int64_t, int64_t, long *);              \
  void setup(const Model &, Arrays &, const Mirror &, int64_t, const double *,               \
             const double *);                                                                 \
  void phase(const double *, const double *, int, double, double *);                         \
  void energies(const Model &, const Arrays &, double, double *);                            \
  }
BK_DECLARE(baseline)
#ifdef BK_FUSED_AVX2
BK_DECLARE(avx2)
#endif
#ifdef BK_FUSED_AVX512
BK_DECLARE(avx512)
#endif
#undef BK_DECLARE

Kernel select()
{
  const char *want = std::getenv("BKFLOW_FUSED_ISA");
  // BKFLOW_FUSED_ISA=baseline|avx2 caps the instruction set (tests, benchmarks)
  const bool baseline_only = want && std::strcmp(want, "baseline") == 0;
  const bool avx2_max = baseline_only || (want && std::strcmp(want, "avx2") == 0);
#if defined(BK_FUSED_AVX2) || defined(BK_FUSED_AVX512)
  __builtin_cpu_init();
#endif
#ifdef BK_FUSED_AVX512
  if (!avx2_max && __builtin_cpu_supports("avx512f"))
    return {"avx512", &avx512::run, &avx512::setup, &avx512::phase, &avx512::energies};
#endif
#ifdef BK_FUSED_AVX2
  if (!baseline_only && __builtin_cpu_supports("avx2"))
    return {"avx2", &avx2::run, &avx2::setup, &avx2::phase, &avx2::energies};
#endif
  (void) avx2_max;
  return {"baseline", &baseline::run, &baseline::setup, &baseline::phase, &baseline::energies};
}

}    // namespace bkfused
