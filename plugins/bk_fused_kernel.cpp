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
  }
BK_DECLARE(baseline)
#ifdef BK_FUSED_AVX2
BK_DECLARE(avx2)
#endif
#undef BK_DECLARE

Kernel select()
{
  const char *want = std::getenv("BKFLOW_FUSED_ISA");
  const bool force_baseline = want && std::strcmp(want, "baseline") == 0;
#ifdef BK_FUSED_AVX2
  __builtin_cpu_init();
  if (!force_baseline && __builtin_cpu_supports("avx2")) return {"avx2", &avx2::run, &avx2::setup};
#else
  (void) force_baseline;
#endif
  return {"baseline", &baseline::run, &baseline::setup};
}

}    // namespace bkfused
