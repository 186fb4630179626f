/* bkflow LAMMPS plugin: fix bk/substrate. One post-force pass over local atoms applies, per
   atom i,
     bonds     F = -k_b (r_ij - r0) d_ij / r_ij over the atom's bonds (topology of the data
               file, newton_bond off so every atom holds all of its bonds). The bond vector
               keeps the periodic image of the lattice: d_ij = x_i - x_j - L m with m chosen so
               that d_ij - (u_i - u_j) is the lattice vector, u = r(t) - r(t0). Unlike the
               minimum image of bond_style harmonic, this holds for any stretch.
     drive     F = k_d^i (anchor_i(t) - r_i),  anchor_i(t) = r_i(t0) + V_d (t - t0) x_hat
     friction  dr_i += v_i dt;  F = -k_e dr_i;  break when |k_e dr_i| > mu_s sigma_n A
               (reset: the contact breaks where |k_e dr_i| crosses the threshold inside the
               step, at the fraction th of v_i dt, and re-forms there: dr_i = (1 - th) v_i dt;
               reset/step: dr_i = 0 at the end of the step, first order in dt;
               coulomb: dr_i rescaled onto the threshold). dr_i starts at (0, 0), or with
               `start` at (value_i, 0), value_i a per-atom property.
     damping   F = -m gamma v_i, v_i the end-of-step velocity v_i(t+dt) = vh_i + dt/(2m) F_i
               solved with this force in it (implicit, second order; "half": the half-step
               velocity vh_i, first order)
   with v_i the half-step velocity that fix nve leaves before post_force, and r_i unwrapped.
   The equations are those of docs/model.md; plugins/README.md documents the syntax. */

#include "fix_bk_substrate.h"

#include "atom.h"
#include "bk_model.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "force.h"
#include "memory.h"
#include "update.h"

using namespace LAMMPS_NS;
using namespace FixConst;

FixBKSubstrate::FixBKSubstrate(LAMMPS *lmp, int narg, char **arg) : FixBKLayer(lmp, narg, arg)
{
  comm_forward = 2;    // the displacements u of ghosts, for the bond list
}

FixBKSubstrate::~FixBKSubstrate()
{
  memory->destroy(u);
  memory->destroy(offset);
  memory->destroy(bl_i);
  memory->destroy(bl_j);
  memory->destroy(bl_both);
  memory->destroy(bl_sx);
  memory->destroy(bl_sy);
}

int FixBKSubstrate::setmask()
{
  return POST_FORCE | POST_NEIGHBOR | (integrate ? INITIAL_INTEGRATE | FINAL_INTEGRATE : 0);
}

void FixBKSubstrate::init()
{
  FixBKLayer::init();
  reset_dt();    // the kicks of `integrate`, and the ledger's (fix nve's step sizes)
}

void FixBKSubstrate::reset_dt()
{
  dtv = update->dt;
  dtf = 0.5 * update->dt * force->ftm2v;
}

/* `integrate`: the general path integrates by itself, with the very operations of fix nve
   (velocity Verlet, 3 components, per-atom or per-type mass) and of fix enforce2d (v_z = f_z
   = 0 after the forces, see post_force), so that it follows the deck fix nve + fix
   bk/substrate + fix enforce2d bit for bit, on any number of ranks. */

// v += dt/(2m) f, then with `drift` x += dt v: fix nve's two halves, operation for operation
template <bool DRIFT> void FixBKSubstrate::nve_step()
{
  double **x = atom->x, **v = atom->v, **f = atom->f;
  const double *rmass = atom->rmass, *mass = atom->mass;
  const int *type = atom->type, *mask = atom->mask;
  const int nlocal = atom->nlocal;
  for (int i = 0; i < nlocal; i++) {
    if (!(mask[i] & groupbit)) continue;
    const double dtfm = dtf / (rmass ? rmass[i] : mass[type[i]]);
    for (int d = 0; d < 3; d++) v[i][d] = bk_kick(v[i][d], dtfm, f[i][d]);
    if constexpr (DRIFT)
      for (int d = 0; d < 3; d++) x[i][d] = bk_drift(x[i][d], dtv, v[i][d]);
  }
}

void FixBKSubstrate::initial_integrate(int /*vflag*/)
{
  nve_step<true>();
}

void FixBKSubstrate::final_integrate()
{
  nve_step<false>();
}

// fix enforce2d's post_force, for `integrate`
void FixBKSubstrate::enforce2d()
{
  double **v = atom->v, **f = atom->f;
  const int *mask = atom->mask;
  const int nlocal = atom->nlocal;
  for (int i = 0; i < nlocal; i++)
    if (mask[i] & groupbit) v[i][2] = f[i][2] = 0.0;
}

/* setup() applies the forces of the current state without advancing the contact history.
   Damping uses the half-step velocity stored by the last post_force, so that a run split into
   chunks, or continued from a restart file, follows the same trajectory as one long run. */

void FixBKSubstrate::setup(int /*vflag*/)
{
  plate_shift = plate_now();
  update_displacements(0);
  apply_forces(0);
  if (integrate) enforce2d();
}

void FixBKSubstrate::post_force(int /*vflag*/)
{
  plate_shift = plate_now();
  update_displacements(0);
  apply_forces(1);
  if (integrate) enforce2d();
}

void FixBKSubstrate::setup_post_neighbor()
{
  post_neighbor();
}

void FixBKSubstrate::post_neighbor()
{
  rebase_images();
  if (drive_on || bonds_on) update_offsets();
  if (bonds_on) build_bond_list();
}

/* Positions jump by a box length, and atoms change rank or local index, only at
   reneighbouring; between two, the periodic shift of each bond is constant. It is the one that
   makes the bond vector minus the relative displacement u_i - u_j the lattice vector, which is
   unambiguous however far the bond is stretched. */

void FixBKSubstrate::build_bond_list()
{
  update_displacements(1);
  double *const *const x = atom->x;
  const int *const mask = atom->mask;
  const int nlocal = atom->nlocal;
  const double xprd = domain->xprd, yprd = domain->yprd;
  int need = 0;
  for (int i = 0; i < nlocal; i++) need += atom->num_bond[i];
  if (need > maxblist) {
    maxblist = need;
    memory->grow(bl_i, maxblist, "bk/substrate:bl_i");
    memory->grow(bl_j, maxblist, "bk/substrate:bl_j");
    memory->grow(bl_both, maxblist, "bk/substrate:bl_both");
    memory->grow(bl_sx, maxblist, "bk/substrate:bl_sx");
    memory->grow(bl_sy, maxblist, "bk/substrate:bl_sy");
  }
  nblist = 0;
  for (int i = 0; i < nlocal; i++) {
    if (!(mask[i] & groupbit)) continue;
    for (int k = 0; k < atom->num_bond[i]; k++) {
      const int j = atom->map(atom->bond_atom[i][k]);
      if (j < 0)
        error->one(FLERR,
                   "{} fix bk/substrate: bond partner {} of atom {} missing on this rank; "
                   "increase comm_modify cutoff",
                   BK_ERR_PARTNER_MISSING, atom->bond_atom[i][k], atom->tag[i]);
      const int both = j < nlocal && (mask[j] & groupbit);
      if (both && j < i) continue;    // the same bond, listed by j with i as partner
      const double wx = x[i][0] - x[j][0], wy = x[i][1] - x[j][1];
      bl_i[nblist] = i;
      bl_j[nblist] = j;
      bl_both[nblist] = both;
      bl_sx[nblist] = bk_image_shift(wx - (u[i][0] - u[j][0]), xprd);
      bl_sy[nblist] = bk_image_shift(wy - (u[i][1] - u[j][1]), yprd);
      nblist++;
    }
  }
}

void FixBKSubstrate::grow_displacements()
{
  if (atom->nmax <= nmax_u) return;
  nmax_u = atom->nmax;
  memory->grow(u, nmax_u, 2, "bk/substrate:u");
  memory->grow(offset, nmax_u, 2, "bk/substrate:offset");
}

/* The unwrapped position of a local atom is x + offset, offset = (ix Lx, iy Ly) from its image
   flags. LAMMPS changes image flags only where it wraps atoms back into the box, at
   reneighbouring (the invariant the bond list rests on too), so the offsets are taken then,
   exactly as Domain::unmap() adds them (the unmap of the origin), and serve every step until
   the next: one unmap call per atom per reneighbouring instead of per step. */

void FixBKSubstrate::update_offsets()
{
  grow_displacements();
  const imageint *const image = atom->image;
  const int nlocal = atom->nlocal;
  double o[2];
  for (int i = 0; i < nlocal; i++) {
    image_offset(image[i], o);
    offset[i][0] = o[0];
    offset[i][1] = o[1];
  }
}

// u = r(t) - r(t0) of local atoms; with ghosts, ghosts get theirs by forward communication
void FixBKSubstrate::update_displacements(int ghosts)
{
  // the drive reads u every step; the bonds only when their list is rebuilt
  if (!drive_on && !(ghosts && bonds_on)) return;
  grow_displacements();
  double *const *const x = atom->x;
  const int nlocal = atom->nlocal;
  for (int i = 0; i < nlocal; i++) {
    u[i][0] = x[i][0] + offset[i][0] - state[i][AX];
    u[i][1] = x[i][1] + offset[i][1] - state[i][AY];
  }
  if (ghosts && comm->nprocs > 1) comm->forward_comm(this);
}

int FixBKSubstrate::pack_forward_comm(int n, int *list, double *buf, int /*pbc_flag*/,
                                      int * /*pbc*/)
{
  int m = 0;
  for (int k = 0; k < n; k++) {
    buf[m++] = u[list[k]][0];
    buf[m++] = u[list[k]][1];
  }
  return m;
}

void FixBKSubstrate::unpack_forward_comm(int n, int first, double *buf)
{
  int m = 0;
  for (int i = first; i < first + n; i++) {
    u[i][0] = buf[m++];
    u[i][1] = buf[m++];
  }
}

/* scalar: the bond energy sum k_b/2 (r - r0)^2 (each bond is held by both its atoms) */

double FixBKSubstrate::compute_scalar()
{
  double e = 0.0;
  if (bonds_on) {
    double *const *const x = atom->x;
    for (int b = 0; b < nblist; b++) {
      const int i = bl_i[b], j = bl_j[b];
      const double dx = x[i][0] - x[j][0] + bl_sx[b], dy = x[i][1] - x[j][1] + bl_sy[b];
      // a bond held by an atom of another rank too counts half here
      e += (bl_both[b] ? 1.0 : 0.5) * bk_bond_energy(dx * dx + dy * dy, kb, r0);
    }
  }
  double all = 0.0;
  MPI_Allreduce(&e, &all, 1, MPI_DOUBLE, MPI_SUM, world);
  return all;
}

/* this rank's energies of the current step: bonds (as compute_scalar), drive springs (from
   the displacements of this step's forces), contacts, kinetic (the full-step velocities) */

void FixBKSubstrate::local_energies(double *e)
{
  e[0] = e[1] = e[2] = e[3] = 0.0;
  double *const *const x = atom->x;
  double *const *const v = atom->v;
  const int *const mask = atom->mask;
  const int nlocal = atom->nlocal;
  if (bonds_on)
    for (int b = 0; b < nblist; b++) {
      const int i = bl_i[b], j = bl_j[b];
      const double dx = x[i][0] - x[j][0] + bl_sx[b], dy = x[i][1] - x[j][1] + bl_sy[b];
      e[0] += (bl_both[b] ? 1.0 : 0.5) * bk_bond_energy(dx * dx + dy * dy, kb, r0);
    }
  const double *const kd = drive_on ? atom->dvector[kd_index] : nullptr;
  const double *const rmass = atom->rmass;
  const double *const mass = atom->mass;
  for (int i = 0; i < nlocal; i++) {
    if (!(mask[i] & groupbit)) continue;
    if (kd) {
      const double ux = u[i][0] - plate_shift, uy = u[i][1];
      e[1] += 0.5 * kd[i] * (ux * ux + uy * uy);
    }
    if (contact != BK_NO_CONTACT)
      e[2] += 0.5 * ke * (state[i][DRX] * state[i][DRX] + state[i][DRY] * state[i][DRY]);
    const double m = rmass ? rmass[i] : mass ? mass[atom->type[i]] : 0.0;
    e[3] += 0.5 * m * (v[i][0] * v[i][0] + v[i][1] * v[i][1]);
  }
  e[3] *= force->mvv2e;    // energy units, as the kicks' ftm2v (1 in lj units)
}

/* the output vector's slots computed here: the drive's force and the breaks summed over
   ranks once per step (lazily, when first asked), the longest bond's maximum */

void FixBKSubstrate::reduce()
{
  if (reduced) return;
  double local[3] = {sum_fx_drive, static_cast<double>(nbreak_step),
                     static_cast<double>(nbreak_total)};
  MPI_Allreduce(local, reduced_vec, 3, MPI_DOUBLE, MPI_SUM, world);
  reduced = 1;
}

double FixBKSubstrate::sigma_x()
{
  reduce();
  return reduced_vec[0] / (domain->xprd * domain->yprd);
}

double FixBKSubstrate::breaks(bool total)
{
  reduce();
  return reduced_vec[total ? 2 : 1];
}

double FixBKSubstrate::longest_bond()
{
  double rmax = 0.0;
  MPI_Allreduce(&rmax_local, &rmax, 1, MPI_DOUBLE, MPI_MAX, world);
  return rmax;
}

// the base's per-atom state, and here the displacements u and offsets and the bond list
double FixBKSubstrate::memory_usage()
{
  double bytes = FixBKLayer::memory_usage();
  bytes += static_cast<double>(nmax_u) * 4 * sizeof(double);
  bytes += static_cast<double>(maxblist) * (3 * sizeof(int) + 2 * sizeof(double));
  return bytes;
}
