/* bkflow LAMMPS plugin: finding bkflow's square lattice among LAMMPS's atoms, the test of
   whether the fused path of fix bk/substrate can run a deck (plugins/README.md "Choosing the
   path", "The fused path"). `integrate` takes the fused path exactly when bk_fused_lattice()
   finds a lattice (bkplugin.cpp); `fused` refuses a deck it finds none in (fix_bk_fused.cpp).

   The lattice: atom ID k + 1 = 1 + ix + Lx iy has exactly four bonds, to its periodic
   neighbours (ix +- 1, iy) and (ix, iy +- 1); Lx, Ly >= 3 (with 2 rows, the up and down
   neighbours coincide). The tests of one rank's atoms (bk_lattice::) are pure functions of
   arrays; bk_fused_lattice() gathers their verdicts over the ranks. */

#ifndef BKFLOW_BK_LATTICE_DETECT_H
#define BKFLOW_BK_LATTICE_DETECT_H

#include "lmptype.h"

#include <string>

namespace LAMMPS_NS {
class LAMMPS;

/* Lx of the lattice the fused path can run, 0 when it cannot, with the reason in *why (the end
   of an error message): atom IDs 1..N, an atom map, the bonds of bkflow's periodic square
   lattice, one positive mass; on K > 1 ranks, the ranks in a column (`processors 1 * 1`: each
   holds a block of rows), at least one row each, and every particle within a quarter row of
   its row's line. Collective. */
int bk_fused_lattice(LAMMPS *lmp, std::string *why = nullptr);

namespace bk_lattice {

/* whether each of the nlocal atoms (IDs tag, bond counts num_bond, bond partners bond_atom)
   is bonded exactly to its four periodic neighbours in a lattice of n atoms, lx a row */
bool bonds_match(const tagint *tag, const int *num_bond, const tagint *const *bond_atom,
                 int nlocal, int n, int lx);

/* how far, in rows of height a, the height y of atom ID `tag` is from its row's line
   y = lo + (iy + 1/2) a of a lattice of lx x ly (through the periodic boundary when periodic) */
double rows_off_line(double y, tagint tag, int lx, int ly, double lo, double a, bool periodic);

}    // namespace bk_lattice
}    // namespace LAMMPS_NS

#endif
