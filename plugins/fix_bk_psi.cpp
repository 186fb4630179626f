/* bkflow LAMMPS plugin: fix bk/psi

     fix ID group bk/psi Nevery Lx Ly file FILE [append]

   The square-lattice order of the layer, Psi = (1/N) sum_i |psi_i| with psi_i = (1/4) sum_j
   exp(4 i theta_ij) over particle i's four bonds (docs/model.md "Lattice order";
   bkflow.observables.order.psi), every Nevery steps (and at the first step of a run when it is a multiple
   of Nevery), computed in the run instead of from position snapshots. The layer is bkflow's
   lattice of Lx x Ly particles, particle ID i + 1 at site (i mod Lx, i div Lx), bonded to its
   +x and +y neighbours (periodic); a bond's vector is the difference of the unwrapped
   positions plus the box image the bond crosses in the lattice (bkflow.observables.order.lattice_shifts),
   so a stretched bond is never mistaken for its image. Every rank puts its atoms' unwrapped
   positions into a vector of the layer's, summed onto rank 0, which computes Psi and
   appends (step, psi) to FILE, a NumPy .npy file (bk_npy.h; numpy.load reads it). The scalar
   is the last Psi. With `append` (a run continued from a restart file) FILE is appended to and
   the first setup's sample left out (the run that wrote the restart file sampled that step). */

#include "fix_bk_psi.h"

#include "atom.h"
#include "bk_interface.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "update.h"

#include <cmath>
#include <complex>
#include <cstring>
#include <mpi.h>

using namespace LAMMPS_NS;
using namespace FixConst;

namespace {
const char *USAGE = "fix ID group bk/psi Nevery Lx Ly file FILE [append]";

/* Psi of the lattice of lx x ly particles at unwrapped positions pos (x y by particle): psi_i
   from the two bonds each particle owns (+x, +y), which count for both of their ends */
double lattice_psi(const std::vector<double> &pos, int lx, int ly)
{
  const int n = lx * ly;
  std::vector<std::complex<double>> z(n, 0.0);
  const double box[2] = {static_cast<double>(lx), static_cast<double>(ly)};
  for (int k = 0; k < n; k++) {
    const int ix = k % lx, iy = k / lx;
    const int nb[2] = {(ix + 1) % lx + lx * iy, ix + lx * ((iy + 1) % ly)};
    for (int d = 0; d < 2; d++) {
      const int j = nb[d];
      double v[2] = {pos[2 * j] - pos[2 * k], pos[2 * j + 1] - pos[2 * k + 1]};
      // the lattice's image of the bond: +box where it wraps
      if ((d == 0 && ix == lx - 1) || (d == 1 && iy == ly - 1)) v[d] += box[d];
      const double r = std::hypot(v[0], v[1]);
      const std::complex<double> u(v[0] / r, v[1] / r);
      const std::complex<double> u2 = u * u;
      const std::complex<double> u4 = u2 * u2;
      z[k] += u4;
      z[j] += u4;
    }
  }
  double psi = 0.0;
  for (int k = 0; k < n; k++) psi += std::abs(z[k] * 0.25);
  return psi / n;
}

}    // namespace

FixBKPsi::FixBKPsi(LAMMPS *lmp, int narg, char **arg) : Fix(lmp, narg, arg)
{
  if (narg < 8 || strcmp(arg[6], "file") != 0)
    error->all(FLERR, "Illegal fix bk/psi command: {}", USAGE);
  nevery = utils::inumeric(FLERR, arg[3], false, lmp);
  lx = utils::inumeric(FLERR, arg[4], false, lmp);
  ly = utils::inumeric(FLERR, arg[5], false, lmp);
  if (nevery <= 0) error->all(FLERR, "fix bk/psi: Nevery must be > 0, got {}", arg[3]);
  if (lx < 3 || ly < 3) error->all(FLERR, "fix bk/psi: Lx and Ly must be >= 3");
  for (int iarg = 8; iarg < narg; iarg++) {
    if (strcmp(arg[iarg], "append") == 0)
      appending = 1;
    else
      error->all(FLERR, "Illegal fix bk/psi command: {}", USAGE);
  }
  scalar_flag = 1;
  global_freq = nevery;
  extscalar = 0;
  out.field("step", "<i8");
  out.field("psi", "<f8");
  last_write = std::chrono::steady_clock::now();
  if (comm->me == 0) {
    if (!out.open(arg[7], appending))
      error->one(FLERR, "{} fix bk/psi: cannot open {}: {}", BK_ERR_CANNOT_OPEN, arg[7],
                 utils::getsyserror());
  }
}

FixBKPsi::~FixBKPsi()
{
  out.close();
}

int FixBKPsi::setmask()
{
  return END_OF_STEP | POST_RUN;
}

void FixBKPsi::init()
{
  if (domain->dimension != 2) error->all(FLERR, "fix bk/psi needs dimension 2");
  if (atom->natoms != static_cast<bigint>(lx) * ly)
    error->all(FLERR, "fix bk/psi: the layer has {} atoms, not Lx x Ly = {}", atom->natoms,
               static_cast<bigint>(lx) * ly);
  if (!atom->tag_enable) error->all(FLERR, "fix bk/psi needs atom IDs");
}

void FixBKPsi::setup(int /*vflag*/)
{
  const bool skip = appending && first_setup;
  first_setup = false;
  if (skip) {
    last_step = update->ntimestep;
    return;
  }
  if (update->ntimestep % nevery == 0) sample();
}

void FixBKPsi::end_of_step()
{
  sample();
}

void FixBKPsi::post_run()
{
  if (comm->me == 0 && !out.write())
    error->one(FLERR, "{} fix bk/psi: writing {} failed: {}", BK_ERR_WRITE_FAILED, out.name,
               utils::getsyserror());
}

double FixBKPsi::compute_scalar()
{
  return last_psi;
}

void FixBKPsi::sample()
{
  if (update->ntimestep == last_step) return;
  last_step = update->ntimestep;
  gather_positions();
  double psi = 0.0;
  if (comm->me == 0) {
    psi = lattice_psi(all, lx, ly);
    record(psi);
  }
  MPI_Bcast(&psi, 1, MPI_DOUBLE, 0, world);
  last_psi = psi;
}

// the layer's unwrapped positions by particle (2N), summed onto rank 0 (`all`); collective
void FixBKPsi::gather_positions()
{
  const int n = lx * ly;
  xy.assign(2 * n, 0.0);
  double **x = atom->x;
  imageint *image = atom->image;
  tagint *tag = atom->tag;
  for (int i = 0; i < atom->nlocal; i++) {
    const tagint k = tag[i] - 1;
    if (k < 0 || k >= n) error->one(FLERR, "fix bk/psi: atom ID {} is not of the layer", tag[i]);
    double u[3];
    domain->unmap(x[i], image[i], u);
    xy[2 * k] = u[0];
    xy[2 * k + 1] = u[1];
  }
  if (comm->me == 0) all.assign(2 * n, 0.0);
  MPI_Reduce(xy.data(), comm->me == 0 ? all.data() : nullptr, 2 * n, MPI_DOUBLE, MPI_SUM, 0,
             world);
}

// (step, psi) staged on rank 0, on disk at most a second after it is known (a deck cut short
// keeps what it computed)
void FixBKPsi::record(double psi)
{
  const double rec[2] = {BKNpy::as_double(static_cast<int64_t>(update->ntimestep)), psi};
  out.stage(rec, true);
  const auto now = std::chrono::steady_clock::now();
  if (now - last_write > std::chrono::seconds(1)) {
    last_write = now;
    if (!out.write())
      error->one(FLERR, "{} fix bk/psi: writing {} failed: {}", BK_ERR_WRITE_FAILED, out.name,
                 utils::getsyserror());
  }
}
