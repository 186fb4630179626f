/* bkflow LAMMPS plugin: fix bk/reduce, what a run's analysis reads of sigma_x and of the
   contacts' phases, reduced as the run goes (see fix_bk_reduce.cpp). */

#ifndef BKFLOW_FIX_BK_REDUCE_H
#define BKFLOW_FIX_BK_REDUCE_H

#include "bk_npy.h"
#include "fix_bk_reader.h"

#include <cstdio>
#include <string>
#include <vector>

namespace LAMMPS_NS {

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
  int with_extrema = 1;    // `extrema none`: the blocks only (a companion run's)
  bigint phase_every = 0, block = 0;
  BKZigzag zigzag;
  double ledger_now[NLEDGER] = {}, ledger_max[NLEDGER] = {}, ledger_min[NLEDGER] = {};
  // the block under way: its index, stress samples and sums (see fix_bk_reduce.cpp)
  bigint block_k = -1;
  std::vector<double> sums;
  BKNpy extrema, blocks;
  std::chrono::steady_clock::time_point last_write;

  void sample() override;
  void parse_options(int narg, char **arg);
  void declare_fields();
  void phase_statistics(double *ph);
  void follow_extrema(double sigma, bigint step);
  void add_to_block(bigint step, double sigma, const double *ph, bool phase_now);
  void open(BKNpy &f, const char *name);
  void stage_extremum(bigint step, double sigma, const double *ledger);
  void close_block();
  void write_out();
  [[noreturn]] void failed(const BKNpy &f);
};

}    // namespace LAMMPS_NS

#endif
