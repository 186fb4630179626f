/* bkflow LAMMPS plugin: the model's physics (docs/model.md), written once. Every formula of the
   model (bond force and energy, the bond's periodic image, the drive, each contact rule with its
   break located inside the step, the damping schemes, the velocity-Verlet half steps, the plate's
   clock, the contacts' load phases) is a static inline scalar function here, and every code that
   integrates or observes the model calls it: fix bk/substrate's general path
   (fix_bk_substrate_forces.cpp), the fused kernel (bk_fused_kernel.inc, built once per
   instruction set) and the floor benchmark (benchmarks/measure/floor_kernel.c). As LAMMPS's GRANULAR sub-models
   share stateless kernels between the host and Kokkos, and HOOMD-blue's CPU and GPU potentials
   share one evaluator.

   Plain C (it is included by the C floor kernel too), no LAMMPS header. The functions are static
   (internal linkage): each source file, each build of the fused kernel among them, compiles
   its own copy with its own flags, so that the linker can never give a CPU without AVX2 a copy
   compiled for it. Each function fixes the order of its operations for every caller, so that
   the paths give the same bits; a change of that order changes every trajectory's bits.

   Adding a contact rule: a value of bk_contact_rule and its name in BK_CONTACT_NAMES, its case
   in bk_contact_break(), and the Python side (bkflow.model.params.CONTACT_RULES; tests/reference.py
   stays an independent implementation on purpose). */

#ifndef BKFLOW_BK_MODEL_H
#define BKFLOW_BK_MODEL_H

#include <math.h>

/* ----------------------------------------------------------------------- rules and schemes */

/* what a contact does when |k_e dr| passes f_max = mu_s sigma_n A (docs/model.md "Forces",
   "Integration"): BK_RESET, the paper's rule with the break located inside the step (the
   contact re-forms where |dr| reached the threshold and keeps the rest of the step's motion);
   BK_RESET_STEP, dr = 0 at the end of the step (first order); BK_COULOMB, dr rescaled onto the
   threshold (sliding). BK_NO_CONTACT: no friction at all. */
enum bk_contact_rule { BK_NO_CONTACT, BK_RESET, BK_RESET_STEP, BK_COULOMB, BK_NCONTACT };

/* the velocity in the damping force -m gamma v: BK_IMPLICIT, the end-of-step velocity solved
   for (second order); BK_HALF, the half-step velocity (first order). BK_NO_DAMPING: gamma = 0
   or no damping. */
enum bk_damping { BK_NO_DAMPING, BK_IMPLICIT, BK_HALF, BK_NDAMPING };

#ifdef __cplusplus
/* the names the decks and bkflow.model.params (CONTACT_RULES, DAMPING_MODES) use, by rule and by
   scheme (index 0, none: no name) */
static const char *const BK_CONTACT_NAMES[BK_NCONTACT] = {"", "reset", "reset/step",
                                                          "coulomb"};
static const char *const BK_DAMPING_NAMES[BK_NDAMPING] = {"", "implicit", "half"};
#endif

/* ----------------------------------------------------------------------- integration */

/* a velocity-Verlet half kick, v + dt/(2m) f (h = dt/(2m)), and a drift, x + dt v: fix nve's
   initial and final integrate */
static inline double bk_kick(double v, double h, double f)
{
  return v + h * f;
}

static inline double bk_drift(double x, double dt, double v)
{
  return x + dt * v;
}

/* the plate's displacement V_d (t - t0) after `steps` whole steps of dt0 from an elapsed time
   e0: the clock counts steps, so that a run in pieces or from a restart file follows one long
   run to the last bit */
static inline double bk_plate_shift(double vd, double e0, double steps, double dt0)
{
  return vd * (e0 + steps * dt0);
}

/* ----------------------------------------------------------------------- bonds */

/* the factor b of a bond's force on its owner, F = b d for the bond vector d (|d|^2 = r2):
   -k_b (|d| - r0) / |d| */
static inline double bk_bond_factor(double r2, double kb, double r0)
{
  const double r = sqrt(r2);
  return -kb * (r - r0) / r;
}

/* a bond's energy k_b/2 (|d| - r0)^2 */
static inline double bk_bond_energy(double r2, double kb, double r0)
{
  const double dr = sqrt(r2) - r0;
  return 0.5 * kb * dr * dr;
}

/* the nearest integer of a small value, without a libm call */
static inline double bk_round_small(double v)
{
  return (double) (int) (v + (v >= 0.0 ? 0.5 : -0.5));
}

/* the periodic shift, a multiple of the box length prd, that brings a bond vector d (minus
   the relative displacement of its atoms, which makes it the lattice vector) within half a
   box: the bond's lattice image, kept however far the bond stretches */
static inline double bk_image_shift(double d, double prd)
{
  return -prd * bk_round_small(d / prd);
}

/* ----------------------------------------------------------------------- drive */

/* the drive's force on a particle displaced by (ux, uy) from its anchor's start, the anchor
   having moved by `shift` along x: k_d^i (anchor(t) - r) */
static inline double bk_drive_x(double kd, double shift, double ux)
{
  return kd * (shift - ux);
}

static inline double bk_drive_y(double kd, double uy)
{
  return -(kd * uy);
}

/* ----------------------------------------------------------------------- contacts */

/* whether a contact of displacement (drx, dry) is past the threshold, |k_e dr| > f_max
   (ke2 = k_e^2, fmax2 = f_max^2) */
static inline int bk_contact_over(double drx, double dry, double ke2, double fmax2)
{
  return ke2 * (drx * drx + dry * dry) > fmax2;
}

/* whether the contact rule left a contact that broke past the threshold: the step carried it
   further than the rule can bring back (BK_RESET when the step's own displacement exceeds the
   range). BK_COULOMB rescales the contact onto the threshold itself, where rounding alone
   leaves about half of them an ulp above it: never an overshoot. */
static inline int bk_contact_overshoot(int rule, double drx, double dry, double ke2,
                                       double fmax2)
{
  return rule != BK_COULOMB && bk_contact_over(drx, dry, ke2, fmax2);
}

/* The contact rule applied to a contact that broke in this step: (*drx, *dry) its displacement
   after the step, (wx, wy) = v dt the step's own displacement, fmax and ke the threshold and
   stiffness, lim2 = (f_max / k_e)^2. BK_RESET: the fraction th of the step at which |dr|
   reached sqrt(lim2) solves |dr_old + th w|^2 = lim2 (the larger root, clamped to [0, 1]), and
   the re-formed contact keeps the rest of the step, dr = (1 - th) w. */
static inline void bk_contact_break(int rule, double *drx, double *dry, double wx, double wy,
                                    double fmax, double ke, double lim2)
{
  if (rule == BK_COULOMB) {
    const double r2 = *drx * *drx + *dry * *dry;
    const double scale = fmax / (ke * sqrt(r2));
    *drx *= scale;
    *dry *= scale;
  } else if (rule == BK_RESET) {
    const double ox = *drx - wx, oy = *dry - wy;
    const double a = wx * wx + wy * wy, b = ox * wx + oy * wy;
    const double c = ox * ox + oy * oy - lim2;
    double th = a > 0.0 ? (-b + sqrt(b * b > a * c ? b * b - a * c : 0.0)) / a : 1.0;
    th = th < 0.0 ? 0.0 : (th > 1.0 ? 1.0 : th);
    *drx = (1.0 - th) * wx;
    *dry = (1.0 - th) * wy;
  } else { /* BK_RESET_STEP */
    *drx = 0.0;
    *dry = 0.0;
  }
}

/* The energy a break takes out of its contact (docs/model.md "Energy"), from its displacement
   before (bx, by) and after (ax, ay) bk_contact_break: BK_RESET, the contact's energy where it
   broke, at dr_old + th w = before - after (f_max^2 / 2 k_e unless th was clamped); any other
   rule, the contact's energy before less after: BK_RESET_STEP, its whole end-of-step energy
   (after = 0); BK_COULOMB, the energy above the threshold that the rescaling removes (the
   sliding work). */
static inline double bk_break_loss(int rule, double bx, double by, double ax, double ay,
                                   double ke)
{
  if (rule == BK_RESET) {
    const double dx = bx - ax, dy = by - ay;
    return 0.5 * ke * (dx * dx + dy * dy);
  }
  return 0.5 * ke * ((bx * bx + by * by) - (ax * ax + ay * ay));
}

/* ----------------------------------------------------------------------- damping */

/* the magnitude m gamma v' of the damping force -m gamma v' on one component (mg = m gamma):
   BK_IMPLICIT, v' the end-of-step velocity v1 = v + h (F_other - m gamma v1) solved for,
   v' = (v + h f_other) den with h = dt/(2m), den = 1/(1 + gamma dt/2), f_other the other forces
   on the component this step; BK_HALF, v' = v, the half-step velocity */
static inline double bk_damping(int scheme, double mg, double v, double h, double f_other,
                                double den)
{
  return scheme == BK_IMPLICIT ? mg * (v + h * f_other) * den : mg * v;
}

/* ----------------------------------------------------------------------- the energy ledger */

/* The ledger's damping term (docs/model.md "Energy"): what one half kick v -> v1 = v + h F
   takes from the kinetic energy through the damping force fd, -fd (v + v1) dt/4 per component
   (h = dt/(2m)): the work of the damping force over the half kick, exactly. A step's two half
   kicks are computed where their forces are known: the second (vh -> v1) when the step's
   forces are, the first of the next step (v1 -> v1 + h F) then too, held until that step. */
static inline double bk_kick_work(double fd, double v, double v1)
{
  return fd * (v + v1);
}

/* The running sums of the ledger that a path keeps, per rank (their sum over ranks is the
   layer's: every term is linear in its atoms): the plate's work by the trapezoid rule over each
   step, V_d dt (F_n + F_n+1)/2 for the drive springs' total x force F (f_prev holds this rank's
   F_n); the energy taken by breaks; the damping's dissipation of the half kicks done
   (damp_next: the work of the next step's first half kick, -4/dt times, not yet counted). */
enum bk_ledger_sum { BK_LED_WORK, BK_LED_BREAK, BK_LED_DAMP, BK_NLEDGER };

/* ----------------------------------------------------------------------- contact phases */

/* exp(2 pi i u) as (*c, *s) for any finite u, without a libm call and without a branch, so
   that a loop over contacts vectorizes: u is reduced to r in [-1/2, 1/2], the half angle
   h = pi r in [-pi/2, pi/2] is taken by its Taylor polynomials to h^21 and h^20 (truncation
   below 3e-17), and doubled. Within 1e-15 of libm's (tests/plugins/test_phase.py). */
static inline void bk_unit_phasor(double u, double *c, double *s)
{
  const double PI = 3.141592653589793238462643383279503;
  const double r = u - floor(u + 0.5);
  const double h = PI * r, h2 = h * h;
  const double sn = h * (1.0 + h2 * (-1.0 / 6.0 + h2 * (1.0 / 120.0 + h2 * (-1.0 / 5040.0
      + h2 * (1.0 / 362880.0 + h2 * (-1.0 / 39916800.0 + h2 * (1.0 / 6227020800.0
      + h2 * (-1.0 / 1307674368000.0 + h2 * (1.0 / 355687428096000.0
      + h2 * (-1.0 / 121645100408832000.0 + h2 * (1.0 / 51090942171709440000.0)))))))))));
  const double cs = 1.0 + h2 * (-0.5 + h2 * (1.0 / 24.0 + h2 * (-1.0 / 720.0
      + h2 * (1.0 / 40320.0 + h2 * (-1.0 / 3628800.0 + h2 * (1.0 / 479001600.0
      + h2 * (-1.0 / 87178291200.0 + h2 * (1.0 / 20922789888000.0
      + h2 * (-1.0 / 6402373705728000.0 + h2 * (1.0 / 2432902008176640000.0))))))))));
  *c = cs * cs - sn * sn;
  *s = 2.0 * sn * cs;
}

/* The contacts' load phases (docs/model.md "Contact phase"): u_i = k_e |dr_i| / (mu_s sigma_n
   A) in [0, 1), the contact breaking at u = 1. The phase sums accumulate, over contacts, what
   the phase statistics need: the first two Fourier moments of the phase angle 2 pi u (the
   Kuramoto order parameter Z = <exp(2 pi i u)> and its second harmonic), and the first two
   moments of u itself. Sums are reduced over MPI ranks as BK_NPHASE doubles. */
enum bk_phase_sum { BK_PH_N, BK_PH_C1, BK_PH_S1, BK_PH_C2, BK_PH_S2, BK_PH_U, BK_PH_UU,
                    BK_NPHASE };

/* adds the contact with displacement (drx, dry) to sums; inv_lim = k_e / (mu_s sigma_n A) */
static inline void bk_add_phase(double *sums, double drx, double dry, double inv_lim)
{
  const double u = inv_lim * sqrt(drx * drx + dry * dry);
  double c, s;
  bk_unit_phasor(u, &c, &s);
  sums[BK_PH_N] += 1.0;
  sums[BK_PH_C1] += c;
  sums[BK_PH_S1] += s;
  sums[BK_PH_C2] += c * c - s * s; /* cos 4 pi u */
  sums[BK_PH_S2] += 2.0 * s * c;   /* sin 4 pi u */
  sums[BK_PH_U] += u;
  sums[BK_PH_UU] += u * u;
}

/* The phase sums of contacts [0, n) of arrays drx, dry (the fused path's lattice order), in
   BK_PHASE_LANES interleaved partial sums added in a fixed order at the end: a loop a compiler
   vectorizes at any vector width, with the same bits at every width. */
enum { BK_PHASE_LANES = 8 };
static inline void bk_phase_sums(const double *drx, const double *dry, int n, double inv_lim,
                                 double *sums)
{
  double acc[BK_NPHASE][BK_PHASE_LANES] = {{0.0}};
  double tail[BK_NPHASE] = {0.0};
  const int whole = n - n % BK_PHASE_LANES;
  for (int k0 = 0; k0 < whole; k0 += BK_PHASE_LANES) {
    for (int l = 0; l < BK_PHASE_LANES; l++) {
      const double x = drx[k0 + l], y = dry[k0 + l];
      const double u = inv_lim * sqrt(x * x + y * y);
      double c, s;
      bk_unit_phasor(u, &c, &s);
      acc[BK_PH_C1][l] += c;
      acc[BK_PH_S1][l] += s;
      acc[BK_PH_C2][l] += c * c - s * s;
      acc[BK_PH_S2][l] += 2.0 * s * c;
      acc[BK_PH_U][l] += u;
      acc[BK_PH_UU][l] += u * u;
    }
  }
  for (int k = whole; k < n; k++) bk_add_phase(tail, drx[k], dry[k], inv_lim);
  for (int j = BK_PH_C1; j < BK_NPHASE; j++) {
    double t = 0.0;
    for (int l = 0; l < BK_PHASE_LANES; l++) t += acc[j][l];
    sums[j] += t + tail[j];
  }
  sums[BK_PH_N] += n;
}

#endif
