/* bkflow LAMMPS plugin: fix bk/substrate, the forces on the 2D Burridge-Knopoff layer of
   docs/model.md (bonds, drive spring to a moving plate, shear-history friction, viscous
   damping), fused into one post-force pass over local atoms. See plugins/README.md. */

#ifndef BKFLOW_FIX_BK_SUBSTRATE_H
#define BKFLOW_FIX_BK_SUBSTRATE_H

#include "bk_model.h"
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
  void initial_integrate(int) override;
  void final_integrate() override;
  void reset_dt() override;
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

  // LAMMPS's simulation time at the current step (the t of bk/stress; t0 of the anchors)
  double current_time() const;
  // whether the fix has contacts (friction), whose load phases bk/phase samples
  bool has_contacts() const { return contact != BK_NO_CONTACT; }
  // the contacts' phase sums of the current step (bk_model.h, BK_NPHASE values),
  // reduced over every rank: collective
  virtual void contact_phase(double *sums);

  // per-atom state columns
  enum { AX, AY, DRX, DRY, VHX, VHY, NSTATE };

 protected:    // FixBKFused (fix_bk_fused.h), the fused path, shares all of it
  friend struct BKSubstrateTable;

  // model parameters (docs/model.md "Forces on particle i")
  int bonds_on = 0, drive_on = 0;
  int contact = BK_NO_CONTACT;   // the contact rule (bk_model.h), none without friction
  int damping = BK_NO_DAMPING;   // the damping scheme (bk_model.h), none when gamma = 0
  double kb = 0.0, r0 = 0.0;     // bond stiffness (force k_b (r - r0)) and rest length
  double vd = 0.0;               // plate velocity along +x
  double ke = 0.0, fmax = 0.0;   // contact spring, break threshold mu_s*sigma_n*A
  double mus = 0.0, sigman = 0.0, area = 0.0;
  double gamma = 0.0;            // damping rate
  std::string kd_name;           // name of the per-atom double property holding k_d^i
  int kd_index = -1;

  double **state = nullptr;      // AX, AY: anchor at t0 (unwrapped); DR*: contact
                                 // displacement; VH*: half-step velocity of the last post_force
  double **u = nullptr;          // displacement r_i(t) - r_i(t0), local atoms and ghosts
  double **offset = nullptr;     // periodic offset (ix Lx, iy Ly) of local atoms: r = x + offset
  int nmax_u = 0;                // rows of u and offset

  // bond list, rebuilt at every reneighbouring: pair (i, j), the periodic shift that puts j
  // at its lattice image of i, and whether j is local (force applied to both ends)
  int nblist = 0, maxblist = 0;
  int *bl_i = nullptr, *bl_j = nullptr, *bl_both = nullptr;
  double *bl_sx = nullptr, *bl_sy = nullptr;
  double t0 = 0.0;               // simulation time at which anchors were taken
  // the plate's clock, time since t0 counted in whole steps: elapsed = elapsed_base +
  // (ntimestep - step_base) * dt_base, rebased only when the time step changes. LAMMPS's
  // own clock (atime) is re-summed at every run command, so a run split into chunks would
  // otherwise differ from one long run in the last bits, which the dynamics then amplify.
  double elapsed_base = 0.0, dt_base = 0.0;
  bigint step_base = 0;
  int vh_valid = 0;              // VH* hold the velocity used by the last post_force
  int integrate = 0;             // `integrate`: the fix also does fix nve and fix enforce2d
  double dtv = 0.0, dtf = 0.0;   // fix nve's step sizes

  // per-step accumulators (local), reduced lazily in compute_vector()
  double sum_fx_drive = 0.0;
  bigint nbreak_step = 0, nbreak_total = 0;
  double plate_shift = 0.0;
  double rmax_local = 0.0;       // longest bond seen in the last step (local atoms)
  int reduced = 0;
  double reduced_vec[3] = {0.0, 0.0, 0.0};

  int double_property(const char *name, const char *keyword);
  double plate_now();    // the plate's shift at the current step (rebases the clock on a new dt)
  void grow_displacements();
  void update_offsets();
  void update_displacements(int ghosts);
  void build_bond_list();
  void apply_forces(int advance);
  double bond_forces();
  template <int DRIVE, int CONTACT, int DAMPING, int ADVANCE> void eval();
  void enforce2d();
  template <bool DRIFT> void nve_step();
};

}    // namespace LAMMPS_NS

#endif
