/* bkflow LAMMPS plugin: fix bk/psi, the square-lattice order Psi(t) computed in the run (see
   fix_bk_psi.cpp). */

#ifndef BKFLOW_FIX_BK_PSI_H
#define BKFLOW_FIX_BK_PSI_H

#include "bk_npy.h"
#include "fix.h"

#include <chrono>
#include <vector>

namespace LAMMPS_NS {

class FixBKPsi : public Fix {
 public:
  FixBKPsi(class LAMMPS *, int, char **);
  ~FixBKPsi() override;
  int setmask() override;
  void init() override;
  void setup(int) override;
  void end_of_step() override;
  void post_run() override;
  double compute_scalar() override;

 private:
  int lx = 0, ly = 0;
  int appending = 0;
  bool first_setup = true;
  bigint last_step = -1;
  double last_psi = 0.0;
  BKNpy out;
  std::chrono::steady_clock::time_point last_write;
  std::vector<double> xy, all;    // the layer's unwrapped positions, by particle (2N)

  void sample();
  void gather_positions();
  void record(double psi);
};

}    // namespace LAMMPS_NS

#endif
