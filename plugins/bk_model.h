/* bkflow LAMMPS plugin: the model's formulas (docs/model.md), written once as inline scalar
   functions for every path that integrates or observes the model (fix bk/substrate's general
   path, the fused kernel, the floor benchmark). No LAMMPS header. */

#ifndef BKFLOW_BK_MODEL_H
#define BKFLOW_BK_MODEL_H

#include <cmath>

namespace bkmodel {

/* The contacts' load phases (docs/model.md "Contact phase"): u_i = k_e |dr_i| / (mu_s sigma_n
   A) in [0, 1), the contact breaking at u = 1. PhaseSums accumulates, over contacts, what the
   phase statistics need: the first two Fourier moments of the phase angle 2 pi u (the
   Kuramoto order parameter Z = <exp(2 pi i u)> and its second harmonic), and the first two
   moments of u itself. Sums are reduced over MPI ranks as NPHASE doubles. */
enum PhaseSum { PH_N, PH_C1, PH_S1, PH_C2, PH_S2, PH_U, PH_UU, NPHASE };

// adds the contact with displacement (drx, dry) to sums; inv_lim = k_e / (mu_s sigma_n A)
inline void add_phase(double *sums, double drx, double dry, double inv_lim)
{
  constexpr double TWO_PI = 6.283185307179586476925286766559;
  const double u = inv_lim * std::sqrt(drx * drx + dry * dry);
  const double c = std::cos(TWO_PI * u), s = std::sin(TWO_PI * u);
  sums[PH_N] += 1.0;
  sums[PH_C1] += c;
  sums[PH_S1] += s;
  sums[PH_C2] += c * c - s * s;    // cos 4 pi u
  sums[PH_S2] += 2.0 * s * c;      // sin 4 pi u
  sums[PH_U] += u;
  sums[PH_UU] += u * u;
}

}    // namespace bkmodel

#endif
