/* bkflow LAMMPS plugin: the fused path's arrays in lattice order (bkfused::Arrays, for the
   kernel of bk_fused_kernel.inc): their layout in memory, the bonds' periodic images fixed from
   the anchors, and what the fix reads off them (sigma_x, the bonds' lengths and energy), row by
   row. No LAMMPS header and no state: fix_bk_fused_atoms.cpp fills the arrays from LAMMPS's atoms and
   sums the rows over ranks (bk_row_blocks.h).

   A block holds rows [0, nrows) of Lx particles (particle k = ix + Lx iy); on one rank it is
   the whole lattice of Ly rows, whose top row's +y partners are in the bottom row; a slab (a
   block of several, bkfused::Model::slab) has a ghost row below (indices -Lx..-1) and above
   (nrows Lx..(nrows + 1) Lx - 1), the top row's +y partners being the ghost row above. */

#ifndef BKFLOW_BK_FUSED_ARRAYS_H
#define BKFLOW_BK_FUSED_ARRAYS_H

#include "bk_fused_kernel.h"

#include <vector>

namespace bkfused {

// the arrays that Arrays holds read-only, writable while they are filled
struct Constants {
  double *ax, *ay, *kd, *srx, *sry, *sux, *suy;
};

/* Every array of Arrays in one pool, each 64-byte aligned and padded; on a slab with room for
   a ghost row before (in the pad) and after. */
class Pool {
 public:
  // points every array of `a` at the pool (zeros, first breaks -1) for nloc particles in rows
  // of Lx; returns the constants' arrays
  Constants allocate(Arrays &a, int nloc, int Lx, bool slab);
  std::size_t size() const { return mem.size(); }

 private:
  std::vector<double> mem;
};

/* each bond's periodic shift (srx, sry: +x bonds; sux, suy: +y bonds) from the anchors (ax,
   ay, with a slab's ghost rows filled): the lattice image that fix bk/substrate keeps, bond
   vector minus relative displacement = lattice vector. A slab: the +y bonds of the ghost row
   below too (its first row's -y bonds). */
void bond_images(const Constants &c, int Lx, int Ly, int nloc, bool slab, double xprd,
                 double yprd, bool xperiodic, bool yperiodic);

// rows[r] = sum over row r of the drive's x force k_d (shift - (X - anchor)), in lattice order
void sigma_rows(const Arrays &a, int Lx, int nrows, double shift, double *rows);

// the squared lengths of particle k's +x and +y bonds (at their fixed lattice images)
inline void bond_r2(const Arrays &a, int Lx, int Ly, bool slab, int k, double &rx2, double &uy2)
{
  const int ix = k % Lx, iy = k / Lx;
  // a slab's top row: its +y partners are the ghost row above
  const int r = (ix + 1) % Lx + Lx * iy, u = slab ? k + Lx : ix + Lx * ((iy + 1) % Ly);
  const double dx = a.x[k] - a.x[r] + a.srx[k], dy = a.y[k] - a.y[r] + a.sry[k];
  const double ex = a.x[k] - a.x[u] + a.sux[k], ey = a.y[k] - a.y[u] + a.suy[k];
  rx2 = dx * dx + dy * dy;
  uy2 = ex * ex + ey * ey;
}

// the largest squared bond length of particles [0, nloc)
double longest_bond2(const Arrays &a, int Lx, int Ly, bool slab, int nloc);

// rows[r] = the energy k_b/2 (r - r0)^2 of the +x and +y bonds of row r's particles
void bond_energy_rows(const Arrays &a, int Lx, int Ly, bool slab, int nrows, double kb,
                      double r0, double *rows);

}    // namespace bkfused

#endif
