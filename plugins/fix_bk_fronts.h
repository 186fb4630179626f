/* bkflow LAMMPS plugin: fix bk/fronts, the slip rate of every particle through each slip
   event of a fix bk/substrate's sigma_x, to follow rupture fronts. See plugins/README.md. */

#ifndef BKFLOW_FIX_BK_FRONTS_H
#define BKFLOW_FIX_BK_FRONTS_H

#include "bk_zigzag.h"
#include "fix_bk_reader.h"

#include <deque>
#include <vector>

namespace LAMMPS_NS {

class FixBKFronts : public FixBKReader {
 public:
  FixBKFronts(class LAMMPS *, int, char **);
  double compute_vector(int) override;
  double memory_usage() override;

 private:
  bigint start = 0;        // events whose maximum lies before this step are not written
  bigint limit = -1;       // at most this many events written (-1: all)
  BKZigzag zigzag;
  bigint nevents = 0, nwritten = 0;
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
