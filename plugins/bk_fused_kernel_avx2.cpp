/* bkflow LAMMPS plugin: the fused kernel built with -mavx2 (CMakeLists.txt), run only where
   the CPU has AVX2 (bk_fused_kernel.cpp checks at run time). No FMA: -ffp-contract=off keeps
   every operation of the baseline build, so both give the same bits. */
#include "bk_fused_kernel.h"

#include <utility>

#define BK_ISA_NS avx2
#include "bk_fused_kernel.inc"
#include "bk_fused_energies.inc"
