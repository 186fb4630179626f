/* bkflow LAMMPS plugin: the kernel of `fix bk/substrate ... fused` (fix_bk_fused.cpp), one
   velocity-Verlet step of the whole model on arrays in lattice order. No LAMMPS header: the
   kernel is compiled once per instruction set (bk_fused_kernel_*.cpp include
   bk_fused_kernel.inc with their own flags) and chosen at run time (bkfused::select). */

#ifndef BKFLOW_BK_FUSED_KERNEL_H
#define BKFLOW_BK_FUSED_KERNEL_H

#include "bk_model.h"

#include <cstdint>

namespace bkfused {

/* Particle k = ix + Lx iy (atom ID k + 1) owns the bond to its +x neighbour (R) and to its +y
   neighbour (U); each bond keeps a fixed periodic shift (srx, sry; sux, suy) so that the bond
   vector is d = x_k - x_partner + s. Positions are unwrapped. */
struct Model {
  int Lx = 0, Ly = 0, N = 0;
  /* slab: the arrays hold a block of Ly rows of a larger lattice (several MPI ranks), with a
     ghost row below (indices -Lx..-1) and above (Ly Lx..(Ly + 1) Lx - 1) whose positions
     Arrays::halo_start and halo_wait fill after every drift; the top row's +y partners are the
     ghost row above. Each particle's arithmetic is the same as on the whole lattice, so every
     block division gives the same bits. */
  int slab = 0;
  int drive = 0, contact = BK_NO_CONTACT, damping = BK_NO_DAMPING;    // bk_model.h
  int ledger = 0;      // keep the energy ledger (Arrays::led)
  double dt = 0.0;
  double mass = 0.0;   // every particle's
  double hv = 0.0;     // fix nve's dtf / m: v += hv f
  double hd = 0.0;     // the damping's dt / (2 m)
  double mg = 0.0;     // m gamma
  double den = 0.0;    // 1 / (1 + gamma dt / 2)
  double kb = 0.0, r0 = 0.0;
  double ke = 0.0, fmax = 0.0, fmax2 = 0.0, ke2 = 0.0, lim2 = 0.0;    // lim2 = (fmax / ke)^2
  double vd = 0.0;
  // the plate's clock (FixBKLayer::plate_now): shift(n) = vd (e0 + (n - n0) dt0)
  double e0 = 0.0, dt0 = 0.0;
  int64_t n0 = 0;
};

struct Arrays {
  // state, lattice order
  double *x, *y, *vx, *vy, *fx, *fy, *drx, *dry, *vhx, *vhy;
  // constant
  const double *ax, *ay, *kd, *srx, *sry, *sux, *suy;
  // scratch: bond forces by owner (br, bu) and by partner (bl: its left bond, bd: its down
  // bond); contact-break flags
  double *brx, *bry, *blx, *bly, *bux, *buy, *bdx, *bdy, *over;
  // the energy ledger (Model::ledger): running sums (bk_model.h bk_ledger_sum), the drive
  // force sum F_n of the last step, the next step's first half kick's damping work (pending),
  // and one step's scratch sums
  double led[BK_NLEDGER];
  double led_fprev, led_next;
  double acc_fx, acc_done, acc_next, acc_lost;
  // per particle, the ledger's terms of the step before they are summed (so that the force
  // loop keeps no reduction and vectorizes): drive x force, damping work of the kicks
  double *term_fx, *term_done, *term_next;
  // each contact's first break at or after fb_mark (FixBKLayer::first_break_of), with
  // fb_track: set to fb_step, the step being taken
  double *fb;
  double fb_mark, fb_step;
  int fb_track;
  // contacts the rule left past the threshold (FixBKLayer::novershoot), counted here
  long overshoot;
  // Model::slab: sends the block's first and last rows of x and y to the neighbouring blocks
  // and posts the receives of their ghost rows (halo_start), then waits for them and fills
  // the ghost rows (halo_wait); the step computes the rows that need no ghost in between
  void (*halo_start)(void *ctx, const double *x, const double *y);
  void (*halo_wait)(void *ctx, double *x, double *y);
  void *halo_ctx;
};

/* Where the state is mirrored: LAMMPS's wrapped positions x = X - offset and velocities of
   local atom loc[k] (loc == nullptr: atom k is local atom k, whose z = z[k] is rewritten and
   v_z = 0); with `state`, the contact displacement and half-step velocity of
   FixBKLayer's per-atom array (columns col_dr, col_dr + 1 and col_vh, col_vh + 1).
   x == nullptr: no mirror. */
struct Mirror {
  double **x = nullptr, **v = nullptr;
  const int *loc = nullptr;
  const double *ox = nullptr, *oy = nullptr, *z = nullptr;
  double **state = nullptr;
  int col_dr = 2, col_vh = 4;
};

/* Advances `nsteps` model steps, the first being step n_first (the plate shift of step n is
   vd (e0 + (n - n0) dt0)), then mirrors. Returns the contact breaks; *last_breaks gets those
   of the last step. */
using RunFn = long (*)(const Model &, Arrays &, const Mirror &, int64_t n_first, int64_t nsteps,
                       long *last_breaks);
/* The forces of the stored state at step n without advancing the contact history (LAMMPS's
   setup()), damping with the velocity (ux, uy); mirrors. */
using SetupFn = void (*)(const Model &, Arrays &, const Mirror &, int64_t n, const double *ux,
                         const double *uy);

/* The contacts' phase sums (bk_model.h, BK_NPHASE values, added to sums) of the n
   contacts of drx, dry; inv_lim = k_e / (mu_s sigma_n A). The same bits in every build. */
using PhaseFn = void (*)(const double *drx, const double *dry, int n, double inv_lim,
                         double *sums);

/* The energies of the state, row by row (rows[4 r + j], r < m.Ly; j: bonds, drive springs at
   plate shift `shift`, contacts, |v|^2 without m/2), in LANES interleaved partial sums:
   vectorized, the same bits in every build. */
using EnergyFn = void (*)(const Model &, const Arrays &, double shift, double *rows);

struct Kernel {
  const char *isa;    // "avx512", "avx2" or "baseline"
  RunFn run;
  SetupFn setup;
  PhaseFn phase;
  EnergyFn energies;
};

/* The build for this CPU: "avx512" where the CPU has AVX-512F, else "avx2" where it has AVX2
   (each when the plugin was built with it), else "baseline" (x86-64 SSE2, or the compiler's
   default elsewhere). The environment variable BKFLOW_FUSED_ISA=baseline or =avx2 caps the
   choice, to test the other builds on a machine with more. Read at every call. */
Kernel select();

}    // namespace bkfused

#endif
