/* bkflow LAMMPS plugin: the fused kernel for any x86-64 (or other) CPU, built with the
   plugin's baseline flags (see bk_fused_kernel.inc). */
#include "bk_fused_kernel.h"

#include <utility>

#define BK_ISA_NS baseline
#include "bk_fused_kernel.inc"
#include "bk_fused_energies.inc"
