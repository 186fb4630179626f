/* bkflow LAMMPS plugin: `fix ID all bk/substrate ... fused`, the fast path of fix
   bk/substrate. It integrates the layer itself (it takes the place of fix nve and fix
   enforce2d): the whole velocity-Verlet step of the model in one fused pass over arrays kept in
   lattice order, with the bonds found by index arithmetic, mirrored into LAMMPS's positions and
   velocities at the steps where something reads them. On several MPI ranks each rank holds a
   block of lattice rows (LAMMPS's sub-domains cut between rows) and trades its boundary rows
   with its neighbours every step. See plugins/README.md ("The fused path").

   This class is the LAMMPS glue: the fix's life cycle (fix_bk_fused.cpp), its exchange of
   state with LAMMPS's atoms (fix_bk_fused_atoms.cpp) and its outputs (fix_bk_fused_outputs.cpp).
   The rest of the path lives by role in
     bk_lattice_detect.h   finding the lattice among LAMMPS's atoms
     bk_row_blocks.h       the blocks of rows (one a rank) and their halo exchange
     bk_fused_deck.h       what the path requires of the deck, changes in it, and when the
                           deck reads LAMMPS's atom arrays
     bk_fused_arrays.h     the arrays in lattice order: layout, bond images, what is read off
     bk_fused_kernel.h     the step's kernel, one build per instruction set */

#ifndef BKFLOW_FIX_BK_FUSED_H
#define BKFLOW_FIX_BK_FUSED_H

#include "bk_fused_arrays.h"
#include "bk_fused_deck.h"
#include "bk_fused_kernel.h"
#include "bk_row_blocks.h"
#include "fix_bk_layer.h"

#include <vector>

namespace LAMMPS_NS {

class FixBKFused : public FixBKLayer {
 public:
  FixBKFused(class LAMMPS *, int, char **);
  ~FixBKFused() override;
  int setmask() override;
  void init() override;
  void setup(int) override;
  void setup_pre_exchange() override;
  void pre_exchange() override;
  void setup_post_neighbor() override;
  void post_neighbor() override;
  void initial_integrate(int) override;
  void post_run() override;
  double compute_scalar() override;
  void contact_phase(double *sums) override;
  double first_break_of(int i) const override;
  void clear_first_breaks() override;

  double memory_usage() override;
  void grow_arrays(int) override;
  void copy_arrays(int, int, int) override;
  void set_arrays(int) override;
  int pack_restart(int, double *) override;
  void unpack_restart(int, int) override;
  int size_restart(int) override;
  int maxsize_restart() override;
  int pack_exchange(int, double *) override;
  int unpack_exchange(int, double *) override;

  // restart columns: FixBKLayer's, then the exact unwrapped position
  enum { XU = NSTATE, YU, NRESTART };

 private:
  double **xu = nullptr;          // per atom: exact unwrapped position from a restart file
                                  // (NaN: none, use x + offset)
  BKMirrorSchedule mirror_schedule;
  bool lattice_ready = false;     // lattice found and arrays allocated
  bool have_state = false;        // arrays hold the state of the last step
  int Lx = 0, Ly = 0, N = 0;      // the lattice (Lx = 0: not found yet)
  BKRowBlocks blocks;             // this rank's block of rows, a slab when K > 1
  double mass = 0.0;

  bkfused::Kernel kernel{};
  bkfused::Model model;
  bkfused::Arrays arr{};
  bkfused::Mirror mirror_to;
  bkfused::Pool pool;          // every array of `arr`
  std::vector<int> loc;        // LAMMPS's local index of lattice particle k
  std::vector<double> ox, oy;  // its periodic offset (ix Lx, iy Ly): X = x + offset
  std::vector<double> z;       // and its z (constant in 2D)
  bool identity = false;       // loc[k] == k for every k

  bigint sigma_step = -1, rmax_step = -1;    // steps of the cached sigma_x and longest bond
  double sigma_value = 0.0, rmax_value = 0.0;

  bool exchanged_in_setup = false;       // this run's setup exchanged atoms (not `pre no`)
  bool unexchanged_start = false;        // update_map at a run's start with no exchange
  bool chosen = false;                   // `integrate` chose this path when the fix was made
  double cutoff_replaced = -1.0;         // the ghost cutoff this fix lowered (-1: none),
                                         // given back when the fix is deleted (unfix)
  bigint setup_step = -1;                // the step of the last setup()

  double sigma_x() override;
  double breaks(bool total) override;
  double longest_bond() override;
  int path_code() const override;
  void local_energies(double *e) override;

  void find_lattice();
  void select_kernel();
  void build_lattice();
  void take_constants(const bkfused::Constants &c);
  void update_map();
  tagint map_rows(int &stale);
  tagint first_foreign_atom() const;
  void check_map(tagint stray, int stale);
  void adopt_atoms();
  void sync_state();
  void set_model();
};

}    // namespace LAMMPS_NS

#endif
