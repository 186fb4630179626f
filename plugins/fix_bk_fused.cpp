/* bkflow LAMMPS plugin: `fix ID all bk/substrate ... fused`, the single-rank fast
   path of fix bk/substrate (fix_bk_fused.h, plugins/README.md "The fused path").

   The fix is fix bk/substrate (same style, same keywords, outputs and restart state, so that
   bk/stress, bk/slips and restart files work with either path) that also integrates: at
   initial_integrate it runs the whole step of fix nve + fix bk/substrate + fix enforce2d in the
   kernel of bk_fused_kernel.inc over arrays in lattice order, then mirrors the positions
   (x = X - periodic offset) and velocities into LAMMPS's arrays, so that neighbour checks,
   periodic wrapping, dumps, bk/stress and bk/slips see what they always did. The canonical
   state is the fix's: unwrapped positions X, velocities, forces, contact displacements and
   half-step velocities. LAMMPS's own force array is not used (it holds zeros).

   Lattice: atom ID k + 1 = 1 + ix + Lx iy, bonded to its four periodic neighbours (the data
   file of bkflow), found from the bond topology when the fix is first initialised. */

#include "fix_bk_fused.h"

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "force.h"
#include "memory.h"
#include "fix_bk_stress.h"
#include "modify.h"
#include "neighbor.h"
#include "output.h"
#include "update.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

using namespace LAMMPS_NS;
using namespace FixConst;

namespace {
constexpr double NaN = std::numeric_limits<double>::quiet_NaN();
}    // namespace

/* What must be true before FixBKLayer's constructor runs (an error after it, which registered
   callbacks with Atom, would leave them dangling): one rank, group all, the bonds. Returns
   narg. */
static int fused_args(LAMMPS *lmp, int narg, char **arg)
{
  if (lmp->comm->nprocs != 1)
    lmp->error->all(FLERR,
                    "fix bk/substrate fused runs on one MPI rank only (this run has {}): on "
                    "several ranks drop `fused` and integrate with fix nve and fix enforce2d",
                    lmp->comm->nprocs);
  if (narg < 3 || strcmp(arg[1], "all") != 0)
    lmp->error->all(FLERR, "fix bk/substrate fused acts on group all only");
  bool bonds = false;
  for (int i = 3; i < narg; i++) bonds = bonds || strcmp(arg[i], "bonds") == 0;
  if (!bonds)
    lmp->error->all(FLERR,
                    "fix bk/substrate fused needs the bonds (the lattice): add bonds k_b r0");
  return narg;
}

FixBKFused::FixBKFused(LAMMPS *lmp, int narg, char **arg) :
    FixBKLayer(lmp, fused_args(lmp, narg, arg), arg)
{
  time_integrate = 1;
  // the base's constructor called its own grow_arrays and set_arrays
  FixBKFused::grow_arrays(atom->nmax);
  for (int i = 0; i < atom->nlocal; i++) xu[i][0] = xu[i][1] = NaN;
}

FixBKFused::~FixBKFused()
{
  memory->destroy(xu);
}

int FixBKFused::setmask()
{
  return INITIAL_INTEGRATE | POST_NEIGHBOR | POST_RUN;
}

/* Everything else in the deck must leave the layer to this fix: no other integrator, no force
   from a pair or bond style or another fix (the fix never reads LAMMPS's force array). */

void FixBKFused::init()
{
  FixBKLayer::init();
  if (comm->nprocs != 1)
    error->all(FLERR, "fix bk/substrate fused runs on one MPI rank only (this run has {})",
               comm->nprocs);
  if (strncmp(update->integrate_style, "verlet", 6) != 0)
    error->all(FLERR, "fix bk/substrate fused needs run_style verlet");
  if (force->pair || force->bond || force->angle || force->dihedral || force->improper ||
      force->kspace)
    error->all(FLERR, "fix bk/substrate fused computes every force of the layer itself: "
                      "remove pair, bond, angle, dihedral, improper and kspace styles");
  constexpr int ACTS = INITIAL_INTEGRATE | POST_INTEGRATE | PRE_FORCE | POST_FORCE |
      FINAL_INTEGRATE;
  for (int i = 0; i < modify->nfix; i++) {
    Fix *f = modify->fix[i];
    if (f == this || strcmp(f->style, "enforce2d") == 0) continue;    // enforce2d: harmless
    if (f->time_integrate || (modify->fmask[i] & ACTS))
      error->all(FLERR,
                 "fix bk/substrate fused integrates the layer with all of its forces itself: "
                 "remove fix {} ({}) from the deck (fix nve and fix enforce2d are not needed)",
                 f->id, f->style);
  }
  if (atom->map_style == Atom::MAP_NONE)
    error->all(FLERR, "fix bk/substrate fused needs an atom map: atom_modify map array");
  if (lattice_ready && atom->natoms != N)
    error->all(FLERR, "fix bk/substrate fused: the number of atoms changed ({} -> {})", N,
               atom->natoms);
  if (!lattice_ready) build_lattice();
  const char *was = kernel.isa;
  kernel = bkfused::select();
  if (!was || strcmp(was, kernel.isa) != 0)
    utils::logmesg(lmp, "fix {} bk/substrate fused: {}x{} lattice, one rank, kernel {}\n", id,
                   Lx, Ly, kernel.isa);

  // who reads LAMMPS's positions, velocities or the per-atom array during a run (mirror_due)
  reader_every.clear();
  reneighboring.clear();
  for (int i = 0; i < modify->nfix; i++) {
    Fix *f = modify->fix[i];
    if (f == this) continue;
    if ((modify->fmask[i] & END_OF_STEP) && !dynamic_cast<FixBKStress *>(f))
      reader_every.push_back(f->nevery > 0 ? f->nevery : 1);
    if (f->force_reneighbor) reneighboring.push_back(f);
  }
}

/* LAMMPS's positions and velocities, and the per-atom array (contact displacement, half-step
   velocity), are written at the steps where something may read them: an output (thermo, dump,
   restart), the end_of_step of another fix (bk/slips, fix print, averages; not bk/stress, which
   reads only sigma_x), a neighbour-list check (which compares positions and then wraps them
   into the box), a reneighbouring a fix forces, and the last step of a run. Between them the
   fix's own arrays are the state; ghost atoms, which nothing uses, keep older positions. */

bool FixBKFused::mirror_due(bigint step) const
{
  if (step == update->laststep || step == output->next) return true;
  const int ago = neighbor->ago + 1;    // what Neighbor::decide() will count this step
  if (ago >= neighbor->delay && ago % neighbor->every == 0) return true;
  for (int every : reader_every)
    if (step % every == 0) return true;
  for (Fix *f : reneighboring)
    if (f->next_reneighbor == step) return true;
  return false;
}

/* The square lattice of bkflow: atom ID k + 1 = 1 + ix + Lx iy has exactly four bonds, to its
   periodic neighbours (ix +- 1, iy) and (ix, iy +- 1). Lx is the one divisor of N for which
   every atom's bond partners are these; Lx, Ly >= 3 (with 2 rows, the up and down neighbours
   coincide). */

static bool lattice_matches(LAMMPS *lmp, int n, int lx)
{
  Atom *atom = lmp->atom;
  const int ly = n / lx;
  for (int k = 0; k < n; k++) {
    const int i = atom->map(k + 1);
    if (atom->num_bond[i] != 4) return false;
    const int ix = k % lx, iy = k / lx;
    tagint want[4] = {(ix + 1) % lx + lx * iy + 1, (ix + lx - 1) % lx + lx * iy + 1,
                      ix + lx * ((iy + 1) % ly) + 1, ix + lx * ((iy + ly - 1) % ly) + 1};
    tagint got[4];
    for (int b = 0; b < 4; b++) got[b] = atom->bond_atom[i][b];
    std::sort(want, want + 4);
    std::sort(got, got + 4);
    if (!std::equal(want, want + 4, got)) return false;
  }
  return true;
}

/* The one lattice detector: Lx of the lattice the fused path can run, 0 when it cannot, with
   the reason in *why (the end of an error message): one rank holding atom IDs 1..N, an atom map, the bonds of bkflow's
   periodic square lattice, one positive mass. `integrate` takes the fused path exactly when
   this is not 0 (plugins/bkplugin.cpp); `fused` refuses a deck it is 0 for. */

int FixBKFused::fused_lattice(LAMMPS *lmp, std::string *why)
{
  Atom *atom = lmp->atom;
  auto no = [why](std::string reason) {
    if (why) *why = std::move(reason);
    return 0;
  };
  if (lmp->comm->nprocs != 1)
    return no(fmt::format(" runs on one MPI rank only (this run has {})", lmp->comm->nprocs));
  if (atom->map_style == Atom::MAP_NONE)
    return no(" needs an atom map: atom_modify map array");
  if (!atom->molecular || !atom->num_bond)
    return no(" needs the bonds (the lattice): add bonds k_b r0");
  if (atom->natoms > 2000000000 || atom->nlocal != atom->natoms)
    return no(fmt::format(": {} atoms, {} of them local", atom->natoms, atom->nlocal));
  const int n = static_cast<int>(atom->natoms);
  auto mass_of = [atom](int i) {
    return atom->rmass ? atom->rmass[i] : atom->mass ? atom->mass[atom->type[i]] : 0.0;
  };
  double m0 = 0.0;
  for (int k = 0; k < n; k++) {
    const int i = atom->map(k + 1);
    if (i < 0 || i >= atom->nlocal)
      return no(fmt::format(" needs atom IDs 1..{} (the lattice's), {} is missing", n, k + 1));
    if (k == 0) m0 = mass_of(i);
    if (mass_of(i) != m0)
      return no(fmt::format(" needs one mass for every atom ({} and {})", m0, mass_of(i)));
  }
  if (!(m0 > 0.0)) return no(": mass must be > 0");
  for (int lx = 3; lx <= n / 3; lx++)
    if (n % lx == 0 && lattice_matches(lmp, n, lx)) return lx;
  return no(": the bonds are not a periodic square lattice with atom ID 1 + ix + Lx iy bonded "
            "to its neighbours at ix +- 1 and iy +- 1 (Lx, Ly >= 3), which the fused path "
            "needs: drop `fused`");
}

void FixBKFused::build_lattice()
{
  std::string why;
  Lx = fused_lattice(lmp, &why);
  if (!Lx) error->all(FLERR, "fix bk/substrate fused{}", why);
  N = static_cast<int>(atom->natoms);
  Ly = N / Lx;
  mass = atom->rmass ? atom->rmass[atom->map(1)] : atom->mass[atom->type[atom->map(1)]];

  // every array in one pool, each 64-byte aligned and padded
  const size_t stride = (static_cast<size_t>(N) + 7) / 8 * 8;
  constexpr int NARR = 30;
  pool.assign(stride * NARR + 8, 0.0);
  double *p = pool.data();
  while (reinterpret_cast<uintptr_t>(p) % 64) p++;
  double *next = p;
  auto take = [&]() {
    double *q = next;
    next += stride;
    return q;
  };
  arr.x = take(), arr.y = take(), arr.vx = take(), arr.vy = take(), arr.fx = take();
  arr.fy = take(), arr.drx = take(), arr.dry = take(), arr.vhx = take(), arr.vhy = take();
  double *ax = take(), *ay = take(), *kd = take(), *srx = take(), *sry = take(), *sux = take();
  double *suy = take();
  arr.ax = ax, arr.ay = ay, arr.kd = kd, arr.srx = srx, arr.sry = sry, arr.sux = sux;
  arr.suy = suy;
  arr.brx = take(), arr.bry = take(), arr.blx = take(), arr.bly = take(), arr.bux = take();
  arr.buy = take(), arr.bdx = take(), arr.bdy = take(), arr.over = take();
  arr.fb = take();
  arr.term_fx = take(), arr.term_done = take(), arr.term_next = take();
  for (int k = 0; k < N; k++) arr.fb[k] = -1.0;

  loc.assign(N, 0);
  ox.assign(N, 0.0);
  oy.assign(N, 0.0);
  z.assign(N, 0.0);
  update_map();

  // constant: anchors, k_d, and each bond's periodic image, fixed from the anchors (the
  // lattice image bk/substrate keeps: bond vector minus relative displacement = lattice vector)
  const double *kdv = drive_on ? atom->dvector[kd_index] : nullptr;
  for (int k = 0; k < N; k++) {
    const int i = loc[k];
    ax[k] = state[i][AX];
    ay[k] = state[i][AY];
    kd[k] = kdv ? kdv[i] : 0.0;
  }
  const double xprd = domain->xprd, yprd = domain->yprd;
  auto image_shift = [](double d, double prd, int periodic) {
    return periodic ? bk_image_shift(d, prd) : 0.0;
  };
  for (int k = 0; k < N; k++) {
    const int ix = k % Lx, iy = k / Lx;
    const int r = (ix + 1) % Lx + Lx * iy, u = ix + Lx * ((iy + 1) % Ly);
    srx[k] = image_shift(ax[k] - ax[r], xprd, domain->xperiodic);
    sry[k] = image_shift(ay[k] - ay[r], yprd, domain->yperiodic);
    sux[k] = image_shift(ax[k] - ax[u], xprd, domain->xperiodic);
    suy[k] = image_shift(ay[k] - ay[u], yprd, domain->yperiodic);
  }
  lattice_ready = true;
  have_state = false;
}

/* local index and periodic offset of every lattice particle: at every reneighbouring (atoms
   may be sorted, image flags change) and at every setup (commands between runs may have moved
   atoms) */

void FixBKFused::update_map()
{
  static constexpr double origin[3] = {0.0, 0.0, 0.0};
  const imageint *const image = atom->image;
  identity = true;
  double o[3];
  for (int k = 0; k < N; k++) {
    const int i = atom->map(k + 1);
    if (i < 0 || i >= atom->nlocal)
      error->one(FLERR, "{} fix bk/substrate fused: atom {} is not local", BK_ERR_ATOM_LOST,
                 k + 1);
    loc[k] = i;
    identity = identity && i == k;
    domain->unmap(origin, image[i], o);
    ox[k] = o[0];
    oy[k] = o[1];
    z[k] = atom->x[i][2];
  }
  mirror_to.x = atom->x;
  mirror_to.v = atom->v;
  mirror_to.loc = identity ? nullptr : loc.data();
  mirror_to.ox = ox.data();
  mirror_to.oy = oy.data();
  mirror_to.z = z.data();
}

void FixBKFused::setup_post_neighbor()
{
  post_neighbor();
}

void FixBKFused::post_neighbor()
{
  if (lattice_ready) update_map();
}

/* Take from LAMMPS what changed since the last step: at the first setup everything (positions,
   velocities, and the per-atom state: anchors, contact history, half-step velocities, which
   read_restart or `start` may have set); later, positions and velocities that a command
   (displace_atoms, velocity, set, ...) changed. A position counts as changed when it differs
   from the fix's by more than the rounding of a periodic wrap (16 ulp of |X| + L). */

void FixBKFused::adopt_atoms()
{
  double *const *const x = atom->x;
  double *const *const v = atom->v;
  const double L = domain->xprd + domain->yprd;
  constexpr double TOL = 16 * std::numeric_limits<double>::epsilon();
  for (int k = 0; k < N; k++) {
    const int i = loc[k];
    const double xa = x[i][0] + ox[k], ya = x[i][1] + oy[k];
    double X, Y;
    if (have_state) {
      X = arr.x[k], Y = arr.y[k];
    } else {
      X = xu[i][0], Y = xu[i][1];    // a restart file's exact positions, or NaN
      arr.drx[k] = state[i][DRX];
      arr.dry[k] = state[i][DRY];
      arr.vhx[k] = state[i][VHX];
      arr.vhy[k] = state[i][VHY];
    }
    const double tol = TOL * (std::fabs(xa) + std::fabs(ya) + L);
    if (!(std::fabs(X - xa) <= tol && std::fabs(Y - ya) <= tol)) X = xa, Y = ya;
    arr.x[k] = X;
    arr.y[k] = Y;
    if (!have_state || v[i][0] != arr.vx[k] || v[i][1] != arr.vy[k]) {
      arr.vx[k] = v[i][0];
      arr.vy[k] = v[i][1];
    }
    v[i][2] = 0.0;    // what fix enforce2d did
    atom->f[i][2] = 0.0;
  }
  have_state = true;
}

void FixBKFused::set_model()
{
  bkfused::Model &m = model;
  const double dt = update->dt;
  m.Lx = Lx, m.Ly = Ly, m.N = N;
  m.drive = drive_on, m.contact = contact, m.damping = damping, m.ledger = ledger_on;
  m.dt = dt;
  m.mass = mass;
  m.hv = 0.5 * update->dt * force->ftm2v / mass;    // fix nve: dtf / mass
  m.hd = 0.5 * dt / mass;
  m.mg = mass * gamma;
  m.den = 1.0 / (1.0 + 0.5 * gamma * dt);
  m.kb = kb, m.r0 = r0;
  m.ke = ke, m.fmax = fmax, m.fmax2 = fmax * fmax, m.ke2 = ke * ke;
  m.lim2 = contact != BK_NO_CONTACT ? m.fmax2 / m.ke2 : 0.0;
  m.vd = vd;
  plate_now();    // rebases the plate's clock if the time step changed
  m.e0 = elapsed_base, m.n0 = step_base, m.dt0 = dt_base;
}

/* setup (start of every run): the forces of the stored state, without advancing the contact
   history, damping with the half-step velocity of the last step (as fix bk/substrate), so that
   a run in chunks, or continued from a restart file, follows one long run bit for bit */

void FixBKFused::setup(int /*vflag*/)
{
  update_map();
  adopt_atoms();
  set_model();
  plate_shift = plate_now();
  const int use_vh = vh_valid && damping != BK_NO_DAMPING;
  mirror_to.x = atom->x;
  mirror_to.v = atom->v;
  mirror_to.state = nullptr;
  for (int k = 0; k < BK_NLEDGER; k++) arr.led[k] = ledger[k];    // a restart's sums, or ours
  kernel.setup(model, arr, mirror_to, update->ntimestep, use_vh ? arr.vhx : arr.vx,
               use_vh ? arr.vhy : arr.vy);
  nbreak_step = 0;
  energy_step = -1;
  sigma_step = rmax_step = -1;
  sync_state();
}

void FixBKFused::initial_integrate(int /*vflag*/)
{
  const bigint n = update->ntimestep;
  plate_shift = plate_now();
  model.e0 = elapsed_base, model.n0 = step_base, model.dt0 = dt_base;
  const bool due = mirror_due(n);
  mirror_to.x = due ? atom->x : nullptr;
  mirror_to.v = atom->v;
  mirror_to.state = due ? state : nullptr;
  long last = 0;
  arr.fb_track = track_breaks;
  arr.fb_mark = break_mark;
  const long nb = kernel.run(model, arr, mirror_to, n, 1, &last);
  nbreak_step = last;
  nbreak_total += nb;
  if (damping != BK_NO_DAMPING) vh_valid = 1;
  if (ledger_on)
    for (int k = 0; k < BK_NLEDGER; k++) ledger[k] = arr.led[k];
  sigma_step = rmax_step = energy_step = -1;
}

void FixBKFused::post_run()
{
  sync_state();
}

// the per-atom array (contact displacement, half-step velocity) and the exact positions
void FixBKFused::sync_state()
{
  for (int k = 0; k < N; k++) {
    double *s = state[loc[k]];
    s[DRX] = arr.drx[k];
    s[DRY] = arr.dry[k];
    s[VHX] = arr.vhx[k];
    s[VHY] = arr.vhy[k];
    xu[loc[k]][0] = arr.x[k];
    xu[loc[k]][1] = arr.y[k];
  }
}

/* sigma_x = sum_k k_d^k (plate shift - (X_k - anchor_k)) / (Lx Ly), in lattice order, from
   the positions of the step, computed once per step when first asked (bk/stress, thermo) */

double FixBKFused::sigma_x()
{
  const bigint step = update->ntimestep;
  if (sigma_step != step) {
    const double shift = plate_shift;
    double s = 0.0;
    for (int k = 0; k < N; k++) s += bk_drive_x(arr.kd[k], shift, arr.x[k] - arr.ax[k]);
    sigma_value = s / (domain->xprd * domain->yprd);
    sigma_step = step;
  }
  return sigma_value;
}

/* the squared lengths of particle k's +x and +y bonds (at their fixed lattice images) */
void FixBKFused::bond_r2(int k, double &rx2, double &uy2) const
{
  const int ix = k % Lx, iy = k / Lx;
  const int r = (ix + 1) % Lx + Lx * iy, u = ix + Lx * ((iy + 1) % Ly);
  const double dx = arr.x[k] - arr.x[r] + arr.srx[k], dy = arr.y[k] - arr.y[r] + arr.sry[k];
  const double ex = arr.x[k] - arr.x[u] + arr.sux[k], ey = arr.y[k] - arr.y[u] + arr.suy[k];
  rx2 = dx * dx + dy * dy;
  uy2 = ex * ex + ey * ey;
}

double FixBKFused::longest_bond()
{
  const bigint step = update->ntimestep;
  if (rmax_step != step) {
    double r2max = 0.0;
    for (int k = 0; k < N; k++) {
      double a, b;
      bond_r2(k, a, b);
      r2max = std::max(r2max, std::max(a, b));
    }
    rmax_value = sqrt(r2max);
    rmax_step = step;
  }
  return rmax_value;
}

void FixBKFused::clear_first_breaks()
{
  FixBKLayer::clear_first_breaks();
  if (lattice_ready)
    for (int k = 0; k < N; k++) arr.fb[k] = -1.0;
}

double FixBKFused::first_break_of(int i) const
{
  if (!lattice_ready) return FixBKLayer::first_break_of(i);
  const double b = arr.fb[atom->tag[i] - 1];
  return b >= break_mark ? b : -1.0;
}

int FixBKFused::path_code() const
{
  return strcmp(kernel.isa, "avx512") == 0 ? BK_PATH_FUSED_AVX512
      : strcmp(kernel.isa, "avx2") == 0    ? BK_PATH_FUSED_AVX2
                                           : BK_PATH_FUSED_BASELINE;
}

// the contacts' phase sums from the fix's own arrays, in lattice order
void FixBKFused::contact_phase(double *sums)
{
  if (!lattice_ready || !have_state) return FixBKLayer::contact_phase(sums);
  double local[BK_NPHASE] = {};
  if (contact != BK_NO_CONTACT) kernel.phase(arr.drx, arr.dry, N, ke / fmax, local);
  MPI_Allreduce(local, sums, BK_NPHASE, MPI_DOUBLE, MPI_SUM, world);
}

/* the energies of the current step from the fix's own arrays (the kernel's, vectorized):
   bonds, drive springs, contacts, kinetic (the full-step velocities) */
void FixBKFused::local_energies(double *e)
{
  e[0] = e[1] = e[2] = e[3] = 0.0;
  if (!lattice_ready || !have_state) return;
  kernel.energies(model, arr, plate_shift, e);
  e[3] *= force->mvv2e;    // energy units, as the kicks' ftm2v (1 in lj units)
}

// the bond energy sum k_b/2 (r - r0)^2
double FixBKFused::compute_scalar()
{
  if (!lattice_ready || !have_state) return 0.0;    // before the first setup: no state yet
  double e = 0.0;
  for (int k = 0; k < N; k++) {
    double a, b;
    bond_r2(k, a, b);
    e += bk_bond_energy(a, kb, r0) + bk_bond_energy(b, kb, r0);
  }
  return e;
}

double FixBKFused::memory_usage()
{
  return FixBKLayer::memory_usage() + static_cast<double>(atom->nmax) * 2 * sizeof(double) +
      static_cast<double>(pool.size()) * sizeof(double) +
      static_cast<double>(loc.size()) * (sizeof(int) + 3 * sizeof(double));
}

void FixBKFused::grow_arrays(int nmax)
{
  FixBKLayer::grow_arrays(nmax);
  memory->grow(xu, nmax, 2, "bk/substrate:xu");
}

void FixBKFused::copy_arrays(int i, int j, int delflag)
{
  FixBKLayer::copy_arrays(i, j, delflag);
  xu[j][0] = xu[i][0];
  xu[j][1] = xu[i][1];
}

// a new atom: as FixBKLayer's, its exact position unknown (x + offset is used)
void FixBKFused::set_arrays(int i)
{
  FixBKLayer::set_arrays(i);
  xu[i][0] = xu[i][1] = NaN;
}

/* restart files: FixBKLayer's columns, then the exact unwrapped position (which x and the
   image flags give only to rounding), so that a continued run follows the uninterrupted one
   bit for bit. The count in buf[0] lets fix bk/substrate read a fused restart (it reads its
   own columns and skips these) and the fused path read a bk/substrate one (no exact position:
   x + offset). */

int FixBKFused::pack_restart(int i, double *buf)
{
  buf[0] = NRESTART + 1;
  for (int c = 0; c < NSTATE; c++) buf[c + 1] = state[i][c];
  buf[XU + 1] = xu[i][0];
  buf[YU + 1] = xu[i][1];
  if (lattice_ready && have_state) {
    const int k = static_cast<int>(atom->tag[i]) - 1;
    buf[DRX + 1] = arr.drx[k];
    buf[DRY + 1] = arr.dry[k];
    buf[VHX + 1] = arr.vhx[k];
    buf[VHY + 1] = arr.vhy[k];
    buf[XU + 1] = arr.x[k];
    buf[YU + 1] = arr.y[k];
  }
  return NRESTART + 1;
}

void FixBKFused::unpack_restart(int nlocal, int nth)
{
  double **extra = atom->extra;
  int m = 0;
  for (int i = 0; i < nth; i++) m += static_cast<int>(extra[nlocal][m]);
  const int count = static_cast<int>(extra[nlocal][m++]);
  for (int c = 0; c < NSTATE; c++) state[nlocal][c] = extra[nlocal][m++];
  first_break[nlocal] = -1.0;
  if (count >= NRESTART + 1) {
    xu[nlocal][0] = extra[nlocal][m++];
    xu[nlocal][1] = extra[nlocal][m++];
  } else {
    xu[nlocal][0] = xu[nlocal][1] = NaN;
  }
}

int FixBKFused::size_restart(int /*nlocal*/)
{
  return NRESTART + 1;
}

int FixBKFused::maxsize_restart()
{
  return NRESTART + 1;
}
