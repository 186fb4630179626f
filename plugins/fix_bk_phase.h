/* bkflow LAMMPS plugin: fix bk/phase, the series of the contacts' load-phase statistics of a
   fix bk/substrate (docs/model.md "Contact phase"), written by the plugin through a buffer.
   See plugins/README.md. */

#ifndef BKFLOW_FIX_BK_PHASE_H
#define BKFLOW_FIX_BK_PHASE_H

#include "fix_bk_reader.h"

namespace LAMMPS_NS {

class FixBKPhase : public FixBKReader {
 public:
  FixBKPhase(class LAMMPS *, int, char **);
  void init() override;

 private:
  void sample() override;
};

}    // namespace LAMMPS_NS

#endif
