/* bkflow LAMMPS plugin: fix bk/stress

     fix ID group bk/stress Nevery substrate-fix-ID file FILE [energy]

   Every Nevery steps (and at the first step of a run when it is a multiple of Nevery) it
   appends one line "t,sigma_x" to FILE, sigma_x being element 1 of the substrate fix's global
   vector and t the simulation time. FILE starts with the header "t,sigma_x" (the stress.csv
   of bkflow). sigma_x is written as the shortest decimal that reads back as the same double
   (std::to_chars), t to 10 significant digits. The lines go through a 1 MB buffer, flushed at
   the end of every run command and at most a second after the last flush, instead of one
   write and flush per line as fix print does, which at one line every ~7 steps costs 4-24% of
   a run against 1-2% for the buffer (N = 900 to 100, benchmarks/RESULTS.md; measured by
   benchmarks/measure/throughput.py --compare-output).

   With `energy` each line also holds the contact breaks since the substrate fix was defined
   and its energy ledger (docs/model.md "Energy"; the substrate fix needs its own keyword
   `energy` for the running sums): header
   "t,sigma_x,breaks,e_bond,e_drive,e_contact,e_kinetic,work,diss_break,diss_damp", each value
   the shortest decimal that reads back as the same double. */

#include "fix_bk_stress.h"

#include "error.h"
#include "fix_bk_layer.h"
#include "update.h"

#include <algorithm>
#include <charconv>
#include <cstring>

using namespace LAMMPS_NS;

namespace {
const char *USAGE = "fix ID group bk/stress Nevery substrate-fix-ID file FILE [energy] [append]";
// the slots written after sigma_x with `energy`
constexpr int LEDGER[] = {BK_SLOT_BREAKS_TOTAL, BK_SLOT_E_BOND,    BK_SLOT_E_DRIVE,
                          BK_SLOT_E_CONTACT,    BK_SLOT_E_KINETIC, BK_SLOT_WORK,
                          BK_SLOT_DISS_BREAK,   BK_SLOT_DISS_DAMP};
constexpr int NLEDGER = sizeof(LEDGER) / sizeof(LEDGER[0]);
}    // namespace

FixBKStress::FixBKStress(LAMMPS *lmp, int narg, char **arg) : FixBKReader(lmp, narg, arg, USAGE)
{
  if (narg < 7) error->all(FLERR, "Illegal fix bk/stress command: {}", USAGE);
  for (int iarg = 7; iarg < narg; iarg++) {
    if (strcmp(arg[iarg], "energy") == 0)
      with_energy = 1;
    else if (strcmp(arg[iarg], "append") == 0)
      appending = 1;
    else
      error->all(FLERR, "Illegal fix bk/stress command: {}", USAGE);
  }
  npy.field("step", "<i8");
  npy.field("sigma", "<f8");
  if (with_energy)
    for (const char *name : {"breaks", "e_bond", "e_drive", "e_contact", "e_kinetic", "work",
                             "diss_break", "diss_damp"})
      npy.field(name, "<f8");
  open_file(5, narg, arg);
  if (fp && !appending)
    write(std::string(with_energy ? "t,sigma_x,breaks,e_bond,e_drive,e_contact,e_kinetic,work,"
                                    "diss_break,diss_damp\n"
                                  : "t,sigma_x\n"));
}

void FixBKStress::sample()
{
  const double sigma = substrate->compute_vector(BK_SLOT_SIGMA);    // collective: every rank calls it
  double ledger[NLEDGER];
  if (with_energy)
    for (int k = 0; k < NLEDGER; k++) ledger[k] = substrate->compute_vector(LEDGER[k]);
  if (npy_mode) {    // step, sigma_x and the ledger, binary
    double rec[2 + NLEDGER] = {BKNpy::as_double(update->ntimestep), sigma};
    if (with_energy) std::copy(ledger, ledger + NLEDGER, rec + 2);
    record(rec);
    flush_if_due();
    return;
  }
  if (!fp) return;
  const double t = substrate->current_time();
  char line[64 + 32 * NLEDGER];
  // t to 10 significant digits (a label; events are matched by step), sigma_x exact
  char *end = std::to_chars(line, line + 30, t, std::chars_format::general, 10).ptr;
  *end++ = ',';
  end = std::to_chars(end, line + 62, sigma).ptr;
  if (with_energy)
    for (int k = 0; k < NLEDGER; k++) {
      *end++ = ',';
      end = std::to_chars(end, end + 30, ledger[k]).ptr;
    }
  *end++ = '\n';
  write(line, end - line);
  flush_if_due();
}
