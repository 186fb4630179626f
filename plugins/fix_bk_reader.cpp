/* bkflow LAMMPS plugin: FixBKReader, the base of fix bk/stress, bk/slips and bk/fronts (see
   fix_bk_reader.h): Nevery, the substrate fix it samples, and its buffered output file; and
   FixBKEvents, the base of bk/slips and bk/fronts: the slip events they record. */

#include "fix_bk_reader.h"

#include "bk_interface.h"

#include "comm.h"
#include "domain.h"
#include "error.h"
#include "fix_bk_layer.h"
#include "modify.h"
#include "update.h"

#include <cstring>

using namespace LAMMPS_NS;
using namespace FixConst;

namespace {
constexpr auto FLUSH_EVERY = std::chrono::seconds(1);
constexpr std::size_t BUFFER_SIZE = 1 << 20;
}    // namespace

FixBKReader::FixBKReader(LAMMPS *lmp, int narg, char **arg, const char *usage_text) :
    Fix(lmp, narg, arg), usage(usage_text)
{
  if (narg < 5) error->all(FLERR, "Illegal fix {} command: {}", style, usage);
  nevery = utils::inumeric(FLERR, arg[3], false, lmp);
  if (nevery <= 0) error->all(FLERR, "fix {}: Nevery must be > 0, got {}", style, arg[3]);
  substrate_id = utils::strdup(arg[4]);
  last_flush = std::chrono::steady_clock::now();
}

FixBKReader::~FixBKReader()
{
  npy.close();
  if (fp) fclose(fp);    // before the buffer it uses goes
  delete[] substrate_id;
  delete[] filename;
}

int FixBKReader::open_file(int iarg, int narg, char **arg)
{
  if (iarg + 2 > narg || strcmp(arg[iarg], "file") != 0)
    error->all(FLERR, "Illegal fix {} command: {}", style, usage);
  delete[] filename;
  filename = utils::strdup(arg[iarg + 1]);
  if (strcmp(filename, "none") == 0) return iarg + 2;    // nothing written to a file
  const std::size_t len = strlen(filename);
  npy_mode = len > 4 && strcmp(filename + len - 4, ".npy") == 0;
  if (npy_mode) {
    if (comm->me == 0) {
      if (!npy.open(filename, appending))
        error->one(FLERR, "{} fix {}: cannot open {}: {}", BK_ERR_CANNOT_OPEN, style, filename,
                   utils::getsyserror());
    }
    return iarg + 2;
  }
  if (comm->me == 0) {
    fp = fopen(filename, appending ? "a" : "w");
    if (!fp)
      error->one(FLERR, "{} fix {}: cannot open {}: {}", BK_ERR_CANNOT_OPEN, style, filename,
                 utils::getsyserror());
    buffer.resize(BUFFER_SIZE);
    setvbuf(fp, buffer.data(), _IOFBF, buffer.size());
  }
  return iarg + 2;
}

int FixBKReader::setmask()
{
  return END_OF_STEP | POST_RUN;
}

/* the bk/substrate fix to sample: it must exist, be of that style, and be defined before the
   reader, so that sigma_x is the current step's at end_of_step */

void FixBKReader::init()
{
  Fix *fix = modify->get_fix_by_id(substrate_id);
  if (!fix)
    error->all(FLERR, "fix {}: no fix with ID {} (the bk/substrate fix)", style, substrate_id);
  substrate = dynamic_cast<FixBKLayer *>(fix);
  if (!substrate)
    error->all(FLERR, "fix {}: fix {} is {}, not bk/substrate", style, substrate_id, fix->style);
  if (modify->find_fix(id) < modify->find_fix(substrate_id))
    error->all(FLERR, "fix {} must be defined after fix {}", style, substrate_id);
}

void FixBKReader::setup(int /*vflag*/)
{
  const bool skip = appending && first_setup;    // sampled by the run that was continued
  first_setup = false;
  if (skip) {
    last_step = update->ntimestep;
    return;
  }
  if (update->ntimestep % nevery == 0) sample_once();
}

void FixBKReader::end_of_step()
{
  sample_once();
}

void FixBKReader::post_run()
{
  flush();
}

void FixBKReader::sample_once()
{
  if (update->ntimestep == last_step) return;
  last_step = update->ntimestep;
  sample();
}

void FixBKReader::write(const char *data, std::size_t n)
{
  if (fwrite(data, 1, n, fp) != n) write_failed();
}

void FixBKReader::write_failed()
{
  error->one(FLERR, "{} fix {}: writing {} failed: {}", BK_ERR_WRITE_FAILED, style, filename,
             utils::getsyserror());
}

void FixBKReader::record(const double *values)
{
  npy.stage(values, comm->me == 0);
}

void FixBKReader::flush()
{
  if (npy.fp && !npy.write()) write_failed();
  if (fp && fflush(fp) != 0) write_failed();
  last_flush = std::chrono::steady_clock::now();
}

void FixBKReader::flush_if_due()
{
  if (!fp && !npy.fp) return;
  const auto now = std::chrono::steady_clock::now();
  if (now - last_flush > FLUSH_EVERY) flush();
}

double FixBKReader::memory_usage()
{
  return static_cast<double>(buffer.size());
}

FixBKEvents::FixBKEvents(LAMMPS *lmp, int narg, char **arg, const char *usage_text,
                         bool takes_limit, bool takes_breaks, bool takes_catalogue) :
    FixBKReader(lmp, narg, arg, usage_text)
{
  if (narg < 8) error->all(FLERR, "Illegal fix {} command: {}", style, usage);
  zigzag.threshold = utils::numeric(FLERR, arg[5], false, lmp);
  if (!(zigzag.threshold > 0.0))
    error->all(FLERR, "fix {}: threshold must be > 0, got {}", style, arg[5]);
  const Keywords takes{takes_limit, takes_breaks, takes_catalogue};
  int iarg = 8;
  while (iarg < narg) iarg = parse_keyword(iarg, narg, arg, takes);
  if (domain->dimension != 2) error->all(FLERR, "fix {} needs dimension 2", style);

  vector_flag = 1;
  size_vector = 2;
  global_freq = 1;
  extvector = 0;

  open_file(6, narg, arg);
}

/* the keyword at arg[iarg] (of those the style takes) and its values; returns the index of
   the next keyword */

int FixBKEvents::parse_keyword(int iarg, int narg, char **arg, const Keywords &takes)
{
  const char *key = arg[iarg];
  if (strcmp(key, "start") == 0 && iarg + 1 < narg) {
    start = utils::bnumeric(FLERR, arg[iarg + 1], false, lmp);
    return iarg + 2;
  }
  if (takes.limit && strcmp(key, "limit") == 0 && iarg + 1 < narg) {
    limit = utils::bnumeric(FLERR, arg[iarg + 1], false, lmp);
    if (limit < 0) error->all(FLERR, "fix {}: limit must be >= 0, got {}", style, limit);
    return iarg + 2;
  }
  if (takes.breaks && strcmp(key, "breaks") == 0) {
    with_breaks = 1;
    return iarg + 1;
  }
  if (takes.catalogue && is_catalogue(iarg, narg, arg)) return parse_catalogue(iarg, arg);
  if (takes.catalogue && strcmp(key, "exact") == 0) {
    exact = 1;
    return iarg + 1;
  }
  if (strcmp(key, "append") == 0) {
    appending = 1;
    return iarg + 1;
  }
  error->all(FLERR, "Illegal fix {} keyword {}: {}", style, key, usage);
  return narg;
}

// `catalogue SLIPS CLUSTERS sx S_X kb K_B lattice LX LY` at arg[iarg], whole
bool FixBKEvents::is_catalogue(int iarg, int narg, char **arg)
{
  return strcmp(arg[iarg], "catalogue") == 0 && iarg + 9 < narg &&
      strcmp(arg[iarg + 3], "sx") == 0 && strcmp(arg[iarg + 5], "kb") == 0 &&
      strcmp(arg[iarg + 7], "lattice") == 0;
}

int FixBKEvents::parse_catalogue(int iarg, char **arg)
{
  with_catalogue = 1;
  catalogue_files[0] = utils::strdup(arg[iarg + 1]);
  catalogue_files[1] = utils::strdup(arg[iarg + 2]);
  cat_sx = utils::numeric(FLERR, arg[iarg + 4], false, lmp);
  cat_kb = utils::numeric(FLERR, arg[iarg + 6], false, lmp);
  cat_lx = utils::inumeric(FLERR, arg[iarg + 8], false, lmp);
  cat_ly = utils::inumeric(FLERR, arg[iarg + 9], false, lmp);
  if (cat_lx < 3 || cat_ly < 3)
    error->all(FLERR, "fix {}: the lattice must be at least 3 x 3", style);
  return iarg + 10;
}

FixBKEvents::~FixBKEvents()
{
  delete[] catalogue_files[0];
  delete[] catalogue_files[1];
}

double FixBKEvents::compute_vector(int n)
{
  return n == 0 ? static_cast<double>(nevents) : static_cast<double>(nwritten);
}
