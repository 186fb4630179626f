/* bkflow LAMMPS plugin: fix bk/substrate on its general path, the forces on the 2D
   Burridge-Knopoff layer of docs/model.md (bonds, drive spring to a moving plate,
   shear-history friction, viscous damping) in one post-force pass over local atoms, on any
   number of ranks; with `integrate`, it also does fix nve's and fix enforce2d's work. A
   sibling of the fused path (fix_bk_fused.h) under FixBKLayer. The forces of a step are in
   fix_bk_substrate_forces.cpp, the rest in fix_bk_substrate.cpp. See plugins/README.md. */

#ifndef BKFLOW_FIX_BK_SUBSTRATE_H
#define BKFLOW_FIX_BK_SUBSTRATE_H

#include "fix_bk_layer.h"

namespace LAMMPS_NS {

class FixBKSubstrate : public FixBKLayer {
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
  double compute_scalar() override;
  int pack_forward_comm(int, int *, double *, int, int *) override;
  void unpack_forward_comm(int, int, double *) override;
  double memory_usage() override;

 private:
  friend struct BKSubstrateTable;

  double **u = nullptr;          // displacement r_i(t) - r_i(t0), local atoms and ghosts
  double **offset = nullptr;     // periodic offset (ix Lx, iy Ly) of local atoms: r = x + offset
  int nmax_u = 0;                // rows of u and offset

  // bond list, rebuilt at every reneighbouring: pair (i, j), the periodic shift that puts j
  // at its lattice image of i, and whether j is local (force applied to both ends)
  int nblist = 0, maxblist = 0;
  int *bl_i = nullptr, *bl_j = nullptr, *bl_both = nullptr;
  double *bl_sx = nullptr, *bl_sy = nullptr;
  double dtv = 0.0, dtf = 0.0;   // fix nve's step sizes (`integrate`)

  // per-step accumulators (local), reduced lazily for the output vector
  double sum_fx_drive = 0.0;
  double rmax_local = 0.0;       // longest bond seen in the last step (local atoms)
  int reduced = 0;
  double reduced_vec[3] = {0.0, 0.0, 0.0};

  double sigma_x() override;
  double breaks(bool total) override;
  double longest_bond() override;
  int path_code() const override { return BK_PATH_GENERAL; }
  void reduce();

  void grow_displacements();
  void update_offsets();
  void update_displacements(int ghosts);
  void build_bond_list();
  void apply_forces(int advance);
  double bond_forces();
  template <int DRIVE, int CONTACT, int DAMPING, int ADVANCE, int LEDGER> void eval();
  void local_energies(double *e) override;
  void enforce2d();
  template <bool DRIFT> void nve_step();
};

}    // namespace LAMMPS_NS

#endif
