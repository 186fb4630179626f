/* bkflow LAMMPS plugin: fix bk/stress, the shear stress series t,sigma_x of a fix
   bk/substrate, written by the plugin itself through a buffer. See plugins/README.md. */

#ifndef BKFLOW_FIX_BK_STRESS_H
#define BKFLOW_FIX_BK_STRESS_H

#include "fix_bk_reader.h"

namespace LAMMPS_NS {

class FixBKStress : public FixBKReader {
 public:
  FixBKStress(class LAMMPS *, int, char **);

 private:
  int with_energy = 0;    // `energy`: the breaks and the energy ledger after sigma_x
  void sample() override;
};

}    // namespace LAMMPS_NS

#endif
