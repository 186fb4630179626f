/* bkflow LAMMPS plugin: the fused path's domain decomposition and halo exchange
   (bk_row_blocks.h). */

#include "bk_row_blocks.h"

#include "atom.h"
#include "bk_interface.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "lammps.h"

#include <algorithm>
#include <cstring>
#include <limits>

using namespace LAMMPS_NS;

BKRowBlocks::~BKRowBlocks()
{
  if (halo_comm != MPI_COMM_NULL) MPI_Comm_free(&halo_comm);
}

void BKRowBlocks::divide(int lx, int ly, int nblocks, int j)
{
  Lx = lx;
  Ly = ly;
  K = nblocks;
  row0 = first_row(j, K, Ly);
  nrows = first_row(j + 1, K, Ly) - row0;
  nloc = nrows * Lx;
}

std::string BKRowBlocks::describe() const
{
  if (K < 2) return "one rank";
  std::string blocks = fmt::format("{} ranks, blocks of rows", K);
  for (int j = 0; j < K; j++)
    blocks += fmt::format("{}{}-{}", j ? " | " : " ", first_row(j, K, Ly),
                          first_row(j + 1, K, Ly) - 1);
  return blocks;
}

/* the cuts at y = ylo + yprd first_row(j) / Ly, half a row from bkflow's rows at y = ylo +
   (iy + 1/2) yprd / Ly, so that the exchange gives each rank the atoms of its rows */

void BKRowBlocks::cut_subdomains(LAMMPS *lmp) const
{
  Comm *comm = lmp->comm;
  comm->layout = Comm::LAYOUT_NONUNIFORM;
  for (int j = 0; j <= K; j++) comm->ysplit[j] = static_cast<double>(first_row(j, K, Ly)) / Ly;
  lmp->domain->set_local_box();
}

tagint BKRowBlocks::first_stray(LAMMPS *lmp) const
{
  const Atom *atom = lmp->atom;
  const Domain *domain = lmp->domain;
  const double lo = domain->boxlo[1], prd = domain->yprd;
  tagint stray = std::numeric_limits<tagint>::max();
  for (int i = 0; i < atom->nlocal; i++) {
    double y = atom->x[i][1];    // wrapped as Domain::pbc will
    if (domain->yperiodic) {
      if (y < lo) y += prd;
      if (y >= lo + prd) y -= prd;
    }
    const int row = static_cast<int>((atom->tag[i] - 1) / Lx);
    int j = static_cast<int>(static_cast<long long>(row) * K / Ly);
    while (first_row(j, K, Ly) > row) j--;
    while (first_row(j + 1, K, Ly) <= row) j++;
    const double below = static_cast<double>(first_row(j, K, Ly)) / Ly;
    const double above = static_cast<double>(first_row(j + 1, K, Ly)) / Ly;
    if (!(y >= lo + prd * below && y < lo + prd * above)) stray = std::min(stray, atom->tag[i]);
  }
  return stray;
}

void BKRowBlocks::report_stray(LAMMPS *lmp, tagint all) const
{
  if (all == std::numeric_limits<tagint>::max()) return;
  if (K > 1)
    lmp->error->all(FLERR,
                    "{} fix bk/substrate fused: particle {} (lattice row {}) left the sub-domain "
                    "of its rank's rows: it moved half a row (or the layer tore) across a rank "
                    "boundary. On {} ranks the fused path needs every particle within half a row "
                    "of its site: run it on one rank, or on the general path (without "
                    "`integrate`: fix nve and fix enforce2d)",
                    BK_ERR_ATOM_LOST, all, (all - 1) / Lx, K);
  lmp->error->all(FLERR, "{} fix bk/substrate fused: atom {} is not local", BK_ERR_ATOM_LOST,
                  all);
}

void BKRowBlocks::open_halo(LAMMPS *lammps, bkfused::Arrays &arr)
{
  lmp = lammps;
  halo_send.assign(4 * static_cast<size_t>(Lx), 0.0);
  halo_recv.assign(4 * static_cast<size_t>(Lx), 0.0);
  if (slab() && halo_comm == MPI_COMM_NULL) MPI_Comm_dup(lmp->world, &halo_comm);
  arr.halo_start = &BKRowBlocks::halo_start;
  arr.halo_wait = &BKRowBlocks::halo_wait;
  arr.halo_ctx = this;
}

void BKRowBlocks::exchange(double *x, double *y)
{
  halo_start(this, x, y);
  halo_wait(this, x, y);
}

/* The halo (bkfused::Arrays::halo_start, halo_wait): this block's first row goes to the block
   below (its ghost row above) and its last row to the block above, while theirs come in;
   non-blocking, so that the kernel computes the rows that need no ghost meanwhile. The
   neighbours are LAMMPS's in the column of ranks (one rank each side, the same one when there
   are two: the tags tell the two messages apart). */

void BKRowBlocks::halo_start(void *self, const double *x, const double *y)
{
  auto *b = static_cast<BKRowBlocks *>(self);
  const double t0 = b->timing ? MPI_Wtime() : 0.0;
  const int Lx = b->Lx, n = b->nloc;
  const int down = b->lmp->comm->procneigh[1][0], up = b->lmp->comm->procneigh[1][1];
  double *s = b->halo_send.data(), *r = b->halo_recv.data();    // [0, 2 Lx): to/from below
  const size_t row = static_cast<size_t>(Lx) * sizeof(double);
  MPI_Irecv(r, 2 * Lx, MPI_DOUBLE, down, 1, b->halo_comm, &b->halo_req[0]);
  MPI_Irecv(r + 2 * Lx, 2 * Lx, MPI_DOUBLE, up, 0, b->halo_comm, &b->halo_req[1]);
  memcpy(s, x, row);
  memcpy(s + Lx, y, row);
  memcpy(s + 2 * Lx, x + n - Lx, row);
  memcpy(s + 3 * Lx, y + n - Lx, row);
  MPI_Isend(s, 2 * Lx, MPI_DOUBLE, down, 0, b->halo_comm, &b->halo_req[2]);
  MPI_Isend(s + 2 * Lx, 2 * Lx, MPI_DOUBLE, up, 1, b->halo_comm, &b->halo_req[3]);
  if (b->timing) b->halo_time += MPI_Wtime() - t0;
}

void BKRowBlocks::halo_wait(void *self, double *x, double *y)
{
  auto *b = static_cast<BKRowBlocks *>(self);
  const double t0 = b->timing ? MPI_Wtime() : 0.0;
  const int Lx = b->Lx, n = b->nloc;
  const double *r = b->halo_recv.data();
  const size_t row = static_cast<size_t>(Lx) * sizeof(double);
  MPI_Waitall(4, b->halo_req, MPI_STATUSES_IGNORE);
  memcpy(x - Lx, r, row);    // the block below's last row
  memcpy(y - Lx, r + Lx, row);
  memcpy(x + n, r + 2 * Lx, row);    // the block above's first row
  memcpy(y + n, r + 3 * Lx, row);
  if (b->timing) {
    b->halo_time += MPI_Wtime() - t0;
    b->halo_calls++;
  }
}

// the exchanges' share of the run (benchmarks/RESULTS.md, benchmarks/report/scaling_model.py)
void BKRowBlocks::log_halo_time(LAMMPS *lammps, const char *fix_id)
{
  if (K > 1 && halo_calls) {
    double t[2] = {halo_time, -halo_time}, all[2];
    MPI_Allreduce(t, all, 2, MPI_DOUBLE, MPI_MAX, lammps->world);
    if (lammps->comm->me == 0)
      utils::logmesg(lammps, "fix {} bk/substrate fused: {} halo exchanges of {} bytes (sent "
                     "and received) a rank, {:.3g} to {:.3g} us each (the fastest and slowest "
                     "rank's mean, waits included)\n", fix_id, halo_calls, 4 * 2 * Lx * sizeof(double),
                     -all[1] / halo_calls * 1e6, all[0] / halo_calls * 1e6);
  }
  halo_time = 0.0;
  halo_calls = 0;
}

void BKRowBlocks::row_totals(const std::vector<double> &rows, int w, double *total,
                             MPI_Comm world) const
{
  std::vector<double> all(static_cast<size_t>(Ly) * w, 0.0);
  std::copy(rows.begin(), rows.end(), all.begin() + static_cast<size_t>(row0) * w);
  if (K > 1) MPI_Allreduce(MPI_IN_PLACE, all.data(), Ly * w, MPI_DOUBLE, MPI_SUM, world);
  for (int j = 0; j < w; j++) {
    double s = 0.0;
    for (int r = 0; r < Ly; r++) s += all[static_cast<size_t>(r) * w + j];
    total[j] = s;
  }
}

double BKRowBlocks::row_sum_total(const std::vector<double> &rows, MPI_Comm world) const
{
  double s;
  row_totals(rows, 1, &s, world);
  return s;
}
