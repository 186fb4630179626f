/* bkflow LAMMPS plugin: fix bk/reduce

     fix ID group bk/reduce Nevery substrate-fix-ID threshold TH block B extrema FILE
         blocks FILE [phase Pevery] [energy] [append]

   What the analysis of a run reads of its shear stress and of its contacts' phases, reduced
   in the run instead of written as series (docs/running.md "What a run writes"):

   - FILE of `extrema`: the turning points of sigma_x (sampled every Nevery steps) by the
     zigzag rule (bk_zigzag.h) at threshold TH: each maximum once sigma_x has fallen from it
     by more than TH, each minimum once sigma_x has risen from it by more than TH, in turn
     (maximum first). The slips at any threshold >= TH are exactly those the same rule finds
     in the records (bkflow.observables.reduced; tests/observables/test_reduced.py). The last record is the extremum
     under way (the running maximum or minimum), rewritten until it is final. Fields: step
     (int64), sigma; with `energy` also the contact breaks and the energy ledger at that
     sample (the columns of bkflow.store.rundir.LEDGER_COLUMNS).
   - FILE of `blocks`: one record per block of B steps (B a multiple of Nevery and of
     Pevery), block k holding the samples of steps kB <= step < (k+1)B: n (int64, its
     sigma_x samples), sigma (their sum); with `phase` also n_phase (int64) and the sums over
     the block's phase samples (every Pevery steps) of R, Z_re, Z_im, |Z|^2, R2, u_mean, u_std
     (fix bk/phase's quantities); with `energy` the breaks and the ledger at the block's last
     sample. The last record is the block under way, rewritten until it is complete.

   With `extrema none` only the blocks are kept (what a steady-state verdict reads: the
   companion run of bkflow's steady protocol). Both files are NumPy .npy files (numpy.load
   reads them): a 512-byte header that holds the number of records, rewritten with the records
   at every flush (the end of every run command, and at most a second after the last write). Only rank 0 writes; the sums are the
   substrate fix's, reduced over ranks. The state (the zigzag's running extrema, the block
   under way, the records written) goes into restart files: a run continued from one with
   `append` writes what the uninterrupted run would have. */

#include "fix_bk_reduce.h"

#include "bk_interface.h"
#include "bk_model.h"
#include "comm.h"
#include "error.h"
#include "fix_bk_layer.h"
#include "update.h"

#include <cmath>
#include <cstring>

using namespace LAMMPS_NS;

namespace {
const char *USAGE = "fix ID group bk/reduce Nevery substrate-fix-ID threshold TH block B "
                    "extrema FILE blocks FILE [phase Pevery] [energy] [append]";
constexpr int LEDGER[] = {BK_SLOT_BREAKS_TOTAL, BK_SLOT_E_BOND,    BK_SLOT_E_DRIVE,
                          BK_SLOT_E_CONTACT,    BK_SLOT_E_KINETIC, BK_SLOT_WORK,
                          BK_SLOT_DISS_BREAK,   BK_SLOT_DISS_DAMP};
const char *LEDGER_NAMES[] = {"breaks", "e_bond",    "e_drive",    "e_contact",
                              "e_kinetic", "work", "diss_break", "diss_damp"};
const char *PHASE_NAMES[] = {"R", "Z_re", "Z_im", "Z2", "R2", "u_mean", "u_std"};
constexpr int NPHASE = 7;
constexpr auto WRITE_EVERY = std::chrono::seconds(1);

double as_double(bigint v)
{
  return BKNpy::as_double(static_cast<int64_t>(v));
}
}    // namespace

FixBKReduce::FixBKReduce(LAMMPS *lmp, int narg, char **arg) : FixBKReader(lmp, narg, arg, USAGE)
{
  if (narg < 13) error->all(FLERR, "Illegal fix bk/reduce command: {}", USAGE);
  if (strcmp(arg[5], "threshold") != 0 || strcmp(arg[7], "block") != 0 ||
      strcmp(arg[9], "extrema") != 0 || strcmp(arg[11], "blocks") != 0)
    error->all(FLERR, "Illegal fix bk/reduce command: {}", USAGE);
  zigzag.threshold = utils::numeric(FLERR, arg[6], false, lmp);
  if (!(zigzag.threshold > 0.0))
    error->all(FLERR, "fix bk/reduce: threshold must be > 0, got {}", arg[6]);
  block = utils::bnumeric(FLERR, arg[8], false, lmp);
  const char *extrema_name = arg[10], *blocks_name = arg[12];
  parse_options(narg, arg);
  declare_fields();

  vector_flag = 1;
  size_vector = 2;
  global_freq = 1;
  extvector = 0;
  restart_global = 1;
  last_write = std::chrono::steady_clock::now();

  with_extrema = strcmp(extrema_name, "none") != 0;
  if (comm->me == 0) {
    if (with_extrema) open(extrema, extrema_name);
    open(blocks, blocks_name);
  }
}

// the optional keywords after `blocks FILE`, and the block's length checked against them
void FixBKReduce::parse_options(int narg, char **arg)
{
  for (int iarg = 13; iarg < narg; iarg++) {
    if (strcmp(arg[iarg], "energy") == 0)
      with_energy = 1;
    else if (strcmp(arg[iarg], "append") == 0)
      appending = 1;
    else if (strcmp(arg[iarg], "phase") == 0 && iarg + 1 < narg) {
      with_phase = 1;
      phase_every = utils::bnumeric(FLERR, arg[++iarg], false, lmp);
      if (phase_every <= 0 || phase_every % nevery != 0)
        error->all(FLERR, "fix bk/reduce: Pevery must be a multiple of Nevery, got {}",
                   phase_every);
    } else
      error->all(FLERR, "Illegal fix bk/reduce command: {}", USAGE);
  }
  if (block <= 0 || block % nevery != 0 || (with_phase && block % phase_every != 0))
    error->all(FLERR, "fix bk/reduce: the block B must be a multiple of Nevery (and of Pevery), "
               "got {}", block);
}

// the records' fields (bkflow.observables.reduced reads them by name)
void FixBKReduce::declare_fields()
{
  extrema.field("step", "<i8");
  extrema.field("sigma", "<f8");
  blocks.field("n", "<i8");
  if (with_phase) blocks.field("n_phase", "<i8");
  blocks.field("sigma", "<f8");
  if (with_phase)
    for (const char *name : PHASE_NAMES) blocks.field(name, "<f8");
  if (with_energy)
    for (const char *name : LEDGER_NAMES) {
      extrema.field(name, "<f8");
      blocks.field(name, "<f8");
    }
  sums.assign(blocks.nfields, 0.0);
}

FixBKReduce::~FixBKReduce()
{
  extrema.close();
  blocks.close();
}

void FixBKReduce::open(BKNpy &f, const char *name)
{
  // appending: the records are positioned by the restart file's state (restart())
  if (!f.open(name, appending))
    error->one(FLERR, "{} fix bk/reduce: cannot open {}: {}", BK_ERR_CANNOT_OPEN, name,
               utils::getsyserror());
}

void FixBKReduce::init()
{
  FixBKReader::init();
  if (with_phase && !substrate->has_contacts())
    error->all(FLERR, "fix bk/reduce: fix {} has no friction, so no contact phases",
               substrate->id);
}

void FixBKReduce::sample()
{
  const bigint step = update->ntimestep;
  const double sigma = substrate->compute_vector(BK_SLOT_SIGMA);    // collective
  if (with_energy)
    for (int k = 0; k < NLEDGER; k++) ledger_now[k] = substrate->compute_vector(LEDGER[k]);
  double ph[NPHASE] = {};
  const bool phase_now = with_phase && step % phase_every == 0;
  if (phase_now) phase_statistics(ph);
  if (with_extrema) follow_extrema(sigma, step);
  add_to_block(step, sigma, ph, phase_now);
  if (comm->me == 0 && std::chrono::steady_clock::now() - last_write > WRITE_EVERY) write_out();
}

// R, Z_re, Z_im, |Z|^2, R2, u_mean, u_std of the contacts' phases now (collective)
void FixBKReduce::phase_statistics(double *ph)
{
  double s[BK_NPHASE];
  substrate->contact_phase(s);    // collective
  const double n = s[BK_PH_N] > 0.0 ? s[BK_PH_N] : 1.0;
  const double zr = s[BK_PH_C1] / n, zi = s[BK_PH_S1] / n;
  const double z2r = s[BK_PH_C2] / n, z2i = s[BK_PH_S2] / n;
  const double mean = s[BK_PH_U] / n, var = s[BK_PH_UU] / n - mean * mean;
  ph[0] = std::sqrt(zr * zr + zi * zi);
  ph[1] = zr;
  ph[2] = zi;
  ph[3] = zr * zr + zi * zi;
  ph[4] = std::sqrt(z2r * z2r + z2i * z2i);
  ph[5] = mean;
  ph[6] = std::sqrt(var > 0.0 ? var : 0.0);
}

/* the zigzag: a maximum is final once sigma_x fell from it by more than the threshold, a
   minimum once it rose again by more; the ledger is kept at each running extremum */

void FixBKReduce::follow_extrema(double sigma, bigint step)
{
  switch (zigzag.feed(sigma, step)) {
    case BKZigzag::NEW_MAX:
      std::memcpy(ledger_max, ledger_now, sizeof ledger_now);
      break;
    case BKZigzag::FALL:
      stage_extremum(zigzag.step_max, zigzag.smax, ledger_max);
      std::memcpy(ledger_min, ledger_now, sizeof ledger_now);
      break;
    case BKZigzag::NEW_MIN:
      std::memcpy(ledger_min, ledger_now, sizeof ledger_now);
      break;
    case BKZigzag::CONFIRMED:
      stage_extremum(zigzag.event_min, zigzag.smin, ledger_min);
      std::memcpy(ledger_max, ledger_now, sizeof ledger_now);
      break;
    default:
      break;
  }
}

// the sample into the sums of its block (the block before it closed when this one starts)
void FixBKReduce::add_to_block(bigint step, double sigma, const double *ph, bool phase_now)
{
  const bigint k = step / block;
  int64_t count;    // counts are int64 bits in the record
  if (k != block_k) {
    std::memcpy(&count, &sums[0], sizeof count);
    if (block_k >= 0 && count > 0) close_block();
    block_k = k;
  }
  int j = 0;
  std::memcpy(&count, &sums[0], sizeof count);
  sums[j++] = as_double(count + 1);
  if (with_phase) {
    std::memcpy(&count, &sums[j], sizeof count);
    sums[j++] = as_double(count + (phase_now ? 1 : 0));
  }
  sums[j++] += sigma;
  if (with_phase)
    for (int p = 0; p < NPHASE; p++) sums[j++] += ph[p];
  if (with_energy)
    for (int p = 0; p < NLEDGER; p++) sums[j++] = ledger_now[p];
}

void FixBKReduce::stage_extremum(bigint step, double sigma, const double *ledger)
{
  double rec[2 + NLEDGER] = {as_double(step), sigma};
  if (with_energy) std::memcpy(rec + 2, ledger, sizeof(double) * NLEDGER);
  extrema.stage(rec, comm->me == 0);
}

void FixBKReduce::close_block()
{
  blocks.stage(sums.data(), comm->me == 0);
  sums.assign(blocks.nfields, 0.0);
}

void FixBKReduce::post_run()
{
  if (comm->me == 0) write_out();
}

/* the records so far: the final ones not yet written, then the one under way */

void FixBKReduce::write_out()
{
  last_write = std::chrono::steady_clock::now();
  if (with_extrema && zigzag.step_max >= 0) {
    const bool falling = zigzag.falling;
    extrema.pending.assign({as_double(falling ? zigzag.step_min : zigzag.step_max),
                            falling ? zigzag.smin : zigzag.smax});
    const double *l = falling ? ledger_min : ledger_max;
    if (with_energy) extrema.pending.insert(extrema.pending.end(), l, l + NLEDGER);
  }
  int64_t count;
  std::memcpy(&count, &sums[0], sizeof count);
  if (count > 0)
    blocks.pending = sums;
  else
    blocks.pending.clear();
  for (BKNpy *f : {&extrema, &blocks})
    if (!f->write()) failed(*f);
}

void FixBKReduce::failed(const BKNpy &f)
{
  error->one(FLERR, "{} fix bk/reduce: writing {} failed: {}", BK_ERR_WRITE_FAILED, f.name,
             utils::getsyserror());
}

double FixBKReduce::compute_vector(int n)
{
  return static_cast<double>((n == 0 ? extrema : blocks).nrecords);
}

/* the restart state: the settings (checked), the zigzag, the ledger at its running extrema,
   the block under way and how many final records each file holds */

void FixBKReduce::write_restart(FILE *fp)
{
  if (comm->me != 0) return;
  std::vector<double> s;
  s.insert(s.end(), {zigzag.threshold, static_cast<double>(block), static_cast<double>(nevery),
                     static_cast<double>(phase_every), static_cast<double>(with_energy),
                     static_cast<double>(with_phase)});
  s.insert(s.end(), {static_cast<double>(zigzag.falling), zigzag.smax, zigzag.smin,
                     static_cast<double>(zigzag.step_max), static_cast<double>(zigzag.step_min),
                     static_cast<double>(zigzag.event_min)});
  s.insert(s.end(), ledger_max, ledger_max + NLEDGER);
  s.insert(s.end(), ledger_min, ledger_min + NLEDGER);
  s.push_back(static_cast<double>(block_k));
  s.insert(s.end(), sums.begin(), sums.end());
  // every final record is on disk: restart files are written between run commands, after
  // post_run's write
  s.push_back(static_cast<double>(extrema.nrecords));
  s.push_back(static_cast<double>(blocks.nrecords));
  const int bytes = static_cast<int>(s.size() * sizeof(double));    // LAMMPS's convention
  fwrite(&bytes, sizeof(int), 1, fp);
  fwrite(s.data(), sizeof(double), s.size(), fp);
}

void FixBKReduce::restart(char *buf)
{
  // a deck that continues a run without `append` starts its records again, from this step
  // (their first block is then not block 0 of the run: bkflow's decks always append)
  if (!appending) return;
  auto *s = reinterpret_cast<double *>(buf);
  // the count LAMMPS stored before the list is not passed on: the settings must match
  if (s[0] != zigzag.threshold || s[1] != static_cast<double>(block) ||
      s[2] != static_cast<double>(nevery) || s[3] != static_cast<double>(phase_every) ||
      s[4] != static_cast<double>(with_energy) || s[5] != static_cast<double>(with_phase))
    error->all(FLERR, "fix bk/reduce: the restart file's fix {} had other settings (threshold, "
               "block, Nevery, phase, energy); a continued run must define it as before", id);
  int j = 6;
  zigzag.falling = static_cast<int>(s[j++]);
  zigzag.smax = s[j++];
  zigzag.smin = s[j++];
  zigzag.step_max = static_cast<bigint>(s[j++]);
  zigzag.step_min = static_cast<bigint>(s[j++]);
  zigzag.event_min = static_cast<bigint>(s[j++]);
  std::memcpy(ledger_max, s + j, sizeof ledger_max);
  j += NLEDGER;
  std::memcpy(ledger_min, s + j, sizeof ledger_min);
  j += NLEDGER;
  block_k = static_cast<bigint>(s[j++]);
  for (int p = 0; p < blocks.nfields; p++) sums[p] = s[j++];
  extrema.nfinal = extrema.nrecords = static_cast<bigint>(s[j++]);
  blocks.nfinal = blocks.nrecords = static_cast<bigint>(s[j++]);
  if (comm->me == 0)
    for (BKNpy *f : {&extrema, &blocks})
      if (f->fp && !f->holds_final())
        error->one(FLERR, "fix bk/reduce: {} holds fewer records than the restart file says "
                   "were written: it is not this run's", f->name);
}
