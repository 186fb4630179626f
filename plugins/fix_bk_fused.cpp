/* bkflow LAMMPS plugin: `fix ID all bk/substrate ... fused`, the fast path of fix
   bk/substrate on any number of ranks (fix_bk_fused.h, plugins/README.md "The fused path").

   The fix is fix bk/substrate (same style, same keywords, outputs and restart state, so that
   bk/stress, bk/slips and restart files work with either path) that also integrates: at
   initial_integrate it runs the whole step of fix nve + fix bk/substrate + fix enforce2d in the
   kernel of bk_fused_kernel.inc over arrays in lattice order, then mirrors the positions
   (x = X - periodic offset) and velocities into LAMMPS's arrays, so that neighbour checks,
   periodic wrapping, dumps, bk/stress and bk/slips see what a fix nve deck gives them. The
   canonical state is the fix's: unwrapped positions X, velocities, forces, contact
   displacements and half-step velocities. LAMMPS's own force array is not used (it holds
   zeros).

   Lattice: atom ID k + 1 = 1 + ix + Lx iy, bonded to its four periodic neighbours (the data
   file of bkflow), found from the bond topology when the fix is first initialised
   (bk_lattice_detect.h).

   Ranks: K ranks in a column (`processors 1 * 1`) hold K blocks of whole rows; the fix cuts
   LAMMPS's sub-domains between rows (a non-uniform brick layout, as `balance` sets) before the
   first exchange, so that LAMMPS's local atoms are the rank's rows, and every step trades the
   block's first and last rows with the neighbouring ranks (bk_row_blocks.h). Atoms never
   migrate: a particle that strays half a row from its site into another rank's sub-domain
   stops the run (update_map). Each particle's arithmetic does not depend on the blocks, so any
   number of ranks gives the same bits; the sums of the outputs are made the same way
   (BKRowBlocks::row_totals). */

#include "fix_bk_fused.h"

#include "atom.h"
#include "bk_lattice_detect.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "force.h"
#include "memory.h"
#include "update.h"

#include <cstring>
#include <limits>

using namespace LAMMPS_NS;
using namespace FixConst;

namespace {
constexpr double NaN = std::numeric_limits<double>::quiet_NaN();
}    // namespace

/* What must be true before FixBKLayer's constructor runs (an error after it, which registered
   callbacks with Atom, would leave them dangling): group all, the bonds. Returns narg. */
static int fused_args(LAMMPS *lmp, int narg, char **arg)
{
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
  for (int i = 3; i < narg; i++) chosen = chosen || strcmp(arg[i], "integrate") == 0;
  maxexchange = NSTATE + 1 + 2;    // pack_exchange: the base's, then the exact position
  // the base's constructor called its own grow_arrays and set_arrays
  FixBKFused::grow_arrays(atom->nmax);
  for (int i = 0; i < atom->nlocal; i++) xu[i][0] = xu[i][1] = NaN;
}

FixBKFused::~FixBKFused()
{
  memory->destroy(xu);
  bk_fused_deck::restore_ghost_cutoff(comm, cutoff_replaced);
}

int FixBKFused::setmask()
{
  return INITIAL_INTEGRATE | PRE_EXCHANGE | POST_NEIGHBOR | POST_RUN;
}

/* Everything else in the deck must leave the layer to this fix (bk_fused_deck.h); the fix
   then finds its lattice (once), picks its kernel, and sets the deck's ghost cutoff and, on
   several ranks, its check of lost bonds; and it learns who reads the atom arrays. */

void FixBKFused::init()
{
  FixBKLayer::init();
  bk_fused_deck::check(lmp, this);
  if (lattice_ready && atom->natoms != N)
    error->all(FLERR, "fix bk/substrate fused: the number of atoms changed ({} -> {})", N,
               atom->natoms);
  if (!Lx) find_lattice();
  select_kernel();
  const double replaced = bk_fused_deck::lower_ghost_cutoff(lmp, id);
  if (replaced >= 0.0) cutoff_replaced = replaced;
  if (blocks.slab()) bk_fused_deck::ignore_lost_bonds(lmp, id);
  mirror_schedule.find_readers(lmp, this);
}

// the lattice, its mass and this rank's block of rows
void FixBKFused::find_lattice()
{
  std::string why;
  Lx = bk_fused_lattice(lmp, &why);
  // with `integrate` the layer passed this test when the fix was made (bkplugin.cpp): it
  // changed (moved) before the first run, and the path is fixed from then on (a fix defined
  // after the move would be another run: the fix keeps the layer's positions at its
  // definition)
  if (!Lx)
    error->all(FLERR, "fix bk/substrate fused{}{}", why,
               chosen ? "; `integrate` chose the fused path when the fix was defined, and the "
                        "layer changed before its first run: for this layer on several ranks "
                        "use the general path, the same trajectory (drop `integrate`, add fix "
                        "nve and fix enforce2d), or run it on one rank" : "");
  N = static_cast<int>(atom->natoms);
  Ly = N / Lx;
  double m = atom->nlocal ? (atom->rmass ? atom->rmass[0] : atom->mass[atom->type[0]]) : 0.0;
  MPI_Allreduce(MPI_IN_PLACE, &m, 1, MPI_DOUBLE, MPI_MAX, world);
  mass = m;
  blocks.divide(Lx, Ly, comm->nprocs, comm->myloc[1]);
}

// the kernel's build for this CPU, at every init; the log names it when it changes
void FixBKFused::select_kernel()
{
  const char *was = kernel.isa;
  kernel = bkfused::select();
  if (comm->me == 0 && (!was || strcmp(was, kernel.isa) != 0))
    utils::logmesg(lmp, "fix {} bk/substrate fused: {}x{} lattice, {}, kernel {}\n", id, Lx, Ly,
                   blocks.describe(), kernel.isa);
}

/* before the first exchange of every run on several ranks: LAMMPS's sub-domains cut between
   the blocks' rows, so that the exchange gives each rank the atoms of its rows */

void FixBKFused::setup_pre_exchange()
{
  exchanged_in_setup = true;
  if (!blocks.slab()) return;
  blocks.cut_subdomains(lmp);
  pre_exchange();
}

/* before every exchange on several ranks: no particle may have left its rows' sub-domain (it
   would be moved to another rank, where its bond partners are not even ghosts) */

void FixBKFused::pre_exchange()
{
  if (!blocks.slab()) return;
  const tagint stray = blocks.first_stray(lmp);
  tagint all = stray;
  MPI_Allreduce(&stray, &all, 1, MPI_LMP_TAGINT, MPI_MIN, world);
  blocks.report_stray(lmp, all);
}

/* the arrays in lattice order, the halo, the map to LAMMPS's atoms, and the constants:
   anchors, k_d, and each bond's periodic image */

void FixBKFused::build_lattice()
{
  const int nloc = blocks.nloc;
  const bkfused::Constants c = pool.allocate(arr, nloc, Lx, blocks.slab());
  blocks.open_halo(lmp, arr);
  loc.assign(nloc, 0);
  ox.assign(nloc, 0.0);
  oy.assign(nloc, 0.0);
  z.assign(nloc, 0.0);
  update_map();
  take_constants(c);
  bkfused::bond_images(c, Lx, Ly, nloc, blocks.slab(), domain->xprd, domain->yprd,
                       domain->xperiodic, domain->yperiodic);
  lattice_ready = true;
  have_state = false;
}

// the anchors and k_d of the block's particles (a slab: and the ghost rows' anchors)
void FixBKFused::take_constants(const bkfused::Constants &c)
{
  const double *kdv = drive_on ? atom->dvector[kd_index] : nullptr;
  for (int k = 0; k < blocks.nloc; k++) {
    const int i = loc[k];
    c.ax[k] = state[i][AX];
    c.ay[k] = state[i][AY];
    c.kd[k] = kdv ? kdv[i] : 0.0;
  }
  if (blocks.slab()) blocks.exchange(c.ax, c.ay);
}

void FixBKFused::setup_post_neighbor()
{
  rebase_images();
  if (!lattice_ready) build_lattice();    // which maps
  else update_map();
}

void FixBKFused::post_neighbor()
{
  rebase_images();
  if (lattice_ready) update_map();
}

void FixBKFused::set_model()
{
  bkfused::Model &m = model;
  const double dt = update->dt;
  m.Lx = Lx, m.Ly = blocks.nrows, m.N = blocks.nloc, m.slab = blocks.slab();
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
  if (!lattice_ready) build_lattice();
  unexchanged_start = !exchanged_in_setup;
  update_map();
  unexchanged_start = exchanged_in_setup = false;
  setup_step = update->ntimestep;
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
  // a run started with `run ... pre no` calls no setup (LAMMPS 22Jul2025): on several ranks,
  // check that no command between runs moved atoms between ranks (balance)
  if (blocks.slab() && n == update->firststep + 1 && setup_step != update->firststep) {
    unexchanged_start = true;
    update_map();
    unexchanged_start = false;
  }
  plate_shift = plate_now();
  model.e0 = elapsed_base, model.n0 = step_base, model.dt0 = dt_base;
  const bool due = mirror_schedule.due(lmp, n);
  mirror_to.x = due ? atom->x : nullptr;
  mirror_to.v = atom->v;
  mirror_to.state = due ? state : nullptr;
  long last = 0;
  arr.fb_track = track_breaks;
  arr.fb_mark = break_mark;
  blocks.timing = true;
  const long nb = kernel.run(model, arr, mirror_to, n, 1, &last);
  blocks.timing = false;
  nbreak_step = last;
  nbreak_total += nb;
  novershoot += arr.overshoot;
  arr.overshoot = 0;
  if (damping != BK_NO_DAMPING) vh_valid = 1;
  if (ledger_on)
    for (int k = 0; k < BK_NLEDGER; k++) ledger[k] = arr.led[k];
  sigma_step = rmax_step = energy_step = -1;
}

void FixBKFused::post_run()
{
  sync_state();
  blocks.log_halo_time(lmp, id);
}
