/* bkflow LAMMPS plugin: the model's formulas (docs/model.md), written once as inline scalar
   functions for every path that integrates or observes the model (fix bk/substrate's general
   path, the fused kernel, the floor benchmark). No LAMMPS header. The functions are static
   (internal linkage): each source file, the fused kernel's builds for every instruction set
   among them, compiles its own copy with its own flags, so that the linker can never give a
   CPU without AVX2 a copy compiled for it. */

#ifndef BKFLOW_BK_MODEL_H
#define BKFLOW_BK_MODEL_H

#include <cmath>

namespace bkmodel {

/* exp(2 pi i u) = (c, s) for any finite u, without a libm call and without a branch, so that
   a loop over contacts vectorizes: u is reduced to r in [-1/2, 1/2], the half angle
   h = pi r in [-pi/2, pi/2] is taken by its Taylor polynomials to h^21 and h^20 (truncation
   below 3e-17), and doubled. Within 1e-15 of libm's (tests/test_phase.py). */
static inline void unit_phasor(double u, double &c, double &s)
{
  constexpr double PI = 3.141592653589793238462643383279503;
  const double r = u - std::floor(u + 0.5);
  const double h = PI * r, h2 = h * h;
  const double sn = h * (1.0 + h2 * (-1.0 / 6.0 + h2 * (1.0 / 120.0 + h2 * (-1.0 / 5040.0
      + h2 * (1.0 / 362880.0 + h2 * (-1.0 / 39916800.0 + h2 * (1.0 / 6227020800.0
      + h2 * (-1.0 / 1307674368000.0 + h2 * (1.0 / 355687428096000.0
      + h2 * (-1.0 / 121645100408832000.0 + h2 * (1.0 / 51090942171709440000.0)))))))))));
  const double cs = 1.0 + h2 * (-0.5 + h2 * (1.0 / 24.0 + h2 * (-1.0 / 720.0
      + h2 * (1.0 / 40320.0 + h2 * (-1.0 / 3628800.0 + h2 * (1.0 / 479001600.0
      + h2 * (-1.0 / 87178291200.0 + h2 * (1.0 / 20922789888000.0
      + h2 * (-1.0 / 6402373705728000.0 + h2 * (1.0 / 2432902008176640000.0))))))))));
  c = cs * cs - sn * sn;
  s = 2.0 * sn * cs;
}

/* The contacts' load phases (docs/model.md "Contact phase"): u_i = k_e |dr_i| / (mu_s sigma_n
   A) in [0, 1), the contact breaking at u = 1. The phase sums accumulate, over contacts, what
   the phase statistics need: the first two Fourier moments of the phase angle 2 pi u (the
   Kuramoto order parameter Z = <exp(2 pi i u)> and its second harmonic), and the first two
   moments of u itself. Sums are reduced over MPI ranks as NPHASE doubles. */
enum PhaseSum { PH_N, PH_C1, PH_S1, PH_C2, PH_S2, PH_U, PH_UU, NPHASE };

// adds the contact with displacement (drx, dry) to sums; inv_lim = k_e / (mu_s sigma_n A)
static inline void add_phase(double *sums, double drx, double dry, double inv_lim)
{
  const double u = inv_lim * std::sqrt(drx * drx + dry * dry);
  double c, s;
  unit_phasor(u, c, s);
  sums[PH_N] += 1.0;
  sums[PH_C1] += c;
  sums[PH_S1] += s;
  sums[PH_C2] += c * c - s * s;    // cos 4 pi u
  sums[PH_S2] += 2.0 * s * c;      // sin 4 pi u
  sums[PH_U] += u;
  sums[PH_UU] += u * u;
}

/* The phase sums of contacts [0, n) of arrays drx, dry (the fused path's lattice order), in
   PHASE_LANES interleaved partial sums added in a fixed order at the end: a loop a compiler
   vectorizes at any vector width, with the same bits at every width. */
constexpr int PHASE_LANES = 8;
static inline void phase_sums(const double *drx, const double *dry, int n, double inv_lim,
                       double *sums)
{
  double acc[NPHASE][PHASE_LANES] = {};
  const int whole = n - n % PHASE_LANES;
  for (int k0 = 0; k0 < whole; k0 += PHASE_LANES) {
    for (int l = 0; l < PHASE_LANES; l++) {
      const double x = drx[k0 + l], y = dry[k0 + l];
      const double u = inv_lim * std::sqrt(x * x + y * y);
      double c, s;
      unit_phasor(u, c, s);
      acc[PH_C1][l] += c;
      acc[PH_S1][l] += s;
      acc[PH_C2][l] += c * c - s * s;
      acc[PH_S2][l] += 2.0 * s * c;
      acc[PH_U][l] += u;
      acc[PH_UU][l] += u * u;
    }
  }
  double tail[NPHASE] = {};
  for (int k = whole; k < n; k++) add_phase(tail, drx[k], dry[k], inv_lim);
  for (int j = PH_C1; j < NPHASE; j++) {
    double t = 0.0;
    for (int l = 0; l < PHASE_LANES; l++) t += acc[j][l];
    sums[j] += t + tail[j];
  }
  sums[PH_N] += n;
}

}    // namespace bkmodel

#endif
