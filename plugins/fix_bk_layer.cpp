/* bkflow LAMMPS plugin: FixBKLayer (fix_bk_layer.h), the part of fix bk/substrate that both of
   its paths share: the arguments, the per-atom state of the layer and its migration and
   restart, the plate's clock, and the output vector. The equations are those of
   docs/model.md, written in bk_model.h; plugins/README.md documents the syntax. */

#include "fix_bk_layer.h"

#include "atom.h"
#include "bkplugin.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "force.h"
#include "memory.h"
#include "update.h"

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <limits>

using namespace LAMMPS_NS;

namespace {
// "a, b or c" of the names of a rule table (entry 0: none); with `bar`, "a|b|c"
std::string names_of(const char *const *names, int n, bool bar = false)
{
  std::string out;
  for (int k = 1; k < n; k++)
    out += std::string(names[k]) +
        (k == n - 1 ? "" : bar ? "|" : k < n - 2 ? ", " : " or ");
  return out;
}

// the fix's syntax, the names of the contact rules and damping schemes from bk_model.h's tables
const std::string USAGE =
    "fix ID group bk/substrate [bonds k_b r0] [drive V_d kd_property] [friction k_e mu_s "
    "sigma_n A " + names_of(BK_CONTACT_NAMES, BK_NCONTACT, true) + "] [damp gamma [" +
    names_of(BK_DAMPING_NAMES, BK_NDAMPING, true) + "]] [start dr_property] [energy] "
    "[integrate|fused]";

double positive(const char *file, int line, const char *what, const char *str, LAMMPS *lmp)
{
  double value = utils::numeric(file, line, str, false, lmp);
  if (!(value > 0.0))
    lmp->error->all(file, line, "fix bk/substrate: {} must be > 0, got {}", what, str);
  return value;
}

// NAME of a per-atom property written d_NAME or NAME
std::string property_name(const char *file, int line, const char *keyword, const char *str,
                          LAMMPS *lmp)
{
  if (strncmp(str, "d_", 2) == 0) str += 2;
  if (*str == '\0')
    lmp->error->all(file, line, "fix bk/substrate {}: empty property name", keyword);
  return str;
}
}    // namespace

FixBKLayer::FixBKLayer(LAMMPS *lmp, int narg, char **arg) : Fix(lmp, narg, arg)
{
  const std::string mismatch = bk_version_mismatch(lmp);
  if (!mismatch.empty())
    error->all(FLERR,
               "fix bk/substrate: the bkflow plugin was {}; rebuild it with `pip install -e .` "
               "against this LAMMPS",
               mismatch);

  if (domain->dimension != 2) error->all(FLERR, "fix bk/substrate requires dimension 2");
  if (domain->triclinic) error->all(FLERR, "fix bk/substrate requires an orthogonal box");
  if (narg < 4) error->all(FLERR, "Illegal fix bk/substrate command: expected {}", USAGE);

  std::string start_name;    // per-atom property holding dr_x at the fix's creation
  int iarg = 3;
  while (iarg < narg) iarg = parse_keyword(iarg, narg, arg, start_name);

  if (bonds_on && !atom->molecular)
    error->all(FLERR, "fix bk/substrate bonds needs a molecular atom style (atom_style bond)");
  if (!start_name.empty() && contact == BK_NO_CONTACT)
    error->all(FLERR, "fix bk/substrate start sets the contact displacement: it needs friction");

  time_integrate = integrate;
  set_output_flags();

  FixBKLayer::grow_arrays(atom->nmax);
  atom->add_callback(Atom::GROW);
  atom->add_callback(Atom::RESTART);

  for (int i = 0; i < atom->nlocal; i++) FixBKLayer::set_arrays(i);
  if (!start_name.empty()) take_start(start_name);
  t0 = current_time();
  elapsed_base = 0.0;
  dt_base = update->dt;
  step_base = update->ntimestep;
}

/* the keyword at arg[iarg] and its values; returns the index of the next keyword */

int FixBKLayer::parse_keyword(int iarg, int narg, char **arg, std::string &start_name)
{
  const char *key = arg[iarg];
  if (strcmp(key, "bonds") == 0) return parse_bonds(iarg, narg, arg);
  if (strcmp(key, "drive") == 0) return parse_drive(iarg, narg, arg);
  if (strcmp(key, "friction") == 0) return parse_friction(iarg, narg, arg);
  if (strcmp(key, "damp") == 0) return parse_damp(iarg, narg, arg);
  if (strcmp(key, "integrate") == 0 || strcmp(key, "fused") == 0) {
    integrate = 1;    // the velocity-Verlet step of fix nve and what fix enforce2d does
    return iarg + 1;
  }
  if (strcmp(key, "energy") == 0) {
    ledger_on = 1;    // the energy ledger's running sums (docs/model.md "Energy")
    return iarg + 1;
  }
  if (strcmp(key, "start") == 0) {
    if (iarg + 2 > narg) error->all(FLERR, "fix bk/substrate start needs: start dr_property");
    start_name = property_name(FLERR, "start", arg[iarg + 1], lmp);
    return iarg + 2;
  }
  error->all(FLERR, "Unknown fix bk/substrate keyword {}: expected {}", key, USAGE);
  return narg;
}

int FixBKLayer::parse_bonds(int iarg, int narg, char **arg)
{
  if (iarg + 3 > narg) error->all(FLERR, "fix bk/substrate bonds needs: bonds k_b r0");
  kb = positive(FLERR, "k_b", arg[iarg + 1], lmp);
  r0 = positive(FLERR, "r0", arg[iarg + 2], lmp);
  bonds_on = 1;
  return iarg + 3;
}

int FixBKLayer::parse_drive(int iarg, int narg, char **arg)
{
  if (iarg + 3 > narg) error->all(FLERR, "fix bk/substrate drive needs: drive V_d kd_property");
  vd = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
  kd_name = property_name(FLERR, "drive", arg[iarg + 2], lmp);
  drive_on = 1;
  return iarg + 3;
}

int FixBKLayer::parse_friction(int iarg, int narg, char **arg)
{
  if (iarg + 6 > narg)
    error->all(FLERR, "fix bk/substrate friction needs: friction k_e mu_s sigma_n A {}",
               names_of(BK_CONTACT_NAMES, BK_NCONTACT, true));
  ke = positive(FLERR, "k_e", arg[iarg + 1], lmp);
  mus = positive(FLERR, "mu_s", arg[iarg + 2], lmp);
  sigman = positive(FLERR, "sigma_n", arg[iarg + 3], lmp);
  area = positive(FLERR, "A", arg[iarg + 4], lmp);
  contact = BK_NO_CONTACT;
  for (int rule = BK_NO_CONTACT + 1; rule < BK_NCONTACT; rule++)
    if (strcmp(arg[iarg + 5], BK_CONTACT_NAMES[rule]) == 0) contact = rule;
  if (contact == BK_NO_CONTACT)
    error->all(FLERR, "fix bk/substrate friction mode must be {}, got {}",
               names_of(BK_CONTACT_NAMES, BK_NCONTACT), arg[iarg + 5]);
  fmax = mus * sigman * area;
  return iarg + 6;
}

// damp gamma, then the scheme if one is named (implicit when none is)
int FixBKLayer::parse_damp(int iarg, int narg, char **arg)
{
  if (iarg + 2 > narg)
    error->all(FLERR, "fix bk/substrate damp needs: damp gamma [implicit|half]");
  gamma = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
  if (gamma < 0.0) error->all(FLERR, "fix bk/substrate: gamma must be >= 0, got {}", gamma);
  iarg += 2;
  int scheme = BK_IMPLICIT;
  for (int d = BK_NO_DAMPING + 1; iarg < narg && d < BK_NDAMPING; d++)
    if (strcmp(arg[iarg], BK_DAMPING_NAMES[d]) == 0) {
      scheme = d;
      iarg++;
      break;
    }
  damping = gamma > 0.0 ? scheme : BK_NO_DAMPING;
  return iarg;
}

// what the fix offers LAMMPS: a global vector and scalar, a per-atom array, restart state
void FixBKLayer::set_output_flags()
{
  vector_flag = 1;
  size_vector = BK_NSLOTS;
  scalar_flag = 1;
  extscalar = 1;
  energy_global_flag = 1;
  global_freq = 1;
  extvector = 0;
  restart_global = 1;
  restart_peratom = 1;
  peratom_flag = 1;
  size_peratom_cols = NSTATE;
  peratom_freq = 1;
  dynamic_group_allow = 0;
  maxexchange = NSTATE + 1;    // pack_exchange: the state and the first break (Comm's margin)
}

/* `start`: contacts already part-way through their cycle; a restart file's state, unpacked
   after the constructor, replaces these values as it does the anchors */

void FixBKLayer::take_start(const std::string &start_name)
{
  const double *const dr0 = atom->dvector[double_property(start_name.c_str(), "start")];
  for (int i = 0; i < atom->nlocal; i++) state[i][DRX] = dr0[i];
}

FixBKLayer::~FixBKLayer()
{
  atom->delete_callback(id, Atom::GROW);
  atom->delete_callback(id, Atom::RESTART);
  memory->destroy(state);
  memory->destroy(first_break);
}

// index of the per-atom double property d_NAME (fix property/atom), for `keyword`
int FixBKLayer::double_property(const char *name, const char *keyword)
{
  int flag, cols;
  const int index = atom->find_custom(name, flag, cols);
  if (index < 0 || flag != 1 || cols != 0)
    error->all(FLERR,
               "fix bk/substrate {}: no per-atom double property d_{}; define it with "
               "`fix ID all property/atom d_{}` before read_data",
               keyword, name, name);
  return index;
}

void FixBKLayer::init()
{
  const char *env = std::getenv("BKFLOW_IMAGE_REBASE");
  const long long every = env ? std::atoll(env) : 0;
  rebase_at = every > 0 && every < IMGMAX / 2 ? static_cast<int>(every) : IMGMAX / 2;
  if (drive_on) kd_index = double_property(kd_name.c_str(), "drive");
  if (bonds_on && force->newton_bond)
    error->all(FLERR, "fix bk/substrate bonds needs every atom to hold all its bonds: "
                      "use `newton on off` (newton_bond off) before read_data");
  if (damping != BK_NO_DAMPING && !atom->rmass_flag && !atom->mass_setflag)
    error->all(FLERR, "fix bk/substrate: damping needs per-atom or per-type masses");
}

/* image flags past half their range (or past BKFLOW_IMAGE_REBASE box lengths, a test's
   setting that makes the fix rebase often) lose a whole number of box lengths, the same for
   every atom of the layer: the middle of the layer's flags, so that the flags stay near 0 */

void FixBKLayer::rebase_images()
{
  const int at = rebase_at;
  const imageint *const image = atom->image;
  const int nlocal = atom->nlocal;
  // the largest and (negated) smallest flag of each dimension, in one reduction
  int local[4] = {-IMGMAX, -IMGMAX, -IMGMAX, -IMGMAX}, all[4];
  for (int i = 0; i < nlocal; i++) {
    const int xbox = (image[i] & IMGMASK) - IMGMAX;
    const int ybox = (image[i] >> IMGBITS & IMGMASK) - IMGMAX;
    local[0] = std::max(local[0], xbox), local[1] = std::max(local[1], -xbox);
    local[2] = std::max(local[2], ybox), local[3] = std::max(local[3], -ybox);
  }
  MPI_Allreduce(local, all, 4, MPI_INT, MPI_MAX, world);
  int shift[2] = {0, 0};
  for (int d = 0; d < 2; d++) {
    const int hi = all[2 * d], lo = -all[2 * d + 1];
    if (hi < lo) continue;    // no atom on any rank
    if (hi >= at || lo <= -at) shift[d] = (hi + lo) / 2;
  }
  if (shift[0] == 0 && shift[1] == 0) return;
  imageint *const img = atom->image;
  for (int i = 0; i < nlocal; i++) {
    const imageint xbox = (img[i] & IMGMASK) - shift[0];
    const imageint ybox = (img[i] >> IMGBITS & IMGMASK) - shift[1];
    img[i] = (img[i] & ~((static_cast<imageint>(IMGMASK) << IMGBITS) | IMGMASK)) |
        (ybox & IMGMASK) << IMGBITS | (xbox & IMGMASK);
  }
  image_base[0] += shift[0];
  image_base[1] += shift[1];
}

void FixBKLayer::image_offset(imageint image, double *o) const
{
  bigint ix, iy;
  image_flags(image, &ix, &iy);
  o[0] = 0.0 + static_cast<double>(ix) * domain->xprd;
  o[1] = 0.0 + static_cast<double>(iy) * domain->yprd;
}

double FixBKLayer::update_dt() const
{
  return update->dt;
}

double FixBKLayer::current_time() const
{
  return update->atime + static_cast<double>(update->ntimestep - update->atimestep) * update->dt;
}

double FixBKLayer::plate_now()
{
  if (update->dt != dt_base) {    // a new time step from here on
    elapsed_base += static_cast<double>(update->ntimestep - step_base) * dt_base;
    step_base = update->ntimestep;
    dt_base = update->dt;
  }
  return bk_plate_shift(vd, elapsed_base, static_cast<double>(update->ntimestep - step_base),
                        dt_base);
}

/* the global vector, slots of bk_model.h's bk_slot: 1 sigma_x = sum_i k_d^i (anchor_x - x_i) /
   (Lx Ly); 2 contact breaks in the last step; 3 contact breaks since the fix was defined;
   4 plate displacement V_d (t - t0); 5 longest bond in the last step; 6 the path that ran
   (bk_path_code) */

double FixBKLayer::compute_vector(int n)
{
  switch (n) {
    case BK_SLOT_SIGMA:
      return sigma_x();
    case BK_SLOT_BREAKS_STEP:
      return breaks(false);
    case BK_SLOT_BREAKS_TOTAL:
      return breaks(true);
    case BK_SLOT_PLATE:
      return plate_shift;
    case BK_SLOT_BOND_MAX:
      return longest_bond();
    case BK_SLOT_PATH:
      return path_code();
    case BK_SLOT_IMAGE_BASE:
      return static_cast<double>(image_base[0]);
    case BK_SLOT_OVERSHOOT: {
      double mine = static_cast<double>(novershoot), all = 0.0;
      MPI_Allreduce(&mine, &all, 1, MPI_DOUBLE, MPI_SUM, world);
      return all;
    }
    default:
      return ledger_slot(n);
  }
}

/* the ledger's slots: the energies of the step (bonds, drive springs, contacts, kinetic) and,
   with `energy`, the running sums (plate work, dissipation by breaks and by damping; NaN
   without it), reduced over ranks in one call per step */

double FixBKLayer::ledger_slot(int n)
{
  if (energy_step != update->ntimestep) {
    double local[4 + BK_NLEDGER] = {};
    local_energies(local);
    for (int k = 0; k < BK_NLEDGER; k++) local[4 + k] = ledger[k];
    MPI_Allreduce(local, energy_vec, 4 + BK_NLEDGER, MPI_DOUBLE, MPI_SUM, world);
    energy_step = update->ntimestep;
  }
  const int k = n - BK_SLOT_E_BOND;
  if (k >= 4 && !ledger_on) return std::numeric_limits<double>::quiet_NaN();
  return energy_vec[k];
}

/* the contacts' load phases u_i = k_e |dr_i| / (mu_s sigma_n A) of the local atoms in the
   group, summed (bk_model.h) and reduced over ranks */

void FixBKLayer::contact_phase(double *sums)
{
  double local[BK_NPHASE] = {};
  if (contact != BK_NO_CONTACT) {
    const double inv_lim = ke / fmax;
    const int *const mask = atom->mask;
    const int nlocal = atom->nlocal;
    for (int i = 0; i < nlocal; i++)
      if (mask[i] & groupbit) bk_add_phase(local, state[i][DRX], state[i][DRY], inv_lim);
  }
  MPI_Allreduce(local, sums, BK_NPHASE, MPI_DOUBLE, MPI_SUM, world);
}

/* global restart state: t0, flags, total breaks, the plate's clock (elapsed_base, step_base,
   dt_base), with `energy` the ledger's running sums after them (flag 2), and the box lengths
   taken out of the image flags (flag 4), which the restart file's image flags lack. The flags
   add 2 and 4 to vh_valid (0 or 1); restart() reads a part only under its flag, and starts a
   part a file lacks (a run without `energy`, or a plugin that does not write it) at 0. */

void FixBKLayer::write_restart(FILE *fp)
{
  double local[1 + BK_NLEDGER] = {static_cast<double>(nbreak_total)};
  for (int k = 0; k < BK_NLEDGER; k++) local[1 + k] = ledger[k];
  double total[1 + BK_NLEDGER] = {};
  MPI_Allreduce(local, total, 1 + BK_NLEDGER, MPI_DOUBLE, MPI_SUM, world);
  if (comm->me == 0) {
    double list[8 + BK_NLEDGER] = {t0, static_cast<double>(vh_valid + (ledger_on ? 2 : 0) + 4),
                                   total[0], elapsed_base, static_cast<double>(step_base),
                                   dt_base};
    int n = 6;
    if (ledger_on)
      for (int k = 0; k < BK_NLEDGER; k++) list[n++] = total[1 + k];
    list[n++] = static_cast<double>(image_base[0]);
    list[n++] = static_cast<double>(image_base[1]);
    int size = n * sizeof(double);
    fwrite(&size, sizeof(int), 1, fp);
    fwrite(list, sizeof(double), n, fp);
  }
}

void FixBKLayer::restart(char *buf)
{
  auto *list = reinterpret_cast<double *>(buf);
  t0 = list[0];
  const int flags = static_cast<int>(list[1]);
  vh_valid = flags & 1;
  nbreak_total = comm->me == 0 ? static_cast<bigint>(list[2]) : 0;
  elapsed_base = list[3];
  step_base = static_cast<bigint>(list[4]);
  dt_base = list[5];
  int n = 6;
  // the sums go on with the run (on rank 0: the sum over ranks is what counts); a file
  // without them starts them at zero here
  for (int k = 0; k < BK_NLEDGER; k++)
    ledger[k] = (flags & 2) && comm->me == 0 ? list[n + k] : 0.0;
  if (flags & 2) n += BK_NLEDGER;
  image_base[0] = flags & 4 ? static_cast<bigint>(list[n]) : 0;
  image_base[1] = flags & 4 ? static_cast<bigint>(list[n + 1]) : 0;
}

double FixBKLayer::memory_usage()
{
  return static_cast<double>(atom->nmax) * (NSTATE + 1) * sizeof(double);
}

void FixBKLayer::grow_arrays(int nmax)
{
  memory->grow(state, nmax, NSTATE, "bk/substrate:state");
  memory->grow(first_break, nmax, "bk/substrate:first_break");
  array_atom = state;
}

void FixBKLayer::copy_arrays(int i, int j, int /*delflag*/)
{
  for (int k = 0; k < NSTATE; k++) state[j][k] = state[i][k];
  first_break[j] = first_break[i];
}

// a new atom: anchored where it stands, no contact history, velocity as given
void FixBKLayer::set_arrays(int i)
{
  double o[2];
  image_offset(atom->image[i], o);
  state[i][AX] = atom->x[i][0] + o[0];
  state[i][AY] = atom->x[i][1] + o[1];
  state[i][DRX] = state[i][DRY] = 0.0;
  state[i][VHX] = atom->v[i][0];
  state[i][VHY] = atom->v[i][1];
  first_break[i] = -1.0;
}

int FixBKLayer::pack_exchange(int i, double *buf)
{
  for (int k = 0; k < NSTATE; k++) buf[k] = state[i][k];
  buf[NSTATE] = first_break[i];
  return NSTATE + 1;
}

int FixBKLayer::unpack_exchange(int nlocal, double *buf)
{
  for (int k = 0; k < NSTATE; k++) state[nlocal][k] = buf[k];
  first_break[nlocal] = buf[NSTATE];
  return NSTATE + 1;
}

/* restart files: buf[0] holds the count (as every fix reading atom->extra expects), then the
   NSTATE columns; a path may write more columns after them (FixBKFused), which this one skips */

int FixBKLayer::pack_restart(int i, double *buf)
{
  buf[0] = NSTATE + 1;
  for (int k = 0; k < NSTATE; k++) buf[k + 1] = state[i][k];
  return NSTATE + 1;
}

void FixBKLayer::unpack_restart(int nlocal, int nth)
{
  double **extra = atom->extra;
  int m = 0;
  for (int i = 0; i < nth; i++) m += static_cast<int>(extra[nlocal][m]);
  m++;
  for (int k = 0; k < NSTATE; k++) state[nlocal][k] = extra[nlocal][m++];
  first_break[nlocal] = -1.0;
}

int FixBKLayer::size_restart(int /*nlocal*/)
{
  return NSTATE + 1;
}

int FixBKLayer::maxsize_restart()
{
  return NSTATE + 1;
}
