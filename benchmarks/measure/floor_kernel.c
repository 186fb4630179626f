/* The floor: the model step of fix bk/substrate as a tight single-thread C kernel, with nothing
   of LAMMPS around it, the fastest this model runs on one core. Compiled and driven by
   benchmarks/measure/floor.py
   (gcc -O3 -march=native -fno-math-errno -shared -fPIC), called through ctypes.

   The model (docs/model.md; plugins/README.md), for the one configuration the benchmark
   measures: bonds with fixed lattice images, drive, contact rule `reset` (the break located
   inside the step), damping `implicit`, velocity Verlet in LAMMPS's order (fix nve's
   initial_integrate, then the fix's post_force, then fix nve's final_integrate):

     vh = v + dt/(2m) f;  x += dt vh                                   (initial_integrate)
     f  = bonds(x) + k_d (anchor + V_d t x_hat - x) - k_e dr - m gamma v1   (post_force)
          with dr += vh dt, broken and re-formed inside the step when |k_e dr| > f_max,
          v1 = (vh + dt/(2m) F_other) / (1 + gamma dt / 2) the end-of-step velocity
     v  = vh + dt/(2m) f                                               (final_integrate)

   Arrays are structure-of-arrays in lattice order, particle k = ix + Lx iy; particle k owns
   the bond to its +x neighbour (R) and to its +y neighbour (U), each with a fixed periodic
   shift (srx, sry: R; sux, suy: U) so that d = x_k - x_partner + s. Bond forces go to two
   arrays per direction, one indexed by the owner and one by the partner, so that every loop is
   a plain vectorizable sweep; the Ly bonds that wrap around a row are redone in a scalar fix-up.
   Contact breaks are rare: a vectorized sweep advances dr and counts them, a scalar sweep
   re-forms the broken ones only in the steps that have any.

   GCC does not take `restrict` on local pointers as proof enough: `#pragma GCC ivdep` says the
   arrays do not overlap.

   Setup (LAMMPS's setup(): the forces of the stored state without advancing the contact
   history, damping with the velocity v) runs when `setup` is nonzero.

   Every formula is a function of plugins/bk_model.h, the model's one header, which the plugin's
   paths call too (floor.py compiles with -I plugins). */

#include "bk_model.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef struct {
  int Lx, Ly;
  double dt, mass, kb, r0, vd, ke, fmax, gamma;
  double xprd, yprd; /* box lengths */
} bk_params;

typedef struct {
  double *x, *y, *vx, *vy, *fx, *fy, *drx, *dry; /* state, updated */
  const double *ax, *ay, *kd;                    /* anchors, drive stiffness */
  const double *srx, *sry, *sux, *suy;           /* fixed periodic shifts of the R and U bonds */
} bk_arrays;

/* scratch of one run: bond forces by owner (R: br, U: bu) and by partner (bl: the partner's
   left bond, bd: its down bond), and the contact-break flags of a step */
typedef struct {
  double *brx, *bry, *blx, *bly, *bux, *buy, *bdx, *bdy, *over;
} bk_scratch;

typedef struct {
  const bk_params *p;
  bk_arrays *a;
  bk_scratch *s;
  int N;
  double hv, lim2, fmax2, ke2;
} bk_ctx;

/* initial_integrate of particles [k0, k1) (v becomes the half-step velocity), and their contact
   history: dr += v dt, re-formed inside the step where |k_e dr| passed f_max. Returns the
   breaks. */
static long advance(const bk_ctx *c, int k0, int k1)
{
  const double dt = c->p->dt, hv = c->hv, ke2 = c->ke2, fmax2 = c->fmax2;
  double *restrict x = c->a->x, *restrict y = c->a->y;
  double *restrict vx = c->a->vx, *restrict vy = c->a->vy;
  const double *restrict fx = c->a->fx, *restrict fy = c->a->fy;
  double *restrict drx = c->a->drx, *restrict dry = c->a->dry;
  double *restrict over = c->s->over;
  long nb = 0;
#pragma GCC ivdep
  for (int k = k0; k < k1; k++) {
    vx[k] = bk_kick(vx[k], hv, fx[k]);
    vy[k] = bk_kick(vy[k], hv, fy[k]);
    x[k] = bk_drift(x[k], dt, vx[k]);
    y[k] = bk_drift(y[k], dt, vy[k]);
    drx[k] += vx[k] * dt;
    dry[k] += vy[k] * dt;
    const int o = bk_contact_over(drx[k], dry[k], ke2, fmax2);
    over[k] = o;
    nb += o;
  }
  if (!nb) return 0;
  for (int k = k0; k < k1; k++)
    if (over[k] != 0.0)
      bk_contact_break(BK_RESET, &drx[k], &dry[k], vx[k] * dt, vy[k] * dt, c->p->fmax,
                       c->p->ke, c->lim2);
  return nb;
}

/* the +x bonds of rows [r0, r1) */
static void right_bonds(const bk_ctx *c, int r0, int r1)
{
  const int Lx = c->p->Lx, k0 = r0 * Lx, k1 = r1 * Lx;
  const double kb = c->p->kb, b0 = c->p->r0;
  const double *restrict x = c->a->x, *restrict y = c->a->y;
  const double *restrict srx = c->a->srx, *restrict sry = c->a->sry;
  double *restrict brx = c->s->brx, *restrict bry = c->s->bry;
  double *restrict blx = c->s->blx, *restrict bly = c->s->bly;
  /* as if every partner were k + 1: wrong at the row ends, redone below */
#pragma GCC ivdep
  for (int k = k0; k < k1 - 1; k++) {
    const double dx = x[k] - x[k + 1] + srx[k], dy = y[k] - y[k + 1] + sry[k];
    const double fb = bk_bond_factor(dx * dx + dy * dy, kb, b0);
    brx[k] = fb * dx;
    bry[k] = fb * dy;
    blx[k + 1] = fb * dx;
    bly[k + 1] = fb * dy;
  }
  for (int r = r0; r < r1; r++) {
    const int k = r * Lx + Lx - 1, j = r * Lx;
    const double dx = x[k] - x[j] + srx[k], dy = y[k] - y[j] + sry[k];
    const double fb = bk_bond_factor(dx * dx + dy * dy, kb, b0);
    brx[k] = fb * dx;
    bry[k] = fb * dy;
    blx[j] = fb * dx;
    bly[j] = fb * dy;
  }
}

static void up_range(const bk_ctx *c, int k0, int k1, int off)
{
  const double kb = c->p->kb, b0 = c->p->r0;
  const double *restrict x = c->a->x, *restrict y = c->a->y;
  const double *restrict sux = c->a->sux, *restrict suy = c->a->suy;
  double *restrict bux = c->s->bux, *restrict buy = c->s->buy;
  double *restrict bdx = c->s->bdx, *restrict bdy = c->s->bdy;
#pragma GCC ivdep
  for (int k = k0; k < k1; k++) {
    const double dx = x[k] - x[k + off] + sux[k], dy = y[k] - y[k + off] + suy[k];
    const double fb = bk_bond_factor(dx * dx + dy * dy, kb, b0);
    bux[k] = fb * dx;
    buy[k] = fb * dy;
    bdx[k + off] = fb * dx;
    bdy[k + off] = fb * dy;
  }
}

/* the +y bonds of rows [r0, r1); the top row's partners are in the bottom row */
static void up_bonds(const bk_ctx *c, int r0, int r1)
{
  const int Lx = c->p->Lx, Ly = c->p->Ly;
  if (r1 < Ly) {
    up_range(c, r0 * Lx, r1 * Lx, Lx);
  } else {
    up_range(c, r0 * Lx, (Ly - 1) * Lx, Lx);
    up_range(c, (Ly - 1) * Lx, Ly * Lx, -(Ly - 1) * Lx);
  }
}

/* the forces on particles [k0, k1): bonds, drive, contact, and damping with the velocity v
   (the half-step one in a step); then, in a step (`final`), v += dt/(2m) f */
static void forces(const bk_ctx *c, int k0, int k1, double shift, int final)
{
  const bk_params *p = c->p;
  const double m = p->mass, dt = p->dt, ke = p->ke, hv = c->hv;
  const double h = 0.5 * dt / m, den = 1.0 / (1.0 + 0.5 * p->gamma * dt), mg = m * p->gamma;
  const double *restrict x = c->a->x, *restrict y = c->a->y;
  const double *restrict ax = c->a->ax, *restrict ay = c->a->ay, *restrict kd = c->a->kd;
  const double *restrict drx = c->a->drx, *restrict dry = c->a->dry;
  const double *restrict brx = c->s->brx, *restrict bry = c->s->bry;
  const double *restrict blx = c->s->blx, *restrict bly = c->s->bly;
  const double *restrict bux = c->s->bux, *restrict buy = c->s->buy;
  const double *restrict bdx = c->s->bdx, *restrict bdy = c->s->bdy;
  double *restrict fx = c->a->fx, *restrict fy = c->a->fy;
  double *restrict vx = c->a->vx, *restrict vy = c->a->vy;
#pragma GCC ivdep
  for (int k = k0; k < k1; k++) {
    const double fbx = brx[k] - blx[k] + bux[k] - bdx[k];
    const double fby = bry[k] - bly[k] + buy[k] - bdy[k];
    double gx = bk_drive_x(kd[k], shift, x[k] - ax[k]);
    double gy = bk_drive_y(kd[k], y[k] - ay[k]);
    gx -= ke * drx[k];
    gy -= ke * dry[k];
    gx -= bk_damping(BK_IMPLICIT, mg, vx[k], h, fbx + gx, den);
    gy -= bk_damping(BK_IMPLICIT, mg, vy[k], h, fby + gy, den);
    const double Fx = fbx + gx, Fy = fby + gy;
    fx[k] = Fx;
    fy[k] = Fy;
    if (final) {
      vx[k] = bk_kick(vx[k], hv, Fx);
      vy[k] = bk_kick(vy[k], hv, Fy);
    }
  }
}

static void *alloc(size_t n)
{
  void *p = NULL;
  if (posix_memalign(&p, 64, (n ? n : 1) * sizeof(double))) return NULL;
  memset(p, 0, n * sizeof(double));
  return p;
}

/* rows per block of the pipeline: about BLOCK_ATOMS particles, whose arrays stay in L1 */
#ifndef BLOCK_ATOMS
#define BLOCK_ATOMS 256
#endif

/* One step: blocks of rows go through initial_integrate, bonds and forces in turn, so that a
   block's data is still in the L1 cache when its forces are summed. A block's +y bonds need the
   next block's positions, and the first block's forces need the last block's +y bonds, so the
   first and the last block advance first. */
static long step(const bk_ctx *c, double shift, int B)
{
  const int Lx = c->p->Lx, Ly = c->p->Ly, nblk = (Ly + B - 1) / B;
  const int last0 = (nblk - 1) * B;
  long nb = advance(c, 0, (B < Ly ? B : Ly) * Lx);
  if (nblk > 1) nb += advance(c, last0 * Lx, Ly * Lx);
  up_bonds(c, last0, Ly);
  for (int i = 0; i < nblk; i++) {
    const int r0 = i * B, r1 = r0 + B < Ly ? r0 + B : Ly;
    if (i + 1 < nblk - 1) nb += advance(c, r1 * Lx, (r1 + B) * Lx);
    right_bonds(c, r0, r1);
    if (i < nblk - 1) up_bonds(c, r0, r1);
    forces(c, r0 * Lx, r1 * Lx, shift, 1);
  }
  return nb;
}

/* Runs `nsteps` steps from step `step0` (plate shift V_d step dt); sigma_x of every `nevery`-th
   step goes to sigma[] (may be NULL). Returns the contact breaks, or -1 on allocation failure;
   *ns gets the wall time of the steps in nanoseconds. */
long bk_floor_run(const bk_params *p, bk_arrays *a, long step0, long nsteps, int setup,
                  int nevery, double *sigma, double *ns)
{
  const int N = p->Lx * p->Ly;
  bk_scratch s;
  double **all[] = {&s.brx, &s.bry, &s.blx, &s.bly, &s.bux, &s.buy, &s.bdx, &s.bdy, &s.over};
  for (size_t i = 0; i < sizeof all / sizeof all[0]; i++)
    if (!(*all[i] = alloc((size_t) N))) return -1;
  bk_ctx c = {p, a, &s, N, 0.5 * p->dt / p->mass, p->fmax * p->fmax / (p->ke * p->ke),
              p->fmax * p->fmax, p->ke * p->ke};
  const double dt = p->dt, area = p->xprd * p->yprd;
  int B = BLOCK_ATOMS / p->Lx;
  B = B < 1 ? 1 : (B > p->Ly ? p->Ly : B);
  long breaks = 0, nsig = 0;

  struct timespec t0, t1, c0, c1;
  clock_gettime(CLOCK_MONOTONIC, &t0);
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c0);
  if (setup) {
    right_bonds(&c, 0, p->Ly);
    up_bonds(&c, 0, p->Ly);
    forces(&c, 0, N, bk_plate_shift(p->vd, 0.0, (double) step0, dt), 0);
  }
  for (long n = step0 + 1; n <= step0 + nsteps; n++) {
    const double shift = bk_plate_shift(p->vd, 0.0, (double) n, dt);
    breaks += step(&c, shift, B);
    if (sigma && nevery > 0 && n % nevery == 0) {
      double sx = 0.0;
      for (int k = 0; k < N; k++) sx += bk_drive_x(a->kd[k], shift, a->x[k] - a->ax[k]);
      sigma[nsig++] = sx / area;
    }
  }
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c1);
  clock_gettime(CLOCK_MONOTONIC, &t1);
  ns[0] = (double) (t1.tv_sec - t0.tv_sec) * 1e9 + (double) (t1.tv_nsec - t0.tv_nsec);
  ns[1] = (double) (c1.tv_sec - c0.tv_sec) * 1e9 + (double) (c1.tv_nsec - c0.tv_nsec);
  for (size_t i = 0; i < sizeof all / sizeof all[0]; i++) free(*all[i]);
  return breaks;
}
