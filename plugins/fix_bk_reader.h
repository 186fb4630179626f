/* bkflow LAMMPS plugin: FixBKReader, the common part of the fixes that sample sigma_x of a
   fix bk/substrate every Nevery steps and write what they find to a file (bk/stress,
   bk/slips). Their arguments start alike:

     fix ID group style Nevery substrate-fix-ID ... file FILE ...

   The base parses Nevery and the substrate ID, opens FILE on rank 0 behind a 1 MB buffer,
   finds and checks the substrate fix at init(), and calls sample() once per sampled step:
   every Nevery steps, and at the first step of a run when it is a multiple of Nevery. */

#ifndef BKFLOW_FIX_BK_READER_H
#define BKFLOW_FIX_BK_READER_H

#include "bk_npy.h"
#include "bk_zigzag.h"
#include "fix.h"

#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

namespace LAMMPS_NS {

class FixBKReader : public Fix {
 public:
  // reads arg[3] (Nevery) and arg[4] (substrate-fix-ID); usage names the full syntax
  FixBKReader(class LAMMPS *, int, char **, const char *usage_text);
  ~FixBKReader() override;
  int setmask() override;
  void init() override;
  void setup(int) override;
  void end_of_step() override;
  void post_run() override;
  double memory_usage() override;

 protected:
  const char *usage;
  class FixBKLayer *substrate = nullptr;    // the bk/substrate fix, set by init()
  FILE *fp = nullptr;                           // FILE on rank 0, nullptr elsewhere
  /* `append` (a run continued from a restart file): FILE is appended to, without a header,
     and the first setup's sample is left out (the run that wrote the restart file sampled
     that step already). A derived fix sets it before open_file() and skips its header. */
  int appending = 0;

  /* a FILE named *.npy is a NumPy file of records (bk_npy.h), its fields declared in `npy`
     by the style before open_file(), each sample given to record(); any other name is text,
     given to write() */
  BKNpy npy;
  bool npy_mode = false;
  void record(const double *values);
  // parses `file FILE` at arg[iarg] and opens FILE (rank 0); returns the next iarg
  int open_file(int iarg, int narg, char **arg);
  // writes to FILE (rank 0); a failed write (a full disk) stops the run with error->one
  void write(const char *data, std::size_t n);
  void write(const std::string &text) { write(text.data(), text.size()); }
  void flush();
  void flush_if_due();    // when the last flush is more than a second old
  // one sample at the current step, called on every rank (compute_vector is collective)
  virtual void sample() = 0;

 private:
  char *substrate_id = nullptr;
  char *filename = nullptr;
  std::vector<char> buffer;    // stdio buffer of fp: lines reach the disk in blocks
  bigint last_step = -1;       // last sampled step (setup() and end_of_step() may meet)
  bool first_setup = true;
  std::chrono::steady_clock::time_point last_flush;

  void sample_once();
  [[noreturn]] void write_failed();
};

/* FixBKEvents: the common part of the fixes that record slip events (bk/slips, bk/fronts):

     fix ID group style Nevery substrate-fix-ID threshold file FILE [start STEP] [limit K]
         [breaks]

   the zigzag rule with its threshold (bk_zigzag.h), the first step whose events are written
   (`start`), at most K events written (`limit`, where the style takes it), each contact's
   first break in the event (`breaks`, where the style takes it), and the global vector
   [1] events confirmed, [2] events written. */
class FixBKEvents : public FixBKReader {
 public:
  FixBKEvents(class LAMMPS *, int, char **, const char *usage_text, bool takes_limit,
              bool takes_breaks = false, bool takes_catalogue = false);
  double compute_vector(int) override;

 protected:
  BKZigzag zigzag;
  bigint start = 0;      // events whose maximum lies before this step are not written
  bigint limit = -1;     // at most this many events written (-1: all)
  bigint nevents = 0, nwritten = 0;
  int with_breaks = 0;    // `breaks`
  // `catalogue SLIPS CLUSTERS sx S_X kb K_B lattice LX LY` (bk/slips): each slip's row of
  // the event catalogue and its clusters, computed in the run (bk_catalogue.h)
  int with_catalogue = 0;
  char *catalogue_files[2] = {nullptr, nullptr};
  double cat_sx = 0.0, cat_kb = 0.0;
  int cat_lx = 0, cat_ly = 0;
  int exact = 0;    // `exact` (bk/slips): frames to 17 digits, not 9
  ~FixBKEvents() override;

  // whether an event whose maximum is at step `step_max` is to be written
  bool writes(bigint step_max) const
  {
    return step_max >= start && (limit < 0 || nwritten < limit);
  }

 private:
  // the keywords a style takes beyond `start` and `append`
  struct Keywords {
    bool limit, breaks, catalogue;
  };
  int parse_keyword(int iarg, int narg, char **arg, const Keywords &takes);
  static bool is_catalogue(int iarg, int narg, char **arg);
  int parse_catalogue(int iarg, char **arg);
};

}    // namespace LAMMPS_NS

#endif
