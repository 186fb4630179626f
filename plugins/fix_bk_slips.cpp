/* bkflow LAMMPS plugin: fix bk/slips

     fix ID group bk/slips Nevery substrate-fix-ID threshold file FILE [start STEP] [breaks]

   Every Nevery steps it reads sigma_x (element 1 of the substrate fix's global vector) and
   runs the zigzag rule of src/bkflow/stress.py: a maximum is the highest sample before
   sigma_x falls by more than `threshold`; its minimum is the lowest sample before sigma_x
   rises again by more than `threshold`. While a maximum (minimum) is open, every new
   running extreme copies the local atoms' positions (no communication); when the event is
   confirmed, the two copies are gathered on rank 0 and appended to FILE as two frames of a
   LAMMPS text dump (columns id type x y z ix iy iz, sorted by id), maximum first. So the
   file holds exactly the positions the slip-cluster analysis needs and nothing in between.
   Events whose maximum lies before step `start` (the transient) are followed but not
   written. With `breaks`, a last column `brk` holds the step of each contact's first break
   after the maximum (-1: none), in the minimum's frame (the maximum's holds -1): where the
   slip nucleated and how its front spread (the event catalogue, bkflow.catalogue). A run
   continued from a restart file loses the breaks of a slip open at the restart.
   Global vector: [1] events confirmed, [2] events written.

   The zigzag state is not stored in restart files: a continued run starts a new search. */

#include "fix_bk_slips.h"

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "fix_bk_layer.h"
#include "update.h"

#include <algorithm>
#include <cstring>

using namespace LAMMPS_NS;

namespace {
const char *USAGE =
    "fix ID group bk/slips Nevery substrate-fix-ID threshold file FILE [start STEP] [breaks] "
    "[append]";
}    // namespace

FixBKSlips::FixBKSlips(LAMMPS *lmp, int narg, char **arg) :
    FixBKEvents(lmp, narg, arg, USAGE, false, true)
{
  ncol = with_breaks ? 6 : 5;
}

void FixBKSlips::init()
{
  FixBKEvents::init();
  if (with_breaks) substrate->track_first_breaks();
}

void FixBKSlips::snapshot(std::vector<double> &buf)
{
  const int nlocal = atom->nlocal;
  const int *mask = atom->mask;
  const tagint *tag = atom->tag;
  const imageint *image = atom->image;
  double **x = atom->x;
  buf.clear();
  buf.reserve(static_cast<size_t>(nlocal) * ncol);
  for (int i = 0; i < nlocal; i++) {
    if (!(mask[i] & groupbit)) continue;
    buf.push_back(static_cast<double>(tag[i]));
    buf.push_back(x[i][0]);
    buf.push_back(x[i][1]);
    bigint ix, iy;    // counted with the box lengths the substrate fix took out of them
    substrate->image_flags(image[i], &ix, &iy);
    buf.push_back(static_cast<double>(ix));
    buf.push_back(static_cast<double>(iy));
    if (with_breaks) buf.push_back(substrate->first_break_of(i));
  }
}

void FixBKSlips::write_frame(const std::vector<double> &buf, bigint step)
{
  int n = static_cast<int>(buf.size());
  const int nprocs = comm->nprocs, me = comm->me;
  std::vector<int> counts(nprocs), displs(nprocs);
  MPI_Gather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, world);
  std::vector<double> all;
  if (me == 0) {
    int total = 0;
    for (int p = 0; p < nprocs; p++) {
      displs[p] = total;
      total += counts[p];
    }
    all.resize(total);
  }
  MPI_Gatherv(buf.data(), n, MPI_DOUBLE, all.data(), counts.data(), displs.data(), MPI_DOUBLE, 0,
              world);
  if (me != 0) return;

  const int NCOL = ncol;
  const size_t natom = all.size() / NCOL;
  std::vector<size_t> order(natom);
  for (size_t k = 0; k < natom; k++) order[k] = k;
  std::sort(order.begin(), order.end(),
            [&](size_t a, size_t b) { return all[a * NCOL] < all[b * NCOL]; });
  std::string frame = fmt::format(
      "ITEM: TIMESTEP\n{}\nITEM: NUMBER OF ATOMS\n{}\nITEM: BOX BOUNDS pp pp pp\n", step, natom);
  frame += fmt::format("{:.17g} {:.17g}\n{:.17g} {:.17g}\n{:.17g} {:.17g}\n", domain->boxlo[0],
                       domain->boxhi[0], domain->boxlo[1], domain->boxhi[1], domain->boxlo[2],
                       domain->boxhi[2]);
  frame += with_breaks ? "ITEM: ATOMS id type x y z ix iy iz brk\n"
                       : "ITEM: ATOMS id type x y z ix iy iz\n";
  for (size_t k : order) {
    const double *r = &all[k * NCOL];
    frame += fmt::format("{} 1 {:.9g} {:.9g} 0 {} {} 0", static_cast<tagint>(r[0]), r[1], r[2],
                         static_cast<bigint>(r[3]), static_cast<bigint>(r[4]));
    frame += with_breaks ? fmt::format(" {}\n", static_cast<bigint>(r[5])) : "\n";
  }
  write(frame);
}

void FixBKSlips::sample()
{
  const bigint step = update->ntimestep;
  switch (zigzag.feed(substrate->compute_vector(BK_SLOT_SIGMA), step)) {
    case BKZigzag::NEW_MAX:
      if (with_breaks) substrate->mark_breaks(step + 1);    // breaks from the next step on
      snapshot(snap_max);
      break;
    case BKZigzag::FALL:
    case BKZigzag::NEW_MIN:
      snapshot(snap_min);
      break;
    case BKZigzag::CONFIRMED:
      nevents++;
      if (writes(zigzag.event_max)) {
        write_frame(snap_max, zigzag.event_max);
        write_frame(snap_min, zigzag.event_min);
        flush();    // every event reaches the file at once
        nwritten++;
      }
      // the confirming sample is the next running maximum
      if (with_breaks) substrate->mark_breaks(step + 1);
      snapshot(snap_max);
      break;
    case BKZigzag::NONE:
      break;
  }
}

// the base's file buffer and the two snapshots of local atoms
double FixBKSlips::memory_usage()
{
  return FixBKReader::memory_usage() +
      static_cast<double>(snap_max.capacity() + snap_min.capacity()) * sizeof(double);
}
