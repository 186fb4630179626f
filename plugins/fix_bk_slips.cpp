/* bkflow LAMMPS plugin: fix bk/slips

     fix ID group bk/slips Nevery substrate-fix-ID threshold file FILE [start STEP] [breaks]

   Every Nevery steps it reads sigma_x (element 1 of the substrate fix's global vector) and
   runs the zigzag rule of src/bkflow/observables/stress.py: a maximum is the highest sample before
   sigma_x falls by more than `threshold`; its minimum is the lowest sample before sigma_x
   rises again by more than `threshold`. While a maximum (minimum) is open, every new
   running extreme copies the local atoms' positions (no communication); when the event is
   confirmed, the two copies are gathered on rank 0 and appended to FILE as two frames of a
   LAMMPS text dump (columns id type x y z ix iy iz, sorted by id), maximum first. So the
   file holds exactly the positions the slip-cluster analysis needs and nothing in between.
   Events whose maximum lies before step `start` (the transient) are followed but not
   written. With `breaks`, a last column `brk` holds the step of each contact's first break
   after the maximum (-1: none), in the minimum's frame (the maximum's holds -1): where the
   slip nucleated and how its front spread (the event catalogue, bkflow.observables.catalogue). A run
   continued from a restart file loses the breaks of a slip open at the restart.
   Global vector: [1] events confirmed, [2] events written.

   With `catalogue SLIPS CLUSTERS sx S_X kb K_B lattice LX LY` the slips are reduced in the
   run: for every slip written, its row of the event catalogue (size and shape) goes to SLIPS
   and its clusters of two or more particles to CLUSTERS, NumPy .npy files (bk_catalogue.h,
   bk_npy.h), computed on rank 0 from the two gathered snapshots at full precision; with
   `file none` no frames are written, only these rows. `exact`: the frames to 17 digits (the
   default 9 are what the clusters need to the dump's precision; tests compare the rows).

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
    "fix ID group bk/slips Nevery substrate-fix-ID threshold file FILE|none [start STEP] [breaks] "
    "[catalogue SLIPS CLUSTERS sx S_X kb K_B lattice LX LY] [exact] [append]";
}    // namespace

FixBKSlips::FixBKSlips(LAMMPS *lmp, int narg, char **arg) :
    FixBKEvents(lmp, narg, arg, USAGE, false, true, true)
{
  ncol = with_breaks ? 6 : 5;
  frames = strcmp(arg[7], "none") != 0;
  if (!frames && !with_catalogue)
    error->all(FLERR, "fix bk/slips: `file none` needs `catalogue`: nothing would be written");
  if (with_catalogue) {
    slip_rows.field("step_max", "<i8");
    slip_rows.field("step_min", "<i8");
    for (const char *name : {"n_slipped", "n_clusters", "cluster_n", "cluster_nx", "cluster_ny"})
      slip_rows.field(name, "<i8");
    for (const char *name : {"potency", "slip_mean", "slip_max", "cluster_lx", "cluster_ly"})
      slip_rows.field(name, "<f8");
    cluster_rows.field("step_max", "<i8");
    for (const char *name : {"label", "n_c", "n_x", "n_y"}) cluster_rows.field(name, "<i8");
    for (const char *name : {"l_x", "l_y", "slip", "bond_change", "eq2_estimate"})
      cluster_rows.field(name, "<f8");
    if (comm->me == 0)
      for (int k = 0; k < 2; k++) {
        BKNpy &f = k ? cluster_rows : slip_rows;
        if (!f.open(catalogue_files[k], appending))
          error->one(FLERR, "{} fix bk/slips: cannot open {}: {}", BK_ERR_CANNOT_OPEN,
                     catalogue_files[k], utils::getsyserror());
      }
  }
}

FixBKSlips::~FixBKSlips()
{
  slip_rows.close();
  cluster_rows.close();
}

void FixBKSlips::post_run()
{
  FixBKReader::post_run();
  if (comm->me == 0)
    for (BKNpy *f : {&slip_rows, &cluster_rows})
      if (f->fp && !f->write())
        error->one(FLERR, "{} fix bk/slips: writing {} failed: {}", BK_ERR_WRITE_FAILED, f->name,
                   utils::getsyserror());
}

void FixBKSlips::init()
{
  FixBKEvents::init();
  if (with_breaks) substrate->track_first_breaks();
}

void FixBKSlips::snapshot(Snap &s)
{
  const int nlocal = atom->nlocal;
  if (!with_breaks && groupbit == 1) {    // group all: LAMMPS's arrays, copied whole
    s.raw = true;
    s.x.assign(&atom->x[0][0], &atom->x[0][0] + 3 * static_cast<size_t>(nlocal));
    s.tag.assign(atom->tag, atom->tag + nlocal);
    s.image.assign(atom->image, atom->image + nlocal);
    // the flags of an atom in the origin's image: the box lengths taken out of them so far
    const imageint zero = (static_cast<imageint>(IMGMAX) << IMG2BITS) |
        (static_cast<imageint>(IMGMAX) << IMGBITS) | IMGMAX;
    substrate->image_flags(zero, &s.base[0], &s.base[1]);
    return;
  }
  s.raw = false;
  const int *mask = atom->mask;
  const tagint *tag = atom->tag;
  const imageint *image = atom->image;
  double **x = atom->x;
  s.columns.resize(static_cast<size_t>(nlocal) * ncol);
  double *out = s.columns.data();
  for (int i = 0; i < nlocal; i++) {
    if (!(mask[i] & groupbit)) continue;
    bigint ix, iy;    // counted with the box lengths the substrate fix took out of them
    substrate->image_flags(image[i], &ix, &iy);
    out[0] = static_cast<double>(tag[i]);
    out[1] = x[i][0];
    out[2] = x[i][1];
    out[3] = static_cast<double>(ix);
    out[4] = static_cast<double>(iy);
    if (with_breaks) out[5] = substrate->first_break_of(i);
    out += ncol;
  }
  s.columns.resize(static_cast<size_t>(out - s.columns.data()));
}

std::vector<double> FixBKSlips::cols(const Snap &s) const
{
  if (!s.raw) return s.columns;
  const size_t n = s.tag.size();
  std::vector<double> out(n * ncol);
  for (size_t i = 0; i < n; i++) {
    const imageint img = s.image[i];
    out[i * ncol] = static_cast<double>(s.tag[i]);
    out[i * ncol + 1] = s.x[3 * i];
    out[i * ncol + 2] = s.x[3 * i + 1];
    out[i * ncol + 3] = static_cast<double>((img & IMGMASK) - IMGMAX + s.base[0]);
    out[i * ncol + 4] = static_cast<double>((img >> IMGBITS & IMGMASK) - IMGMAX + s.base[1]);
  }
  return out;
}

std::vector<double> FixBKSlips::gather(const std::vector<double> &buf)
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
  if (me != 0) return all;
  const int NCOL = ncol;
  const size_t natom = all.size() / NCOL;
  std::vector<size_t> order(natom);
  for (size_t k = 0; k < natom; k++) order[k] = k;
  std::sort(order.begin(), order.end(),
            [&](size_t a, size_t b) { return all[a * NCOL] < all[b * NCOL]; });
  std::vector<double> sorted(all.size());
  for (size_t k = 0; k < natom; k++)
    std::copy(&all[order[k] * NCOL], &all[order[k] * NCOL] + NCOL, &sorted[k * NCOL]);
  return sorted;
}

void FixBKSlips::write_frame(const std::vector<double> &all, bigint step)
{
  if (comm->me != 0 || !frames) return;
  const int NCOL = ncol;
  const size_t natom = all.size() / NCOL;
  std::string frame = fmt::format(
      "ITEM: TIMESTEP\n{}\nITEM: NUMBER OF ATOMS\n{}\nITEM: BOX BOUNDS pp pp pp\n", step, natom);
  frame += fmt::format("{:.17g} {:.17g}\n{:.17g} {:.17g}\n{:.17g} {:.17g}\n", domain->boxlo[0],
                       domain->boxhi[0], domain->boxlo[1], domain->boxhi[1], domain->boxlo[2],
                       domain->boxhi[2]);
  frame += with_breaks ? "ITEM: ATOMS id type x y z ix iy iz brk\n"
                       : "ITEM: ATOMS id type x y z ix iy iz\n";
  for (size_t k = 0; k < natom; k++) {
    const double *r = &all[k * NCOL];
    frame += exact ? fmt::format("{} 1 {:.17g} {:.17g} 0 {} {} 0", static_cast<tagint>(r[0]),
                                 r[1], r[2], static_cast<bigint>(r[3]), static_cast<bigint>(r[4]))
                   : fmt::format("{} 1 {:.9g} {:.9g} 0 {} {} 0", static_cast<tagint>(r[0]), r[1],
                                 r[2], static_cast<bigint>(r[3]), static_cast<bigint>(r[4]));
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
        const std::vector<double> amax = gather(cols(snap_max)), amin = gather(cols(snap_min));
        write_frame(amax, zigzag.event_max);
        write_frame(amin, zigzag.event_min);
        if (with_catalogue && comm->me == 0)
          catalogue(amax, amin, zigzag.event_max, zigzag.event_min);
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

/* the slip's row and clusters from the two snapshots (rank 0, sorted by ID): unwrapped
   positions, x + ix Lx_box, y + iy Ly_box */

void FixBKSlips::catalogue(const std::vector<double> &amax, const std::vector<double> &amin,
                           bigint step_max, bigint step_min)
{
  const int n = cat_lx * cat_ly;
  const size_t natom = amax.size() / ncol;
  if (natom != static_cast<size_t>(n) || amin.size() != amax.size())
    error->one(FLERR, "fix bk/slips: catalogue of a lattice of {} x {}, but the group holds {} "
               "atoms", cat_lx, cat_ly, natom);
  std::vector<double> xmax(2 * n), xmin(2 * n);
  const double lxb = domain->xprd, lyb = domain->yprd;
  for (int k = 0; k < n; k++) {
    const double *a = &amax[k * ncol], *b = &amin[k * ncol];
    if (static_cast<int>(a[0]) != k + 1 || static_cast<int>(b[0]) != k + 1)
      error->one(FLERR, "fix bk/slips: catalogue needs atom IDs 1..{} (bkflow's lattice)", n);
    xmax[2 * k] = a[1] + a[3] * lxb;
    xmax[2 * k + 1] = a[2] + a[4] * lyb;
    xmin[2 * k] = b[1] + b[3] * lxb;
    xmin[2 * k + 1] = b[2] + b[4] * lyb;
  }
  const BKSlipRow r = bk_catalogue::slip_row(xmax, xmin, cat_lx, cat_ly, cat_sx, cat_kb, found);
  const double row[] = {BKNpy::as_double(step_max), BKNpy::as_double(step_min),
                        BKNpy::as_double(r.n_slipped), BKNpy::as_double(r.n_clusters),
                        BKNpy::as_double(r.cluster_n), BKNpy::as_double(r.cluster_nx),
                        BKNpy::as_double(r.cluster_ny), r.potency, r.slip_mean, r.slip_max,
                        r.cluster_lx, r.cluster_ly};
  slip_rows.stage(row, true);
  for (const BKCluster &c : found) {
    const double crow[] = {BKNpy::as_double(step_max), BKNpy::as_double(c.label),
                           BKNpy::as_double(c.n_c), BKNpy::as_double(c.n_x),
                           BKNpy::as_double(c.n_y), c.l_x, c.l_y, c.slip, c.bond_change, c.eq2};
    cluster_rows.stage(crow, true);
  }
  // on disk at most a second after they are known (a deck cut short keeps what it found)
  const auto now = std::chrono::steady_clock::now();
  if (now - rows_written > std::chrono::seconds(1)) {
    rows_written = now;
    for (BKNpy *f : {&slip_rows, &cluster_rows})
      if (!f->write())
        error->one(FLERR, "{} fix bk/slips: writing {} failed: {}", BK_ERR_WRITE_FAILED, f->name,
                   utils::getsyserror());
  }
}

// the base's file buffer and the two snapshots of local atoms
double FixBKSlips::memory_usage()
{
  return FixBKReader::memory_usage() +
      static_cast<double>(snap_max.x.capacity() + snap_min.x.capacity() +
                          snap_max.columns.capacity() + snap_min.columns.capacity()) *
      sizeof(double);
}
