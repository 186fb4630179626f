/* bkflow: fix bk/stress, the shear stress series written by the plugin itself */

#ifdef FIX_CLASS
// clang-format off
FixStyle(bk/stress,FixBKStress);
// clang-format on
#else

#ifndef LMP_FIX_BK_STRESS_H
#define LMP_FIX_BK_STRESS_H

#include "fix.h"

#include <chrono>
#include <cstdio>
#include <vector>

namespace LAMMPS_NS {

class FixBKStress : public Fix {
 public:
  FixBKStress(class LAMMPS *, int, char **);
  ~FixBKStress() override;
  int setmask() override;
  void init() override;
  void setup(int) override;
  void end_of_step() override;
  void post_run() override;

 private:
  char *substrate_id;
  class Fix *substrate;
  char *filename;
  FILE *fp;
  std::vector<char> buffer;  // stdio buffer of fp: lines reach the disk in blocks
  bigint last_step;          // last written step (setup() and end_of_step() may meet)
  std::chrono::steady_clock::time_point last_flush;

  void sample();
};

}    // namespace LAMMPS_NS

#endif
#endif
