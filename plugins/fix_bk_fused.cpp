/* bkflow LAMMPS plugin: `fix ID all bk/substrate ... fused`, the fast path of fix
   bk/substrate on any number of ranks (fix_bk_fused.h, plugins/README.md "The fused path").

   The fix is fix bk/substrate (same style, same keywords, outputs and restart state, so that
   bk/stress, bk/slips and restart files work with either path) that also integrates: at
   initial_integrate it runs the whole step of fix nve + fix bk/substrate + fix enforce2d in the
   kernel of bk_fused_kernel.inc over arrays in lattice order, then mirrors the positions
   (x = X - periodic offset) and velocities into LAMMPS's arrays, so that neighbour checks,
   periodic wrapping, dumps, bk/stress and bk/slips see what they always did. The canonical
   state is the fix's: unwrapped positions X, velocities, forces, contact displacements and
   half-step velocities. LAMMPS's own force array is not used (it holds zeros).

   Lattice: atom ID k + 1 = 1 + ix + Lx iy, bonded to its four periodic neighbours (the data
   file of bkflow), found from the bond topology when the fix is first initialised.

   Ranks: K ranks in a column (`processors 1 * 1`) hold K blocks of whole rows; the fix cuts
   LAMMPS's sub-domains between rows (a non-uniform brick layout, as `balance` sets) before the
   first exchange, so that LAMMPS's local atoms are the rank's rows, and every step trades the
   block's first and last rows with the neighbouring ranks (halo_start, halo_wait). Atoms never migrate: a
   particle that strays half a row from its site into another rank's sub-domain stops the run
   (update_map). Each particle's arithmetic does not depend on the blocks, so any number of
   ranks gives the same bits; the sums of the outputs are made the same way (row_sum_total). */

#include "fix_bk_fused.h"

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "force.h"
#include "input.h"
#include "memory.h"
#include "fix_bk_stress.h"
#include "modify.h"
#include "neighbor.h"
#include "output.h"
#include "update.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>
#include <limits>

using namespace LAMMPS_NS;
using namespace FixConst;

namespace {
constexpr double NaN = std::numeric_limits<double>::quiet_NaN();
constexpr double GHOST_CUTOFF = 0.1;    // the communication cutoff of the fused path
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
  if (halo_comm != MPI_COMM_NULL) MPI_Comm_free(&halo_comm);
  // after unfix, the deck's own ghost cutoff again: a general-path fix defined next needs its
  // ghosts (comm is deleted after modify at LAMMPS's end). thermo_modify lost/bond stays
  // ignore: a command cannot be issued from here (a fix redefined with the same ID is deleted
  // while LAMMPS still reads the new one's arguments from the input's buffer), and the
  // general path checks its bond partners itself
  if (cutoff_replaced >= 0.0 && comm && comm->cutghostuser == GHOST_CUTOFF)
    comm->cutghostuser = cutoff_replaced;
}

int FixBKFused::setmask()
{
  return INITIAL_INTEGRATE | PRE_EXCHANGE | POST_NEIGHBOR | POST_RUN;
}

/* Everything else in the deck must leave the layer to this fix: no other integrator, no force
   from a pair or bond style or another fix (the fix never reads LAMMPS's force array). */

void FixBKFused::init()
{
  FixBKLayer::init();
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
    if (comm->nprocs > 1 && strcmp(f->style, "balance") == 0)
      error->all(FLERR, "fix bk/substrate fused on several ranks cuts the sub-domains between "
                        "lattice rows itself: remove fix {} (balance)", f->id);
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
  if (!Lx) find_lattice();
  const char *was = kernel.isa;
  kernel = bkfused::select();
  if (comm->me == 0 && (!was || strcmp(was, kernel.isa) != 0)) {
    std::string blocks = "one rank";
    if (nblocks > 1) {
      blocks = fmt::format("{} ranks, blocks of rows", nblocks);
      for (int j = 0; j < nblocks; j++)
        blocks += fmt::format("{}{}-{}", j ? " | " : " ", block_first_row(j, nblocks, Ly),
                              block_first_row(j + 1, nblocks, Ly) - 1);
    }
    utils::logmesg(lmp, "fix {} bk/substrate fused: {}x{} lattice, {}, kernel {}\n", id, Lx, Ly,
                   blocks, kernel.isa);
  }
  // The fix trades its boundary rows itself: LAMMPS's ghost atoms, which nothing here reads,
  // would cost a copy of their positions every step and, on several ranks, a second meeting
  // of the ranks every step (LAMMPS's forward communication). So no ghost: a cutoff of 0.1
  // (0 LAMMPS warns of), which no atom half a row from the cuts reaches. LAMMPS's check of the
  // bonds at setup then finds no partner across ranks: it is told to ignore that (the bonds
  // are this fix's alone, no bond style reads them; a stray is this fix's error, update_map)
  if (comm->cutghostuser > GHOST_CUTOFF) {
    if (comm->me == 0)
      utils::logmesg(lmp, "fix {} bk/substrate fused: the fix trades its boundary rows itself, "
                     "comm_modify cutoff {} -> {}\n", id, comm->cutghostuser, GHOST_CUTOFF);
    cutoff_replaced = comm->cutghostuser;    // the deck's latest (comm_modify between runs)
    comm->cutghostuser = GHOST_CUTOFF;
  }
  if (nblocks > 1) {    // (the wheel ships no thermo.h: the command, before the run's setup)
    if (comm->me == 0)
      utils::logmesg(lmp, "fix {} bk/substrate fused: thermo_modify lost/bond ignore (LAMMPS's "
                     "bond check at setup finds no bond partner across ranks)\n", id);
    input->one("thermo_modify lost/bond ignore");
  }

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
   coincide). Checked on this rank's atoms. */

static bool lattice_matches(LAMMPS *lmp, int n, int lx)
{
  Atom *atom = lmp->atom;
  const int ly = n / lx;
  for (int i = 0; i < atom->nlocal; i++) {
    if (atom->num_bond[i] != 4) return false;
    const int k = static_cast<int>(atom->tag[i]) - 1;
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

/* The one lattice detector (collective): Lx of the lattice the fused path can run, 0 when it
   cannot, with the reason in *why (the end of an error message): atom IDs 1..N, an atom map,
   the bonds of bkflow's periodic square lattice, one positive mass; on K > 1 ranks, the ranks
   in a column (`processors 1 * 1`: each holds a block of rows) and at least one row each.
   `integrate` takes the fused path exactly when this is not 0 (plugins/bkplugin.cpp); `fused`
   refuses a deck it is 0 for. */

int FixBKFused::fused_lattice(LAMMPS *lmp, std::string *why)
{
  Atom *atom = lmp->atom;
  Comm *comm = lmp->comm;
  MPI_Comm world = lmp->world;
  auto no = [why](std::string reason) {
    if (why) *why = std::move(reason);
    return 0;
  };
  const int K = comm->nprocs;
  if (K > 1 && comm->layout == Comm::LAYOUT_TILED)
    return no(fmt::format(" on {} ranks needs LAMMPS's brick layout, each rank a block of "
                          "lattice rows: drop `comm_style tiled` (and `balance ... rcb`)", K));
  if (K > 1 && (comm->procgrid[0] != 1 || comm->procgrid[2] != 1))
    return no(fmt::format(" on {} ranks needs them in one column, each holding a block of "
                          "lattice rows: add `processors 1 * 1` before read_data (the grid is "
                          "{}x{}x{}{})", K, comm->procgrid[0], comm->procgrid[1],
                          comm->procgrid[2],
                          comm->layout == Comm::LAYOUT_TILED ? ", tiled" : ""));
  if (atom->map_style == Atom::MAP_NONE)
    return no(" needs an atom map: atom_modify map array");
  if (!atom->molecular || !atom->num_bond)
    return no(" needs the bonds (the lattice): add bonds k_b r0");
  if (atom->natoms > 2000000000) return no(fmt::format(": {} atoms", atom->natoms));
  const int n = static_cast<int>(atom->natoms);
  auto mass_of = [atom](int i) {
    return atom->rmass ? atom->rmass[i] : atom->mass ? atom->mass[atom->type[i]] : 0.0;
  };
  // IDs 1..n (with natoms = n and LAMMPS's IDs unique, every one is present); the masses
  double local[3] = {0.0, std::numeric_limits<double>::infinity(),
                     -std::numeric_limits<double>::infinity()};
  for (int i = 0; i < atom->nlocal; i++) {
    if (atom->tag[i] < 1 || atom->tag[i] > n) local[0] = 1.0;
    local[1] = std::min(local[1], mass_of(i));
    local[2] = std::max(local[2], mass_of(i));
  }
  local[1] = -local[1];
  double all[3];
  MPI_Allreduce(local, all, 3, MPI_DOUBLE, MPI_MAX, world);
  if (all[0] != 0.0) return no(fmt::format(" needs atom IDs 1..{} (the lattice's)", n));
  if (-all[1] != all[2])
    return no(fmt::format(" needs one mass for every atom ({} and {})", -all[1], all[2]));
  if (!(all[2] > 0.0)) return no(": mass must be > 0");
  for (int lx = 3; lx <= n / 3; lx++) {
    if (n % lx) continue;
    int ok = lattice_matches(lmp, n, lx) ? 1 : 0, all_ok = 0;
    MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, world);
    if (!all_ok) continue;
    if (K > n / lx)
      return no(fmt::format(" on {} ranks needs at least one lattice row per rank (the lattice "
                            "has {}): run on at most {} ranks", K, n / lx, n / lx));
    if (K > 1) {    // each particle within a quarter row of its row's line
      const int ly = n / lx;
      const double a = lmp->domain->yprd / ly, lo = lmp->domain->boxlo[1];
      double far = 0.0;    // the farthest off its line, in rows, and its ID (the lowest at a tie)
      tagint who = std::numeric_limits<tagint>::max();
      for (int i = 0; i < atom->nlocal; i++) {
        const double site = lo + (static_cast<double>((atom->tag[i] - 1) / lx) + 0.5) * a;
        double d = std::fabs(atom->x[i][1] - site) / a;
        if (lmp->domain->yperiodic) {
          d = std::fmod(d, static_cast<double>(ly));
          d = std::min(d, ly - d);
        }
        if (d > far || (d == far && atom->tag[i] < who)) far = d, who = atom->tag[i];
      }
      double far_all = 0.0;
      MPI_Allreduce(&far, &far_all, 1, MPI_DOUBLE, MPI_MAX, world);
      tagint mine = far == far_all ? who : std::numeric_limits<tagint>::max(), tag = mine;
      MPI_Allreduce(&mine, &tag, 1, MPI_LMP_TAGINT, MPI_MIN, world);
      if (far_all > 0.25)
        return no(fmt::format(" on {} ranks needs every particle within a quarter row of its "
                              "row's line y = ylo + (iy + 1/2) yprd / Ly (the ranks' cuts fall "
                              "half a row from these lines, where bkflow's lattices sit); "
                              "particle {} (row {}) is {:.2f} rows off it", K, tag,
                              (tag - 1) / lx, far_all));
    }
    return lx;
  }
  return no(": the bonds are not a periodic square lattice with atom ID 1 + ix + Lx iy bonded "
            "to its neighbours at ix +- 1 and iy +- 1 (Lx, Ly >= 3), which the fused path "
            "needs: drop `fused`");
}

// the lattice, its mass and this rank's block of rows
void FixBKFused::find_lattice()
{
  std::string why;
  Lx = fused_lattice(lmp, &why);
  // with `integrate` the layer passed this test when the fix was made (bkplugin.cpp): it
  // changed (moved) before the first run, and the path cannot change any more (a fix defined
  // after the move would be another run: the fix keeps the layer's positions at its definition)
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
  nblocks = comm->nprocs;
  const int j = comm->myloc[1];
  row0 = block_first_row(j, nblocks, Ly);
  nrows = block_first_row(j + 1, nblocks, Ly) - row0;
  nloc = nrows * Lx;
}

/* before the first exchange of every run on several ranks: LAMMPS's sub-domains cut between
   the blocks' rows (rows at y = ylo + (iy + 1/2) yprd / Ly, as bkflow writes them), so that the
   exchange gives each rank the atoms of its rows */

void FixBKFused::setup_pre_exchange()
{
  exchanged_in_setup = true;
  if (nblocks < 2) return;
  comm->layout = Comm::LAYOUT_NONUNIFORM;
  for (int j = 0; j <= nblocks; j++)
    comm->ysplit[j] = static_cast<double>(block_first_row(j, nblocks, Ly)) / Ly;
  domain->set_local_box();
  pre_exchange();
}

/* before every exchange on several ranks: no particle may have left its rows' sub-domain (it
   would be moved to another rank, where its bond partners are not even ghosts) */

void FixBKFused::pre_exchange()
{
  if (nblocks < 2) return;
  const tagint stray = first_stray(lmp, Lx, Ly, nblocks);
  tagint all = stray;
  MPI_Allreduce(&stray, &all, 1, MPI_LMP_TAGINT, MPI_MIN, world);
  report_stray(all);
}

/* The lowest ID of this rank's atoms that is not in the sub-domain of its row's block (the
   cuts of setup_pre_exchange, y = ylo + yprd first(j) / Ly), or the largest tagint */

tagint FixBKFused::first_stray(LAMMPS *lmp, int Lx, int Ly, int K)
{
  const Atom *atom = lmp->atom;
  const Domain *domain = lmp->domain;
  const double lo = domain->boxlo[1], prd = domain->yprd;
  tagint stray = std::numeric_limits<tagint>::max();
  for (int i = 0; i < atom->nlocal; i++) {
    double y = atom->x[i][1];    // wrapped as Domain::pbc will
    if (domain->yperiodic) {
      if (y < lo) y += prd;
      if (y >= lo + prd) y -= prd;
    }
    const int row = static_cast<int>((atom->tag[i] - 1) / Lx);
    int j = static_cast<int>(static_cast<long long>(row) * K / Ly);
    while (block_first_row(j, K, Ly) > row) j--;
    while (block_first_row(j + 1, K, Ly) <= row) j++;
    const double below = static_cast<double>(block_first_row(j, K, Ly)) / Ly;
    const double above = static_cast<double>(block_first_row(j + 1, K, Ly)) / Ly;
    if (!(y >= lo + prd * below && y < lo + prd * above)) stray = std::min(stray, atom->tag[i]);
  }
  return stray;
}

// stops the run on every rank with `all`, the lowest ID any rank found out of place (reduced
// over ranks by the caller), if any
void FixBKFused::report_stray(tagint all)
{
  if (all == std::numeric_limits<tagint>::max()) return;
  if (nblocks > 1)
    error->all(FLERR,
               "{} fix bk/substrate fused: particle {} (lattice row {}) left the sub-domain "
               "of its rank's rows: it moved half a row (or the layer tore) across a rank "
               "boundary. On {} ranks the fused path needs every particle within half a row "
               "of its site: run it on one rank, or on the general path (without "
               "`integrate`: fix nve and fix enforce2d)",
               BK_ERR_ATOM_LOST, all, (all - 1) / Lx, nblocks);
  error->all(FLERR, "{} fix bk/substrate fused: atom {} is not local", BK_ERR_ATOM_LOST, all);
}

/* The halo (bkfused::Arrays::halo_start, halo_wait): this block's first row goes to the block
   below (its ghost row above) and its last row to the block above, while theirs come in;
   non-blocking, so that the kernel computes the rows that need no ghost meanwhile. The
   neighbours are LAMMPS's in the column of ranks (one rank each side, the same one when there
   are two: the tags tell the two messages apart). */

void FixBKFused::halo_start(void *self, const double *x, const double *y)
{
  auto *f = static_cast<FixBKFused *>(self);
  const double t0 = f->in_step ? MPI_Wtime() : 0.0;
  const int Lx = f->Lx, n = f->nloc;
  const int down = f->comm->procneigh[1][0], up = f->comm->procneigh[1][1];
  double *s = f->halo_send.data(), *r = f->halo_recv.data();    // [0, 2 Lx): to/from below
  const size_t row = static_cast<size_t>(Lx) * sizeof(double);
  MPI_Irecv(r, 2 * Lx, MPI_DOUBLE, down, 1, f->halo_comm, &f->halo_req[0]);
  MPI_Irecv(r + 2 * Lx, 2 * Lx, MPI_DOUBLE, up, 0, f->halo_comm, &f->halo_req[1]);
  memcpy(s, x, row);
  memcpy(s + Lx, y, row);
  memcpy(s + 2 * Lx, x + n - Lx, row);
  memcpy(s + 3 * Lx, y + n - Lx, row);
  MPI_Isend(s, 2 * Lx, MPI_DOUBLE, down, 0, f->halo_comm, &f->halo_req[2]);
  MPI_Isend(s + 2 * Lx, 2 * Lx, MPI_DOUBLE, up, 1, f->halo_comm, &f->halo_req[3]);
  if (f->in_step) f->halo_time += MPI_Wtime() - t0;
}

void FixBKFused::halo_wait(void *self, double *x, double *y)
{
  auto *f = static_cast<FixBKFused *>(self);
  const double t0 = f->in_step ? MPI_Wtime() : 0.0;
  const int Lx = f->Lx, n = f->nloc;
  const double *r = f->halo_recv.data();
  const size_t row = static_cast<size_t>(Lx) * sizeof(double);
  MPI_Waitall(4, f->halo_req, MPI_STATUSES_IGNORE);
  memcpy(x - Lx, r, row);    // the block below's last row
  memcpy(y - Lx, r + Lx, row);
  memcpy(x + n, r + 2 * Lx, row);    // the block above's first row
  memcpy(y + n, r + 3 * Lx, row);
  if (f->in_step) {
    f->halo_time += MPI_Wtime() - t0;
    f->halo_calls++;
  }
}

void FixBKFused::build_lattice()
{
  const bool slab = nblocks > 1;
  // every array in one pool, each 64-byte aligned and padded; on a slab with a ghost row
  // before (in the pad) and after
  const size_t pad = slab ? (static_cast<size_t>(Lx) + 7) / 8 * 8 : 0;
  size_t stride = pad + (static_cast<size_t>(nloc) + (slab ? Lx : 0) + 7) / 8 * 8;
  // arrays a multiple of 4 KB apart alias in the CPU's store forwarding (the loops stream
  // ten of them at once: twice the time per step where it happened, benchmarks/RESULTS.md);
  // an odd number of 64-byte lines apart, the NARR arrays start at distinct offsets of 4 KB
  if (stride / 8 % 2 == 0) stride += 8;
  constexpr int NARR = 30;
  pool.assign(stride * NARR + 8, 0.0);
  double *p = pool.data();
  while (reinterpret_cast<uintptr_t>(p) % 64) p++;
  double *next = p;
  auto take = [&]() {
    double *q = next + pad;
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
  for (int k = 0; k < nloc; k++) arr.fb[k] = -1.0;
  halo_send.assign(4 * static_cast<size_t>(Lx), 0.0);
  halo_recv.assign(4 * static_cast<size_t>(Lx), 0.0);
  if (slab && halo_comm == MPI_COMM_NULL) MPI_Comm_dup(world, &halo_comm);    // its own tags
  arr.halo_start = &FixBKFused::halo_start;
  arr.halo_wait = &FixBKFused::halo_wait;
  arr.halo_ctx = this;

  loc.assign(nloc, 0);
  ox.assign(nloc, 0.0);
  oy.assign(nloc, 0.0);
  z.assign(nloc, 0.0);
  update_map();

  // constant: anchors, k_d, and each bond's periodic image, fixed from the anchors (the
  // lattice image bk/substrate keeps: bond vector minus relative displacement = lattice vector)
  const double *kdv = drive_on ? atom->dvector[kd_index] : nullptr;
  for (int k = 0; k < nloc; k++) {
    const int i = loc[k];
    ax[k] = state[i][AX];
    ay[k] = state[i][AY];
    kd[k] = kdv ? kdv[i] : 0.0;
  }
  if (slab) {    // the ghost rows' anchors
    halo_start(this, ax, ay);
    halo_wait(this, ax, ay);
  }
  const double xprd = domain->xprd, yprd = domain->yprd;
  auto image_shift = [](double d, double prd, int periodic) {
    return periodic ? bk_image_shift(d, prd) : 0.0;
  };
  // a slab: the +y bonds of the ghost row below too (the first row's -y bonds)
  for (int k = slab ? -Lx : 0; k < nloc; k++) {
    const int ix = (k + Lx) % Lx, iy = (k + Lx) / Lx - 1;
    const int u = slab ? k + Lx : ix + Lx * ((iy + 1) % Ly);
    sux[k] = image_shift(ax[k] - ax[u], xprd, domain->xperiodic);
    suy[k] = image_shift(ay[k] - ay[u], yprd, domain->yperiodic);
    if (k < 0) continue;
    const int r = (ix + 1) % Lx + Lx * iy;
    srx[k] = image_shift(ax[k] - ax[r], xprd, domain->xperiodic);
    sry[k] = image_shift(ay[k] - ay[r], yprd, domain->yperiodic);
  }
  lattice_ready = true;
  have_state = false;
}

/* local index and periodic offset of every lattice particle of this rank's rows: at every
   reneighbouring (atoms may be sorted, image flags change) and at every setup (commands
   between runs may have moved atoms). Every particle of the rows must be local here, and no
   other: on several ranks, a particle that strayed into another rank's sub-domain (half a row
   from its site) stops the run, on every rank at once. */

void FixBKFused::update_map()
{
  const imageint *const image = atom->image;
  const tagint first = static_cast<tagint>(row0) * Lx + 1;
  tagint stray = std::numeric_limits<tagint>::max();    // the lowest ID out of place
  int stale = 0;    // the atom map names another atom: atoms moved without a map rebuild
  identity = true;
  double o[2];
  for (int k = 0; k < nloc; k++) {
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
  if (atom->nlocal != nloc)
    for (int i = 0; i < atom->nlocal; i++)
      if (atom->tag[i] < first || atom->tag[i] >= first + nloc)
        stray = std::min(stray, atom->tag[i]);
  // a run started with `pre no` after a command moved atoms between ranks (balance): LAMMPS
  // did not exchange them back, nor rebuild its map
  tagint all = stray;
  int any_stale = stale;
  if (nblocks > 1) {
    MPI_Allreduce(&stray, &all, 1, MPI_LMP_TAGINT, MPI_MIN, world);
    MPI_Allreduce(&stale, &any_stale, 1, MPI_INT, MPI_MAX, world);
  }
  if (any_stale || (all != std::numeric_limits<tagint>::max() && unexchanged_start))
    error->all(FLERR,
               "{} fix bk/substrate fused: at the start of this run particle {} is not where "
               "the fix holds it (a command between runs moved atoms between ranks, e.g. "
               "`balance`, and `run ... pre no` skipped the exchange that puts them back): "
               "run with `pre yes`", BK_ERR_ATOM_LOST, all);
  report_stray(all);
  mirror_to.x = atom->x;
  mirror_to.v = atom->v;
  mirror_to.loc = identity ? nullptr : loc.data();
  mirror_to.ox = ox.data();
  mirror_to.oy = oy.data();
  mirror_to.z = z.data();
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
  for (int k = 0; k < nloc; k++) {
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
  m.Lx = Lx, m.Ly = nrows, m.N = nloc, m.slab = nblocks > 1;
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
  if (nblocks > 1 && n == update->firststep + 1 && setup_step != update->firststep) {
    unexchanged_start = true;
    update_map();
    unexchanged_start = false;
  }
  plate_shift = plate_now();
  model.e0 = elapsed_base, model.n0 = step_base, model.dt0 = dt_base;
  const bool due = mirror_due(n);
  mirror_to.x = due ? atom->x : nullptr;
  mirror_to.v = atom->v;
  mirror_to.state = due ? state : nullptr;
  long last = 0;
  arr.fb_track = track_breaks;
  arr.fb_mark = break_mark;
  in_step = true;
  const long nb = kernel.run(model, arr, mirror_to, n, 1, &last);
  in_step = false;
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
  if (nblocks > 1 && halo_calls) {    // the exchanges' share of the run (benchmarks/RESULTS.md)
    double t[2] = {halo_time, -halo_time}, all[2];
    MPI_Allreduce(t, all, 2, MPI_DOUBLE, MPI_MAX, world);
    if (comm->me == 0)
      utils::logmesg(lmp, "fix {} bk/substrate fused: {} halo exchanges of {} bytes (sent "
                     "and received) a rank, {:.3g} to {:.3g} us each (the fastest and slowest rank's mean, waits "
                     "included)\n", id, halo_calls, 4 * 2 * Lx * sizeof(double),
                     -all[1] / halo_calls * 1e6, all[0] / halo_calls * 1e6);
  }
  halo_time = 0.0;
  halo_calls = 0;
}

// the per-atom array (contact displacement, half-step velocity) and the exact positions
void FixBKFused::sync_state()
{
  for (int k = 0; k < nloc; k++) {
    double *s = state[loc[k]];
    s[DRX] = arr.drx[k];
    s[DRY] = arr.dry[k];
    s[VHX] = arr.vhx[k];
    s[VHY] = arr.vhy[k];
    xu[loc[k]][0] = arr.x[k];
    xu[loc[k]][1] = arr.y[k];
  }
}

/* Sums over the lattice of per-row values (collective): rows[w r + j] is value j of row r of
   this rank's block (width w values a row); the blocks' rows are gathered exactly (a sum of
   one value and zeros) and added in row order into total[j], so that every division into
   blocks gives the same bits */

void FixBKFused::row_totals(const std::vector<double> &rows, int w, double *total) const
{
  std::vector<double> all(static_cast<size_t>(Ly) * w, 0.0);
  std::copy(rows.begin(), rows.end(), all.begin() + static_cast<size_t>(row0) * w);
  if (nblocks > 1)
    MPI_Allreduce(MPI_IN_PLACE, all.data(), Ly * w, MPI_DOUBLE, MPI_SUM, world);
  for (int j = 0; j < w; j++) {
    double s = 0.0;
    for (int r = 0; r < Ly; r++) s += all[static_cast<size_t>(r) * w + j];
    total[j] = s;
  }
}

double FixBKFused::row_sum_total(const std::vector<double> &rows) const
{
  double s;
  row_totals(rows, 1, &s);
  return s;
}

/* sigma_x = sum_k k_d^k (plate shift - (X_k - anchor_k)) / (Lx Ly), summed in lattice order
   within each row and then over rows, from the positions of the step, computed once per step
   when first asked (bk/stress, thermo) */

double FixBKFused::sigma_x()
{
  const bigint step = update->ntimestep;
  if (sigma_step != step) {
    const double shift = plate_shift;
    std::vector<double> rows(nrows, 0.0);
    for (int r = 0; r < nrows; r++) {
      double s = 0.0;
      for (int k = r * Lx; k < (r + 1) * Lx; k++)
        s += bk_drive_x(arr.kd[k], shift, arr.x[k] - arr.ax[k]);
      rows[r] = s;
    }
    sigma_value = row_sum_total(rows) / (domain->xprd * domain->yprd);
    sigma_step = step;
  }
  return sigma_value;
}

/* the squared lengths of particle k's +x and +y bonds (at their fixed lattice images) */
void FixBKFused::bond_r2(int k, double &rx2, double &uy2) const
{
  const int ix = k % Lx, iy = k / Lx;
  // a slab's top row: its +y partners are the ghost row above
  const int r = (ix + 1) % Lx + Lx * iy, u = nblocks > 1 ? k + Lx : ix + Lx * ((iy + 1) % Ly);
  const double dx = arr.x[k] - arr.x[r] + arr.srx[k], dy = arr.y[k] - arr.y[r] + arr.sry[k];
  const double ex = arr.x[k] - arr.x[u] + arr.sux[k], ey = arr.y[k] - arr.y[u] + arr.suy[k];
  rx2 = dx * dx + dy * dy;
  uy2 = ex * ex + ey * ey;
}

// the contact breaks of the last step or since the fix was defined, over every rank
double FixBKFused::breaks(bool total)
{
  double b = static_cast<double>(total ? nbreak_total : nbreak_step);
  if (nblocks > 1) MPI_Allreduce(MPI_IN_PLACE, &b, 1, MPI_DOUBLE, MPI_SUM, world);
  return b;
}

double FixBKFused::longest_bond()
{
  const bigint step = update->ntimestep;
  if (rmax_step != step) {
    double r2max = 0.0;
    for (int k = 0; k < nloc; k++) {
      double a, b;
      bond_r2(k, a, b);
      r2max = std::max(r2max, std::max(a, b));
    }
    if (nblocks > 1) MPI_Allreduce(MPI_IN_PLACE, &r2max, 1, MPI_DOUBLE, MPI_MAX, world);
    rmax_value = sqrt(r2max);
    rmax_step = step;
  }
  return rmax_value;
}

void FixBKFused::clear_first_breaks()
{
  FixBKLayer::clear_first_breaks();
  if (lattice_ready)
    for (int k = 0; k < nloc; k++) arr.fb[k] = -1.0;
}

double FixBKFused::first_break_of(int i) const
{
  if (!lattice_ready) return FixBKLayer::first_break_of(i);
  const double b = arr.fb[atom->tag[i] - 1 - static_cast<tagint>(row0) * Lx];
  return b >= break_mark ? b : -1.0;
}

int FixBKFused::path_code() const
{
  return strcmp(kernel.isa, "avx512") == 0 ? BK_PATH_FUSED_AVX512
      : strcmp(kernel.isa, "avx2") == 0    ? BK_PATH_FUSED_AVX2
                                           : BK_PATH_FUSED_BASELINE;
}

// the contacts' phase sums from the fix's own arrays, row by row (row_totals)
void FixBKFused::contact_phase(double *sums)
{
  if (!lattice_ready || !have_state) return FixBKLayer::contact_phase(sums);
  std::vector<double> rows(static_cast<size_t>(nrows) * BK_NPHASE, 0.0);
  if (contact != BK_NO_CONTACT)
    for (int r = 0; r < nrows; r++)
      kernel.phase(arr.drx + r * Lx, arr.dry + r * Lx, Lx, ke / fmax, &rows[r * BK_NPHASE]);
  row_totals(rows, BK_NPHASE, sums);
}

/* the energies of the current step from the fix's own arrays (the kernel's, vectorized):
   bonds, drive springs, contacts, kinetic (the full-step velocities), row by row and summed
   over the lattice in row order (row_totals, collective), the same bits on any number of
   ranks; rank 0 holds them and the others zeros, so the caller's sum over ranks adds only
   zeros to them */
void FixBKFused::local_energies(double *e)
{
  e[0] = e[1] = e[2] = e[3] = 0.0;
  if (!lattice_ready || !have_state) return;
  std::vector<double> rows(static_cast<size_t>(nrows) * 4, 0.0);
  kernel.energies(model, arr, plate_shift, rows.data());
  row_totals(rows, 4, e);
  e[3] *= 0.5 * model.mass;
  e[3] *= force->mvv2e;    // energy units, as the kicks' ftm2v (1 in lj units)
  if (!model.drive) e[1] = 0.0;
  if (model.contact == BK_NO_CONTACT) e[2] = 0.0;
  if (comm->me != 0) e[0] = e[1] = e[2] = e[3] = 0.0;
}

// the bond energy sum k_b/2 (r - r0)^2, row by row (row_sum_total)
double FixBKFused::compute_scalar()
{
  if (!lattice_ready || !have_state) return 0.0;    // before the first setup: no state yet
  std::vector<double> rows(nrows, 0.0);
  for (int r = 0; r < nrows; r++) {
    double e = 0.0;
    for (int k = r * Lx; k < (r + 1) * Lx; k++) {
      double a, b;
      bond_r2(k, a, b);
      e += bk_bond_energy(a, kb, r0) + bk_bond_energy(b, kb, r0);
    }
    rows[r] = e;
  }
  return row_sum_total(rows);
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
  const tagint k = atom->tag[i] - 1 - static_cast<tagint>(row0) * Lx;
  if (lattice_ready && have_state && k >= 0 && k < nloc) {
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
