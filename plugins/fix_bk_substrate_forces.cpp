/* bkflow LAMMPS plugin: the forces of one step of fix bk/substrate on its general path
   (fix_bk_substrate.h; the equations in fix_bk_substrate.cpp's opening comment): the bonds over
   the bond list, then the drive, contact and damping forces of each local atom in a loop
   specialised for the parts the deck has (eval), so that it carries no branch on them. */

#include "fix_bk_substrate.h"

#include "atom.h"
#include "bk_dispatch.h"
#include "bk_model.h"
#include "update.h"

#include <array>
#include <cmath>
#include <utility>

using namespace LAMMPS_NS;

// the bond forces of this step; returns the largest squared bond length (local bonds)
double FixBKSubstrate::bond_forces()
{
  double *const *const x = atom->x;
  double *const *const f = atom->f;
  double r2max = 0.0;
  for (int b = 0; b < nblist; b++) {
    const int i = bl_i[b], j = bl_j[b];
    const double dx = x[i][0] - x[j][0] + bl_sx[b], dy = x[i][1] - x[j][1] + bl_sy[b];
    const double r2 = dx * dx + dy * dy;
    const double fb = bk_bond_factor(r2, kb, r0);
    f[i][0] += fb * dx;
    f[i][1] += fb * dy;
    if (bl_both[b]) {
      f[j][0] -= fb * dx;
      f[j][1] -= fb * dy;
    }
    if (r2 > r2max) r2max = r2;
  }
  return r2max;
}

namespace {

// what eval()'s loop reads of the fix and of the step, the same for every atom
struct EvalConst {
  double dt, ke, fmax, fmax2, ke2, lim2, gamma, dtf;
  double step_now, break_mark;
  int track_breaks;
  double *first_break;
};

// the sums of eval()'s loop over the atoms: the drive's x force, the breaks, the ledger's terms
struct EvalSums {
  double sfx = 0.0;
  bigint nb = 0, nover = 0;
  double lost = 0.0, kick_done = 0.0, kick_next = 0.0;
};

/* atom i's contact over a step: dr += v dt and, past the threshold, the contact rule, the
   break counted (its step recorded, its energy taken into the ledger) */
template <int CONTACT, int LEDGER>
__attribute__((always_inline)) inline void advance_contact(int i, double *s, double vx,
                                                           double vy, const EvalConst &c,
                                                           EvalSums &sum)
{
  using L = FixBKLayer;
  s[L::DRX] += vx * c.dt;
  s[L::DRY] += vy * c.dt;
  if (bk_contact_over(s[L::DRX], s[L::DRY], c.ke2, c.fmax2)) {
    sum.nb++;
    if (c.track_breaks && c.first_break[i] < c.break_mark) c.first_break[i] = c.step_now;
    const double bx = s[L::DRX], by = s[L::DRY];
    bk_contact_break(CONTACT, &s[L::DRX], &s[L::DRY], vx * c.dt, vy * c.dt, c.fmax, c.ke,
                     c.lim2);
    sum.nover += bk_contact_overshoot(CONTACT, s[L::DRX], s[L::DRY], c.ke2, c.fmax2);
    if constexpr (LEDGER) sum.lost += bk_break_loss(CONTACT, bx, by, s[L::DRX], s[L::DRY], c.ke);
  }
}

/* the damping force on an atom of mass m (taken off its other forces fx, fy; v and f its
   velocity and its force so far, the bonds'), with (vx, vy) the velocity it damps; with
   ADVANCE, that velocity kept as the half-step velocity of the step */
template <int DAMPING, int ADVANCE, int LEDGER>
__attribute__((always_inline)) inline void damp(double *s, double vx, double vy,
                                                const double *v, const double *f, double m,
                                                double &fx, double &fy, const EvalConst &c,
                                                EvalSums &sum)
{
  const double mg = m * c.gamma;
  const double h = 0.5 * c.dt / m, den = 1.0 / (1.0 + 0.5 * c.gamma * c.dt);
  const double gx = bk_damping(DAMPING, mg, vx, h, f[0] + fx, den);
  const double gy = bk_damping(DAMPING, mg, vy, h, f[1] + fy, den);
  fx -= gx;
  fy -= gy;
  if constexpr (LEDGER) {
    // the half kicks around this force: v -> v1 (a step: v the half-step velocity; setup:
    // none) and v1 -> v1 + hk F, the next step's first; v1 is the full-step velocity
    const double hk = c.dtf / m;
    const double Fx = f[0] + fx, Fy = f[1] + fy;
    const double v1x = ADVANCE ? bk_kick(v[0], hk, Fx) : v[0];
    const double v1y = ADVANCE ? bk_kick(v[1], hk, Fy) : v[1];
    if constexpr (ADVANCE) sum.kick_done += bk_kick_work(-gx, v[0], v1x)
        + bk_kick_work(-gy, v[1], v1y);
    sum.kick_next += bk_kick_work(-gx, v1x, bk_kick(v1x, hk, Fx))
        + bk_kick_work(-gy, v1y, bk_kick(v1y, hk, Fy));
  }
  if constexpr (ADVANCE) {
    s[FixBKLayer::VHX] = vx;
    s[FixBKLayer::VHY] = vy;
  }
}

}    // namespace

/* the drive, contact and damping forces of every local atom of the group, added to the bond
   forces in f; with ADVANCE (a step, not setup) the contacts advance and the half-step
   velocities are kept */

template <int DRIVE, int CONTACT, int DAMPING, int ADVANCE, int LEDGER>
void FixBKSubstrate::eval()
{
  double *const *const v = atom->v;
  double *const *const f = atom->f;
  const int *const mask = atom->mask;
  const int nlocal = atom->nlocal;
  const double *const kd = DRIVE ? atom->dvector[kd_index] : nullptr;
  const double *const rmass = atom->rmass;
  const double *const mass = atom->mass;
  const int *const type = atom->type;
  const double dt = update->dt;
  const double shift = plate_shift;
  const double fmax2 = fmax * fmax, ke2 = ke * ke, lim2 = fmax2 / ke2;
  const int use_vh = !ADVANCE && vh_valid;
  double *const *const uu = u;
  const EvalConst c{dt, ke, fmax, fmax2, ke2, lim2, gamma, dtf,
                    static_cast<double>(update->ntimestep), break_mark, track_breaks,
                    first_break};

  EvalSums sum;
  for (int i = 0; i < nlocal; i++) {
    if (!(mask[i] & groupbit)) continue;
    double *const s = state[i];
    double fx = 0.0, fy = 0.0;
    if constexpr (DRIVE) {
      const double fdx = bk_drive_x(kd[i], shift, uu[i][0]);
      fx += fdx;
      fy += bk_drive_y(kd[i], uu[i][1]);
      sum.sfx += fdx;
    }
    const double vx = use_vh ? s[VHX] : v[i][0];
    const double vy = use_vh ? s[VHY] : v[i][1];
    if constexpr (CONTACT != BK_NO_CONTACT) {
      if constexpr (ADVANCE) advance_contact<CONTACT, LEDGER>(i, s, vx, vy, c, sum);
      fx -= ke * s[DRX];
      fy -= ke * s[DRY];
    }
    if constexpr (DAMPING != BK_NO_DAMPING)
      damp<DAMPING, ADVANCE, LEDGER>(s, vx, vy, v[i], f[i], rmass ? rmass[i] : mass[type[i]],
                                     fx, fy, c, sum);
    f[i][0] += fx;
    f[i][1] += fy;
  }

  sum_fx_drive = sum.sfx;
  nbreak_step = sum.nb;
  nbreak_total += sum.nb;
  novershoot += sum.nover;
  if (ADVANCE && DAMPING != BK_NO_DAMPING) vh_valid = 1;
  if constexpr (LEDGER) {
    ledger_plate(sum.sfx, ADVANCE);
    ledger[BK_LED_BREAK] += sum.lost;
    ledger_damping(sum.kick_done, sum.kick_next, ADVANCE);
  }
}

namespace LAMMPS_NS {
// eval()'s specialisations for a step (ADVANCE 1) or for setup (ADVANCE 0), indexed by
// bk_dispatch (bk_dispatch.h)
struct BKSubstrateTable {
  using Eval = void (FixBKSubstrate::*)();

  template <int ADVANCE, int... I>
  static constexpr std::array<Eval, sizeof...(I)> make(std::integer_sequence<int, I...>)
  {
    return {{&FixBKSubstrate::eval<bk_dispatch_drive(I), bk_dispatch_contact(I),
                                   bk_dispatch_damping(I), ADVANCE, bk_dispatch_ledger(I)>...}};
  }
};
}    // namespace LAMMPS_NS

/* The forces of one step: the bonds over the bond list, then the drive, contact and damping
   forces of each local atom in one specialisation of eval() (one per combination of the parts
   that change its loop, so that the loop carries no branch on the parameters). The damping
   force reads f, so the bonds come first. advance = 0 (setup) applies the stored state. */

void FixBKSubstrate::apply_forces(int advance)
{
  constexpr auto all = std::make_integer_sequence<int, BK_NDISPATCH>{};
  static const std::array<std::array<BKSubstrateTable::Eval, BK_NDISPATCH>, 2> table = {
      {BKSubstrateTable::make<0>(all), BKSubstrateTable::make<1>(all)}};
  const double r2max = bonds_on ? bond_forces() : 0.0;
  (this->*table[advance ? 1 : 0][bk_dispatch(drive_on, contact, damping, ledger_on)])();
  energy_step = -1;
  rmax_local = sqrt(r2max);
  reduced = 0;
}
