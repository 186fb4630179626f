/* bkflow LAMMPS plugin: fix bk/phase

     fix ID group bk/phase Nevery substrate-fix-ID file FILE

   Every Nevery steps (and at the first step of a run when it is a multiple of Nevery) it
   appends one line "t,R,Z_re,Z_im,R2,u_mean,u_std" to FILE (bkflow's phase.csv): with the
   contacts' load phases u_i = k_e |dr_i| / (mu_s sigma_n A) in [0, 1) (docs/model.md "Contact
   phase"), Z = (1/N) sum_i exp(2 pi i u_i) (the Kuramoto order parameter), R = |Z|, R2 = |(1/N)
   sum_i exp(4 pi i u_i)| (its second harmonic), and the mean and standard deviation of u
   (1/2 and 1/sqrt(12) = 0.2887 for uniform phases). The sums come from the substrate fix
   (FixBKLayer::contact_phase, one pass over the contacts, reduced over ranks); t is
   written to 10 significant digits, the rest as the shortest decimal that reads back as the
   same double, through the buffer of FixBKReader. */

#include "fix_bk_phase.h"

#include "bk_model.h"
#include "error.h"
#include "fix_bk_layer.h"
#include "update.h"

#include <charconv>
#include <cmath>
#include <cstring>

using namespace LAMMPS_NS;

namespace {
const char *USAGE = "fix ID group bk/phase Nevery substrate-fix-ID file FILE [append]";
}    // namespace

FixBKPhase::FixBKPhase(LAMMPS *lmp, int narg, char **arg) : FixBKReader(lmp, narg, arg, USAGE)
{
  if (narg == 8 && strcmp(arg[7], "append") == 0)
    appending = 1;
  else if (narg != 7)
    error->all(FLERR, "Illegal fix bk/phase command: {}", USAGE);
  npy.field("step", "<i8");
  for (const char *name : {"R", "Z_re", "Z_im", "R2", "u_mean", "u_std"}) npy.field(name, "<f8");
  open_file(5, narg, arg);
  if (fp && !appending) write(std::string("t,R,Z_re,Z_im,R2,u_mean,u_std\n"));
}

void FixBKPhase::init()
{
  FixBKReader::init();
  if (!substrate->has_contacts())
    error->all(FLERR, "fix bk/phase: fix {} has no friction, so no contact phases",
               substrate->id);
}

void FixBKPhase::sample()
{
  double s[BK_NPHASE];
  substrate->contact_phase(s);    // collective: every rank calls it
  if (!fp && !npy_mode) return;
  const double n = s[BK_PH_N] > 0.0 ? s[BK_PH_N] : 1.0;
  const double zr = s[BK_PH_C1] / n, zi = s[BK_PH_S1] / n;
  const double z2r = s[BK_PH_C2] / n, z2i = s[BK_PH_S2] / n;
  const double mean = s[BK_PH_U] / n, var = s[BK_PH_UU] / n - mean * mean;
  const double values[6] = {std::sqrt(zr * zr + zi * zi), zr, zi,
                            std::sqrt(z2r * z2r + z2i * z2i), mean,
                            std::sqrt(var > 0.0 ? var : 0.0)};
  if (npy_mode) {    // step and the six statistics, binary
    const double rec[7] = {BKNpy::as_double(update->ntimestep), values[0], values[1],
                           values[2], values[3], values[4], values[5]};
    record(rec);
    flush_if_due();
    return;
  }
  char line[256];
  char *end = std::to_chars(line, line + 30, substrate->current_time(),
                            std::chars_format::general, 10).ptr;
  for (double v : values) {
    *end++ = ',';
    end = std::to_chars(end, line + 250, v).ptr;
  }
  *end++ = '\n';
  write(line, end - line);
  flush_if_due();
}
