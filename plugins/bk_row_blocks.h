/* bkflow LAMMPS plugin: the fused path's domain decomposition (plugins/README.md "Several
   ranks"). The K ranks stand in one column (`processors 1 * 1`) and rank j holds the lattice
   rows [first_row(j), first_row(j + 1)), a block; LAMMPS's sub-domains are cut between the
   blocks, so that LAMMPS's local atoms are the rank's rows, and atoms never migrate. Every
   step each block sends its first row to the block below and its last row to the block above
   (the halo exchange), whose ghost rows they become. Sums over the lattice are made row by
   row and added in row order, so that any number of blocks gives the same bits. */

#ifndef BKFLOW_BK_ROW_BLOCKS_H
#define BKFLOW_BK_ROW_BLOCKS_H

#include "bk_fused_kernel.h"
#include "lmptype.h"

#include <mpi.h>
#include <string>
#include <vector>

namespace LAMMPS_NS {
class LAMMPS;

class BKRowBlocks {
 public:
  // the first row of block j of K blocks of an Ly-row lattice
  static int first_row(int j, int K, int Ly)
  {
    return static_cast<int>(static_cast<long long>(j) * Ly / K);
  }

  int Lx = 0, Ly = 0;    // the lattice
  int K = 1;             // blocks (ranks); K > 1: each block a slab with ghost rows
  // this rank's block: rows [row0, row0 + nrows), nloc = nrows Lx particles, lattice particle
  // k (local index k) being atom ID row0 Lx + k + 1
  int row0 = 0, nrows = 0, nloc = 0;

  BKRowBlocks() = default;
  BKRowBlocks(const BKRowBlocks &) = delete;
  BKRowBlocks &operator=(const BKRowBlocks &) = delete;
  ~BKRowBlocks();

  // the block at position j of the column of K ranks, in a lattice of Lx x Ly
  void divide(int lx, int ly, int nblocks, int j);
  bool slab() const { return K > 1; }
  // "one rank" or "K ranks, blocks of rows a-b | c-d ..." (the log)
  std::string describe() const;

  // LAMMPS's sub-domains cut between the blocks' rows (a non-uniform brick layout)
  void cut_subdomains(LAMMPS *lmp) const;
  // the lowest ID of this rank's atoms outside the sub-domain of its row's block, or the
  // largest tagint
  tagint first_stray(LAMMPS *lmp) const;
  // stops the run on every rank if `all` (the lowest stray ID over ranks) is not the largest
  // tagint
  void report_stray(LAMMPS *lmp, tagint all) const;

  // the halo: its buffers and communicator (a slab), and the kernel's hooks in `arr`
  void open_halo(LAMMPS *lmp, bkfused::Arrays &arr);
  // x and y of the ghost rows from the neighbouring blocks, at once
  void exchange(double *x, double *y);
  // the exchanges' time is counted while `timing` (the step's kernel), and logged at a run's
  // end (collective); the count starts again
  bool timing = false;
  void log_halo_time(LAMMPS *lmp, const char *fix_id);

  // sums over the lattice of per-row values (collective): rows[w r + j] is value j of row r
  // of this block (width w values a row); the blocks' rows are gathered exactly (a sum of
  // one value and zeros) and added in row order into total[j]
  void row_totals(const std::vector<double> &rows, int w, double *total, MPI_Comm world) const;
  double row_sum_total(const std::vector<double> &rows, MPI_Comm world) const;

 private:
  LAMMPS *lmp = nullptr;
  std::vector<double> halo_send, halo_recv;
  MPI_Request halo_req[4];
  MPI_Comm halo_comm = MPI_COMM_NULL;    // a duplicate of world: the halo's tags are its own
  double halo_time = 0.0;                // seconds in halo_start and halo_wait this run
  bigint halo_calls = 0;                 // and the exchanges

  static void halo_start(void *self, const double *x, const double *y);
  static void halo_wait(void *self, double *x, double *y);
};

}    // namespace LAMMPS_NS

#endif
