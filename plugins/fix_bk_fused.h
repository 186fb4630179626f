/* bkflow LAMMPS plugin: `fix ID all bk/substrate ... fused`, the fast path of fix
   bk/substrate. It integrates the layer itself (it replaces fix nve and fix enforce2d): the
   whole velocity-Verlet step of the model in one fused pass over arrays kept in lattice order,
   with the bonds found by index arithmetic, mirrored into LAMMPS's positions and velocities
   at the steps where something reads them. On several MPI ranks each rank holds a block of
   lattice rows (LAMMPS's sub-domains cut between rows) and trades its boundary rows with its
   neighbours every step. See plugins/README.md ("The fused path"). */

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
  // Lx of a lattice the fused path runs, 0 if it cannot; why not in *why (fix_bk_fused.cpp).
  // Collective.
  static int fused_lattice(class LAMMPS *, std::string *why = nullptr);
  // the first row of block j of K blocks of an Ly-row lattice (block j: rows [first(j),
  // first(j + 1)))
  static int block_first_row(int j, int K, int Ly)
  {
    return static_cast<int>(static_cast<long long>(j) * Ly / K);
  }

 private:

  double **xu = nullptr;              // per atom: exact unwrapped position from a restart
                                     // file (NaN: none, use x + offset)
  std::vector<int> reader_every;     // Nevery of the other fixes' end_of_step (not bk/stress)
  std::vector<Fix *> reneighboring;  // fixes that may force a reneighbouring
  bool lattice_ready = false;    // lattice found and arrays allocated
  bool have_state = false;       // arrays hold the state of the last step
  int Lx = 0, Ly = 0, N = 0;
  // this rank's block of rows: [row0, row0 + nrows), nloc = nrows Lx particles, lattice
  // particle k (local index k) being atom ID row0 Lx + k + 1; K blocks (ranks), a slab when
  // K > 1 (bkfused::Model::slab)
  int row0 = 0, nrows = 0, nloc = 0, nblocks = 1;
  std::vector<double> halo_send, halo_recv;
  double halo_time = 0.0;    // seconds in halo_start and halo_wait this run (this rank), and
                             // the exchanges
  bigint halo_calls = 0;
  double mass = 0.0;

  bkfused::Kernel kernel{};
  bkfused::Model model;
  bkfused::Arrays arr{};
  bkfused::Mirror mirror_to;
  std::vector<double> pool;    // every array of `arr`, 64-byte aligned inside
  std::vector<int> loc;        // LAMMPS's local index of lattice particle k
  std::vector<double> ox, oy;  // its periodic offset (ix Lx, iy Ly): X = x + offset
  std::vector<double> z;       // and its z (constant in 2D)
  bool identity = false;       // loc[k] == k for every k

  bigint sigma_step = -1, rmax_step = -1;    // steps of the cached sigma_x and longest bond
  double sigma_value = 0.0, rmax_value = 0.0;

  double sigma_x() override;
  double breaks(bool total) override;
  double longest_bond() override;
  int path_code() const override;
  void local_energies(double *e) override;

  bool mirror_due(bigint step) const;
  void build_lattice();
  void find_lattice();
  void report_stray(tagint all);
  static tagint first_stray(class LAMMPS *, int Lx, int Ly, int K);
  static void halo_start(void *self, const double *x, const double *y);
  static void halo_wait(void *self, double *x, double *y);
  MPI_Request halo_req[4];
  MPI_Comm halo_comm = MPI_COMM_NULL;    // a duplicate of world: the halo's tags are its own
  bool in_step = false;                  // inside the step's kernel (the halo's timing)
  bool exchanged_in_setup = false;       // this run's setup exchanged atoms (not `pre no`)
  bool unexchanged_start = false;        // update_map at a run's start with no exchange
  bool chosen = false;                   // `integrate` chose this path when the fix was made
  double cutoff_replaced = -1.0;         // the ghost cutoff this fix lowered (-1: none),
                                         // given back when the fix is deleted (unfix)
  bigint setup_step = -1;                // the step of the last setup()
  void row_totals(const std::vector<double> &rows, int w, double *total) const;
  double row_sum_total(const std::vector<double> &rows) const;
  void update_map();
  void adopt_atoms();
  void sync_state();
  void set_model();
  void bond_r2(int k, double &rx2, double &uy2) const;
};

}    // namespace LAMMPS_NS

#endif
