/* bkflow LAMMPS plugin: fix bk/reduce, what a run's analysis reads of sigma_x and of the
   contacts' phases, reduced as the run goes (see fix_bk_reduce.cpp). */

#ifndef BKFLOW_FIX_BK_REDUCE_H
#define BKFLOW_FIX_BK_REDUCE_H

#include "fix_bk_reader.h"

#include <cstdio>
#include <string>
#include <vector>

namespace LAMMPS_NS {

/* one NumPy .npy file of fixed-size records: a 512-byte header that says how many, rewritten
   at every flush, then the records; the last `pending` records are rewritten at every flush
   (the state of the run so far, not yet final) */
struct BKNpy {
  std::string name;
  std::string descr;       // the structured dtype, NumPy's spelling
  int nfields = 0;         // doubles per record (int64 fields are stored as such, see put)
  int nint = 0;            // the first nint fields are int64
  FILE *fp = nullptr;
  bigint nfinal = 0;       // final records on disk (rank 0)
  bigint nrecords = 0;     // final records (every rank)
  std::vector<double> staged;    // final records not yet written
  std::vector<double> pending;   // the non-final tail (0 or 1 record)
};

class FixBKReduce : public FixBKReader {
 public:
  FixBKReduce(class LAMMPS *, int, char **);
  ~FixBKReduce() override;
  void init() override;
  void post_run() override;
  void write_restart(FILE *) override;
  void restart(char *) override;
  double compute_vector(int) override;

 private:
  static constexpr int NLEDGER = 8;
  int with_energy = 0, with_phase = 0;
  bigint phase_every = 0, block = 0;
  BKZigzag zigzag;
  double ledger_now[NLEDGER] = {}, ledger_max[NLEDGER] = {}, ledger_min[NLEDGER] = {};
  // the block under way: its index, stress samples and sums (see fix_bk_reduce.cpp)
  bigint block_k = -1;
  std::vector<double> sums;
  BKNpy extrema, blocks;
  std::chrono::steady_clock::time_point last_write;

  void sample() override;
  void open(BKNpy &f, const char *name);
  void stage_extremum(BKNpy &f, bigint step, double sigma, const double *ledger);
  void close_block();
  void write_out();
  void write_file(BKNpy &f);
  [[noreturn]] void failed(const BKNpy &f);
  int state_size() const;
};

}    // namespace LAMMPS_NS

#endif
