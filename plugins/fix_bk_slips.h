/* bkflow: fix bk/slips. Follows sigma_x of a fix bk/substrate on the same samples as the
   stress series and writes the atom positions at the maximum and at the following minimum
   of every slip event (zigzag rule, src/bkflow/stress.py), without dumping every step.
   See plugins/README.md. */

#ifndef BKFLOW_FIX_BK_SLIPS_H
#define BKFLOW_FIX_BK_SLIPS_H

#include "fix.h"

#include <vector>

namespace LAMMPS_NS {

class FixBKSlips : public Fix {
 public:
  FixBKSlips(class LAMMPS *, int, char **);
  ~FixBKSlips() override;
  int setmask() override;
  void init() override;
  void setup(int) override;
  void end_of_step() override;
  double compute_vector(int) override;

 private:
  char *substrate_id;
  class Fix *substrate;
  double threshold;
  bigint start;          // events whose maximum lies before this step are not written
  char *filename;
  FILE *fp;

  int falling;           // zigzag state: 0 = following a maximum, 1 = following a minimum
  double smax, smin;     // running maximum / minimum of sigma_x
  bigint step_max, step_min;
  bigint last_step;      // last sampled step (setup() and end_of_step() may meet)
  bigint nevents, nwritten;

  // snapshots of local atoms: tag, x, y, ix, iy (5 doubles per atom)
  std::vector<double> snap_max, snap_min;

  void sample();
  void snapshot(std::vector<double> &buf);
  void write_frame(const std::vector<double> &buf, bigint step);
};

}    // namespace LAMMPS_NS

#endif
