/* bkflow LAMMPS plugin: `fix ID all bk/substrate ... fused`, the single-rank fast path of fix
   bk/substrate. It integrates the layer itself (it replaces fix nve and fix enforce2d): the
   whole velocity-Verlet step of the model in one fused pass over arrays kept in lattice order,
   with the bonds found by index arithmetic, mirrored into LAMMPS's positions and velocities
   at the steps where something reads them. See plugins/README.md ("The fused path"). */

#ifndef BKFLOW_FIX_BK_FUSED_H
#define BKFLOW_FIX_BK_FUSED_H

#include "bk_fused_kernel.h"
#include "fix_bk_layer.h"

#include <string>
#include <vector>

namespace LAMMPS_NS {

class FixBKFused : public FixBKLayer {
 public:
  FixBKFused(class LAMMPS *, int, char **);
  ~FixBKFused() override;
  int setmask() override;
  void init() override;
  void setup(int) override;
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

  // restart columns: FixBKLayer's, then the exact unwrapped position
  enum { XU = NSTATE, YU, NRESTART };
  // Lx of a lattice the fused path runs, 0 if it cannot; why not in *why (fix_bk_fused.cpp)
  static int fused_lattice(class LAMMPS *, std::string *why = nullptr);

 private:

  double **xu = nullptr;              // per atom: exact unwrapped position from a restart
                                     // file (NaN: none, use x + offset)
  std::vector<int> reader_every;     // Nevery of the other fixes' end_of_step (not bk/stress)
  std::vector<Fix *> reneighboring;  // fixes that may force a reneighbouring
  bool lattice_ready = false;    // lattice found and arrays allocated
  bool have_state = false;       // arrays hold the state of the last step
  int Lx = 0, Ly = 0, N = 0;
  double mass = 0.0;

  bkfused::Kernel kernel{};
  bkfused::Model model;
  bkfused::Arrays arr{};
  bkfused::Mirror mirror_to;
  std::vector<double> pool;    // every array of `arr`, 64-byte aligned inside
  std::vector<int> loc;        // local index of lattice particle k (atom ID k + 1)
  std::vector<double> ox, oy;  // its periodic offset (ix Lx, iy Ly): X = x + offset
  std::vector<double> z;       // and its z (constant in 2D)
  bool identity = false;       // loc[k] == k for every k

  bigint sigma_step = -1, rmax_step = -1;    // steps of the cached sigma_x and longest bond
  double sigma_value = 0.0, rmax_value = 0.0;

  double sigma_x() override;
  double breaks(bool total) override { return static_cast<double>(total ? nbreak_total
                                                                         : nbreak_step); }
  double longest_bond() override;
  int path_code() const override;
  void local_energies(double *e) override;

  bool mirror_due(bigint step) const;
  void build_lattice();
  void update_map();
  void adopt_atoms();
  void sync_state();
  void set_model();
  void bond_r2(int k, double &rx2, double &uy2) const;
};

}    // namespace LAMMPS_NS

#endif
