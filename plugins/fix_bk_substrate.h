/* bkflow: the substrate of the 2D Burridge-Knopoff layer of ../shared/MODEL.md
   (drive spring to a moving plate, shear-history friction, viscous damping),
   fused into one post-force pass over local atoms. See plugins/README.md. */

#ifndef BKFLOW_FIX_BK_SUBSTRATE_H
#define BKFLOW_FIX_BK_SUBSTRATE_H

#include "fix.h"

namespace LAMMPS_NS {

class FixBKSubstrate : public Fix {
 public:
  FixBKSubstrate(class LAMMPS *, int, char **);
  ~FixBKSubstrate() override;
  int setmask() override;
  void init() override;
  void setup(int) override;
  void setup_post_neighbor() override;
  void post_neighbor() override;
  void post_force(int) override;
  double compute_vector(int) override;
  double compute_scalar() override;
  int pack_forward_comm(int, int *, double *, int, int *) override;
  void unpack_forward_comm(int, int, double *) override;

  void write_restart(FILE *) override;
  void restart(char *) override;

  double memory_usage() override;
  void grow_arrays(int) override;
  void copy_arrays(int, int, int) override;
  void set_arrays(int) override;
  int pack_exchange(int, double *) override;
  int unpack_exchange(int, double *) override;
  int pack_restart(int, double *) override;
  void unpack_restart(int, int) override;
  int size_restart(int) override;
  int maxsize_restart() override;

  // per-atom state columns
  enum { AX, AY, DRX, DRY, VHX, VHY, NSTATE };

 private:
  friend struct BKSubstrateTable;
  // model parameters (MODEL.md "Forces on particle i")
  int bonds_on, drive_on, friction_on, damp_on, coulomb;
  int locate_break;    // reset: locate the break inside the step (0: at its end, reset/step)
  int damp_implicit;   // damping with the end-of-step velocity (0: the half-step one)
  double kb, r0;         // bond stiffness (force k_b (r - r0)) and rest length
  double vd;             // plate velocity along +x
  double ke, fmax;       // contact spring, break threshold mu_s*sigma_n*A
  double mus, sigman, area;
  double gamma;          // damping rate
  char *kd_name;         // name of the per-atom double property holding k_d^i
  int kd_index;

  double **state;        // AX, AY: anchor at t0 (unwrapped); DR*: contact displacement;
                         // VH*: half-step velocity of the last post_force
  double **u;            // displacement r_i(t) - r_i(t0), local atoms and ghosts
  int nmax_u;

  // bond list, rebuilt at every reneighbouring: pair (i, j), the periodic shift that puts j
  // at its lattice image of i, and whether j is local (force applied to both ends)
  int nblist, maxblist;
  int *bl_i, *bl_j, *bl_both;
  double *bl_sx, *bl_sy;
  double t0;             // simulation time at which anchors were taken
  // the plate's clock, time since t0 counted in whole steps: elapsed = elapsed_base +
  // (ntimestep - step_base) * dt_base, rebased only when the time step changes. LAMMPS's
  // own clock (atime) is re-summed at every run command, so a run split into chunks would
  // otherwise differ from one long run in the last bits, which the dynamics then amplify.
  double elapsed_base, dt_base;
  bigint step_base;
  int vh_valid;          // VH* hold the velocity used by the last post_force

  // per-step accumulators (local), reduced lazily in compute_vector()
  double sum_fx_drive;
  bigint nbreak_step, nbreak_total;
  double plate_shift;
  double rmax_local;     // longest bond seen in the last step (local atoms)
  int reduced;
  double reduced_vec[3];

  double current_time() const;
  double elapsed();
  void update_displacements(int ghosts);
  void build_bond_list();
  template <int BONDS, int DRIVE, int FRIC, int COULOMB, int DAMP, int ADVANCE> void eval();
  void dispatch(int advance);
};

// The bk/substrate fix that a fix reading its sigma_x (bk/stress, bk/slips) samples: it must
// exist, be of that style, and be defined before the reader, so that sigma_x is the current
// step's at end_of_step. Stops with an error naming the reader otherwise.
class Fix *bk_substrate_for(class LAMMPS *lmp, const char *reader_style, const char *reader_id,
                            const char *substrate_id);

}    // namespace LAMMPS_NS

#endif
