/* bkflow LAMMPS plugin: the fused kernel built with -mavx512f and 512-bit vectors
   (CMakeLists.txt), run only where the CPU has AVX-512F (bk_fused_kernel.cpp checks at run
   time). No FMA: -ffp-contract=off keeps every operation of the baseline build, so all builds
   give the same bits. */
#include "bk_fused_kernel.h"

#include <utility>

#define BK_ISA_NS avx512
#include "bk_fused_kernel.inc"
#include "bk_fused_energies.inc"
