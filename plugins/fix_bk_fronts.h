/* bkflow LAMMPS plugin: fix bk/fronts, the slip rate of every particle through each slip
   event of a fix bk/substrate's sigma_x, to follow rupture fronts. See plugins/README.md. */

#ifndef BKFLOW_FIX_BK_FRONTS_H
#define BKFLOW_FIX_BK_FRONTS_H

#include "fix_bk_reader.h"

#include <deque>
#include <vector>

namespace LAMMPS_NS {

class FixBKFronts : public FixBKEvents {
 public:
  FixBKFronts(class LAMMPS *, int, char **);
  double memory_usage() override;

 private:
  bigint natoms = 0;

  // the samples since the running maximum: step, and the local atoms' tags and v_x
  struct Sample {
    bigint step;
    std::vector<tagint> tag;
    std::vector<float> vx;
  };
  std::deque<Sample> samples;
  bool truncated = false;    // the oldest samples of the open event were dropped (cap)

  void sample() override;
  void record(bigint step);
  void write_event(bigint from, bigint to);
};

}    // namespace LAMMPS_NS

#endif
