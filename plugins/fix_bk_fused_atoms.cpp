/* bkflow LAMMPS plugin: `fix bk/substrate ... fused` (fix_bk_fused.h) and LAMMPS's atoms: the
   map from the fix's lattice order to LAMMPS's local atoms (update_map), the state taken from
   them at a run's start (adopt_atoms) and given back to the per-atom array (sync_state), and
   the per-atom exact positions that travel with atoms between ranks and go into restart
   files. */

#include "fix_bk_fused.h"

#include "atom.h"
#include "domain.h"
#include "error.h"
#include "memory.h"

#include <algorithm>
#include <cmath>
#include <limits>

using namespace LAMMPS_NS;

namespace {
constexpr double NaN = std::numeric_limits<double>::quiet_NaN();
}    // namespace

/* local index and periodic offset of every lattice particle of this rank's rows: at every
   reneighbouring (atoms may be sorted, image flags change) and at every setup (commands
   between runs may have moved atoms). Every particle of the rows must be local here, and no
   other: on several ranks, a particle that strayed into another rank's sub-domain (half a row
   from its site) stops the run, on every rank at once. */

void FixBKFused::update_map()
{
  int stale = 0;    // the atom map names another atom: atoms moved without a map rebuild
  const tagint stray = std::min(map_rows(stale), first_foreign_atom());
  check_map(stray, stale);
  mirror_to.x = atom->x;
  mirror_to.v = atom->v;
  mirror_to.loc = identity ? nullptr : loc.data();
  mirror_to.ox = ox.data();
  mirror_to.oy = oy.data();
  mirror_to.z = z.data();
}

// maps the rows' particles; returns the lowest ID of theirs that is not local here
tagint FixBKFused::map_rows(int &stale)
{
  const imageint *const image = atom->image;
  const tagint first = static_cast<tagint>(blocks.row0) * Lx + 1;
  tagint stray = std::numeric_limits<tagint>::max();
  identity = true;
  double o[2];
  for (int k = 0; k < blocks.nloc; k++) {
    const int i = atom->map(first + k);
    if (i >= 0 && i < atom->nlocal && atom->tag[i] != first + k) stale = 1;
    if (i < 0 || i >= atom->nlocal || atom->tag[i] != first + k) {
      stray = std::min(stray, first + k);
      continue;
    }
    loc[k] = i;
    identity = identity && i == k;
    image_offset(image[i], o);
    ox[k] = o[0];
    oy[k] = o[1];
    z[k] = atom->x[i][2];
  }
  return stray;
}

// the lowest ID of the local atoms that are not of the rows, or the largest tagint
tagint FixBKFused::first_foreign_atom() const
{
  const tagint first = static_cast<tagint>(blocks.row0) * Lx + 1;
  tagint stray = std::numeric_limits<tagint>::max();
  if (atom->nlocal != blocks.nloc)
    for (int i = 0; i < atom->nlocal; i++)
      if (atom->tag[i] < first || atom->tag[i] >= first + blocks.nloc)
        stray = std::min(stray, atom->tag[i]);
  return stray;
}

// stops the run on every rank if any rank found a particle out of place (collective)
void FixBKFused::check_map(tagint stray, int stale)
{
  tagint all = stray;
  int any_stale = stale;
  if (blocks.slab()) {
    MPI_Allreduce(&stray, &all, 1, MPI_LMP_TAGINT, MPI_MIN, world);
    MPI_Allreduce(&stale, &any_stale, 1, MPI_INT, MPI_MAX, world);
  }
  // a run started with `pre no` after a command moved atoms between ranks (balance): LAMMPS
  // did not exchange them back, nor rebuild its map
  if (any_stale || (all != std::numeric_limits<tagint>::max() && unexchanged_start))
    error->all(FLERR,
               "{} fix bk/substrate fused: at the start of this run particle {} is not where "
               "the fix holds it (a command between runs moved atoms between ranks, e.g. "
               "`balance`, and `run ... pre no` skipped the exchange that puts them back): "
               "run with `pre yes`", BK_ERR_ATOM_LOST, all);
  blocks.report_stray(lmp, all);
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
  for (int k = 0; k < blocks.nloc; k++) {
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
    v[i][2] = 0.0;    // what fix enforce2d does
    atom->f[i][2] = 0.0;
  }
  have_state = true;
}

// the per-atom array (contact displacement, half-step velocity) and the exact positions
void FixBKFused::sync_state()
{
  for (int k = 0; k < blocks.nloc; k++) {
    double *s = state[loc[k]];
    s[DRX] = arr.drx[k];
    s[DRY] = arr.dry[k];
    s[VHX] = arr.vhx[k];
    s[VHY] = arr.vhy[k];
    xu[loc[k]][0] = arr.x[k];
    xu[loc[k]][1] = arr.y[k];
  }
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
  const tagint k = atom->tag[i] - 1 - static_cast<tagint>(blocks.row0) * Lx;
  if (lattice_ready && have_state && k >= 0 && k < blocks.nloc) {
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

/* atoms that change rank (only at the first setup of a run on several ranks, when the fix
   cuts the sub-domains between rows) take their exact position with them */

int FixBKFused::pack_exchange(int i, double *buf)
{
  int n = FixBKLayer::pack_exchange(i, buf);
  buf[n++] = xu[i][0];
  buf[n++] = xu[i][1];
  return n;
}

int FixBKFused::unpack_exchange(int nlocal, double *buf)
{
  int n = FixBKLayer::unpack_exchange(nlocal, buf);
  xu[nlocal][0] = buf[n++];
  xu[nlocal][1] = buf[n++];
  return n;
}

int FixBKFused::size_restart(int /*nlocal*/)
{
  return NRESTART + 1;
}

int FixBKFused::maxsize_restart()
{
  return NRESTART + 1;
}
