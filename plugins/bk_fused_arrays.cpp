/* bkflow LAMMPS plugin: the fused path's arrays in lattice order (bk_fused_arrays.h). */

#include "bk_fused_arrays.h"

#include <algorithm>
#include <cstdint>

namespace bkfused {

Constants Pool::allocate(Arrays &a, int nloc, int Lx, bool slab)
{
  const size_t pad = slab ? (static_cast<size_t>(Lx) + 7) / 8 * 8 : 0;
  size_t stride = pad + (static_cast<size_t>(nloc) + (slab ? Lx : 0) + 7) / 8 * 8;
  // arrays a multiple of 4 KB apart alias in the CPU's store forwarding (the loops stream
  // ten of them at once, and the step slows where they alias: benchmarks/RESULTS.md); an
  // odd number of 64-byte lines apart, the NARR arrays start at distinct offsets of 4 KB
  if (stride / 8 % 2 == 0) stride += 8;
  constexpr int NARR = 30;
  mem.assign(stride * NARR + 8, 0.0);
  double *p = mem.data();
  while (reinterpret_cast<uintptr_t>(p) % 64) p++;
  double *next = p;
  auto take = [&]() {
    double *q = next + pad;
    next += stride;
    return q;
  };
  a.x = take(), a.y = take(), a.vx = take(), a.vy = take(), a.fx = take();
  a.fy = take(), a.drx = take(), a.dry = take(), a.vhx = take(), a.vhy = take();
  Constants c;
  c.ax = take(), c.ay = take(), c.kd = take(), c.srx = take(), c.sry = take(), c.sux = take();
  c.suy = take();
  a.ax = c.ax, a.ay = c.ay, a.kd = c.kd, a.srx = c.srx, a.sry = c.sry, a.sux = c.sux;
  a.suy = c.suy;
  a.brx = take(), a.bry = take(), a.blx = take(), a.bly = take(), a.bux = take();
  a.buy = take(), a.bdx = take(), a.bdy = take(), a.over = take();
  a.fb = take();
  a.term_fx = take(), a.term_done = take(), a.term_next = take();
  for (int k = 0; k < nloc; k++) a.fb[k] = -1.0;
  return c;
}

void bond_images(const Constants &c, int Lx, int Ly, int nloc, bool slab, double xprd,
                 double yprd, bool xperiodic, bool yperiodic)
{
  const double *ax = c.ax, *ay = c.ay;
  auto image_shift = [](double d, double prd, int periodic) {
    return periodic ? bk_image_shift(d, prd) : 0.0;
  };
  for (int k = slab ? -Lx : 0; k < nloc; k++) {
    const int ix = (k + Lx) % Lx, iy = (k + Lx) / Lx - 1;
    const int u = slab ? k + Lx : ix + Lx * ((iy + 1) % Ly);
    c.sux[k] = image_shift(ax[k] - ax[u], xprd, xperiodic);
    c.suy[k] = image_shift(ay[k] - ay[u], yprd, yperiodic);
    if (k < 0) continue;
    const int r = (ix + 1) % Lx + Lx * iy;
    c.srx[k] = image_shift(ax[k] - ax[r], xprd, xperiodic);
    c.sry[k] = image_shift(ay[k] - ay[r], yprd, yperiodic);
  }
}

void sigma_rows(const Arrays &a, int Lx, int nrows, double shift, double *rows)
{
  for (int r = 0; r < nrows; r++) {
    double s = 0.0;
    for (int k = r * Lx; k < (r + 1) * Lx; k++) s += bk_drive_x(a.kd[k], shift, a.x[k] - a.ax[k]);
    rows[r] = s;
  }
}

double longest_bond2(const Arrays &a, int Lx, int Ly, bool slab, int nloc)
{
  double r2max = 0.0;
  for (int k = 0; k < nloc; k++) {
    double rx2, uy2;
    bond_r2(a, Lx, Ly, slab, k, rx2, uy2);
    r2max = std::max(r2max, std::max(rx2, uy2));
  }
  return r2max;
}

void bond_energy_rows(const Arrays &a, int Lx, int Ly, bool slab, int nrows, double kb,
                      double r0, double *rows)
{
  for (int r = 0; r < nrows; r++) {
    double e = 0.0;
    for (int k = r * Lx; k < (r + 1) * Lx; k++) {
      double rx2, uy2;
      bond_r2(a, Lx, Ly, slab, k, rx2, uy2);
      e += bk_bond_energy(rx2, kb, r0) + bk_bond_energy(uy2, kb, r0);
    }
    rows[r] = e;
  }
}

}    // namespace bkfused
