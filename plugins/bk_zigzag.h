/* bkflow LAMMPS plugin: the zigzag rule of src/bkflow/observables/stress.py, shared by fix bk/slips and
   fix bk/fronts so that both see the very same slip events (and the analysis finds them again
   in stress.csv). A maximum is the highest sample before sigma_x falls by more than
   `threshold`; its minimum is the lowest sample before sigma_x rises again by more than
   `threshold`; the rise confirms the event (max, min), and the sample that confirms it is the
   next running maximum. */

#ifndef BKFLOW_BK_ZIGZAG_H
#define BKFLOW_BK_ZIGZAG_H

#include "lmptype.h"

namespace LAMMPS_NS {

struct BKZigzag {
  enum Event { NONE, NEW_MAX, FALL, NEW_MIN, CONFIRMED };

  double threshold = 0.0;
  int falling = 0;                    // 0: following a maximum, 1: following a minimum
  double smax = 0.0, smin = 0.0;      // running maximum / minimum of sigma_x
  bigint step_max = -1, step_min = -1;
  bigint event_max = -1, event_min = -1;    // the steps of the last confirmed event

  /* feed one sample; NEW_MAX: a new running maximum (also the first sample, and the sample
     that confirms an event, which feed() reports as CONFIRMED); FALL: sigma_x fell by more
     than the threshold, this sample is the first running minimum; NEW_MIN: a lower minimum;
     CONFIRMED: the event (event_max, event_min) is complete and this sample is the next
     running maximum; NONE: nothing of the above. */
  Event feed(double s, bigint step)
  {
    if (step_max < 0) {
      smax = s;
      step_max = step;
      return NEW_MAX;
    }
    if (!falling) {
      if (s > smax) {
        smax = s;
        step_max = step;
        return NEW_MAX;
      }
      if (smax - s > threshold) {
        falling = 1;
        smin = s;
        step_min = step;
        return FALL;
      }
      return NONE;
    }
    if (s < smin) {
      smin = s;
      step_min = step;
      return NEW_MIN;
    }
    if (s - smin > threshold) {
      event_max = step_max;
      event_min = step_min;
      falling = 0;
      smax = s;
      step_max = step;
      return CONFIRMED;
    }
    return NONE;
  }
};

}    // namespace LAMMPS_NS

#endif
