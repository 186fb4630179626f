/* bkflow LAMMPS plugin: the fused path and the rest of the deck (plugins/README.md "The fused
   path"). The fused fix integrates the layer with all of its forces itself, so the deck must
   leave the layer to it (checked at every init); it changes two of the deck's settings (the
   ghost cutoff, and on several ranks thermo_modify lost/bond); and it writes its state into
   LAMMPS's atom arrays only at the steps where another part of the deck may read them
   (BKMirrorSchedule). */

#ifndef BKFLOW_BK_FUSED_DECK_H
#define BKFLOW_BK_FUSED_DECK_H

#include "lmptype.h"

#include <vector>

namespace LAMMPS_NS {
class Comm;
class Fix;
class LAMMPS;

namespace bk_fused_deck {

// the communication cutoff of the fused path: no atom is a ghost
constexpr double GHOST_CUTOFF = 0.1;

/* stops with an error unless the deck leaves the layer to `self`: run_style verlet, no pair,
   bond, angle, dihedral, improper or kspace style, no other fix that integrates or acts on
   forces (fix enforce2d is tolerated), no fix balance on several ranks, an atom map */
void check(LAMMPS *lmp, const Fix *self);

/* The fix trades its boundary rows itself: LAMMPS's ghost atoms, which nothing here reads,
   would cost a copy of their positions every step and, on several ranks, a second meeting of
   the ranks every step (LAMMPS's forward communication). So no ghost: the ghost cutoff is
   lowered to GHOST_CUTOFF (0 LAMMPS warns of), which no atom half a row from the cuts reaches.
   Returns the deck's cutoff it replaced, or -1 if the deck's was not above. */
double lower_ghost_cutoff(LAMMPS *lmp, const char *fix_id);
// gives the deck its cutoff back (the fix deleted), unless something else changed it since
void restore_ghost_cutoff(Comm *comm, double replaced);

/* On several ranks LAMMPS's check of the bonds at setup finds no partner across ranks, which
   the lowered cutoff leaves out: it is told to ignore that (the bonds are the fused fix's
   alone, no bond style reads them; a stray is the fix's error, FixBKFused::update_map). */
void ignore_lost_bonds(LAMMPS *lmp, const char *fix_id);

}    // namespace bk_fused_deck

/* The steps at which LAMMPS's positions, velocities and the per-atom array must hold the
   fused fix's state: an output (thermo, dump, restart), the end_of_step of another fix
   (bk/slips, fix print, averages; not bk/stress, which reads only sigma_x), a neighbour-list
   check (which compares positions and then wraps them into the box), a reneighbouring a fix
   forces, and the last step of a run. */
class BKMirrorSchedule {
 public:
  // the other fixes of the deck that read the atoms or force a reneighbouring (at init)
  void find_readers(LAMMPS *lmp, const Fix *self);
  bool due(LAMMPS *lmp, bigint step) const;

 private:
  std::vector<int> reader_every;     // Nevery of the other fixes' end_of_step
  std::vector<Fix *> reneighboring;  // fixes that may force a reneighbouring
};

}    // namespace LAMMPS_NS

#endif
