/* bkflow LAMMPS plugin: fix bk/fronts

     fix ID group bk/fronts Nevery substrate-fix-ID threshold file FILE [start STEP] [limit K]

   Every Nevery steps it reads sigma_x (element 1 of the substrate fix's global vector),
   follows the slip events of the zigzag rule (bk_zigzag.h: the events of fix bk/slips and of
   the analysis) and keeps the x velocity (the slip rate) of every local atom at every sample
   since the running maximum. When an event is confirmed, the samples from its maximum to its
   minimum are gathered on rank 0 and appended to FILE, and the samples before the next
   maximum are dropped: memory holds one event at a time (at most MAX_SAMPLES samples; an
   event longer than that keeps its last MAX_SAMPLES and is marked truncated). Nothing is
   kept for an event that will not be written (its maximum before `start`, or `limit`
   reached).

   FILE is binary, little-endian, so that a front at fine time resolution stays small:
     header:  8 bytes "BKFRONT1", int64 number of atoms N
     events:  int64 step of the maximum, int64 step of the minimum, int64 samples S,
              int64 flags (1: truncated), S x int64 steps, S x N x float32 v_x by atom ID
   bkflow.store.rundir reads it (RunDir.read_fronts). Events whose maximum lies before step `start`
   (the transient) are followed but not written; `limit K` writes the first K only.
   Global vector: [1] events confirmed, [2] events written. */

#include "fix_bk_fronts.h"

#include "atom.h"
#include "comm.h"
#include "error.h"
#include "fix_bk_layer.h"
#include "update.h"

#include <algorithm>
#include <cstdint>
#include <cstring>

using namespace LAMMPS_NS;

namespace {
const char *USAGE = "fix ID group bk/fronts Nevery substrate-fix-ID threshold file FILE "
                    "[start STEP] [limit K] [append]";
// the longest event kept whole, in samples (20000 time units at bkflow's 0.1 sampling)
constexpr std::size_t MAX_SAMPLES = 200000;
}    // namespace

FixBKFronts::FixBKFronts(LAMMPS *lmp, int narg, char **arg) :
    FixBKEvents(lmp, narg, arg, USAGE, true)
{
  natoms = atom->natoms;
  if (comm->me == 0 && !appending) {
    const int64_t n = natoms;
    write("BKFRONT1", 8);
    write(reinterpret_cast<const char *>(&n), sizeof(n));
    flush();
  }
}

// the local atoms' tags and x velocities at this step
void FixBKFronts::record(bigint step)
{
  if (samples.size() >= MAX_SAMPLES) {
    samples.pop_front();
    truncated = true;
  }
  Sample &s = samples.emplace_back();
  s.step = step;
  const int nlocal = atom->nlocal;
  const int *mask = atom->mask;
  s.tag.reserve(nlocal);
  s.vx.reserve(nlocal);
  for (int i = 0; i < nlocal; i++) {
    if (!(mask[i] & groupbit)) continue;
    s.tag.push_back(atom->tag[i]);
    s.vx.push_back(static_cast<float>(atom->v[i][0]));
  }
}

void FixBKFronts::sample()
{
  const bigint step = update->ntimestep;
  const auto event = zigzag.feed(substrate->compute_vector(BK_SLOT_SIGMA), step);
  if (event == BKZigzag::CONFIRMED) {
    nevents++;
    if (writes(zigzag.event_max)) {
      write_event(zigzag.event_max, zigzag.event_min);
      nwritten++;
    }
  }
  if (event == BKZigzag::NEW_MAX || event == BKZigzag::CONFIRMED) {
    samples.clear();    // an event starts at its maximum: nothing before it is needed
    truncated = false;
  }
  // only the open event can still be written: not if its maximum lies in the transient, nor
  // once `limit` events are written (then the fix costs one sigma_x per sample)
  if (writes(zigzag.step_max)) record(step);
}

void FixBKFronts::write_event(bigint from, bigint to)
{
  std::vector<const Sample *> chosen;
  for (const Sample &s : samples)
    if (s.step >= from && s.step <= to) chosen.push_back(&s);
  const int me = comm->me, nprocs = comm->nprocs;
  std::vector<float> frame, all_v;
  std::vector<tagint> all_t;
  std::vector<int> counts(nprocs), displs(nprocs);
  if (me == 0) {
    const int64_t head[4] = {from, to, static_cast<int64_t>(chosen.size()), truncated ? 1 : 0};
    write(reinterpret_cast<const char *>(head), sizeof(head));
    for (const Sample *s : chosen) {
      const int64_t step = s->step;
      write(reinterpret_cast<const char *>(&step), sizeof(step));
    }
    frame.resize(natoms);
  }
  for (const Sample *s : chosen) {
    int n = static_cast<int>(s->vx.size());
    MPI_Gather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, world);
    int total = 0;
    if (me == 0)
      for (int p = 0; p < nprocs; p++) displs[p] = total, total += counts[p];
    all_v.resize(total);
    all_t.resize(total);
    MPI_Gatherv(s->vx.data(), n, MPI_FLOAT, all_v.data(), counts.data(), displs.data(),
                MPI_FLOAT, 0, world);
    MPI_Gatherv(s->tag.data(), n, MPI_LMP_TAGINT, all_t.data(), counts.data(), displs.data(),
                MPI_LMP_TAGINT, 0, world);
    if (me != 0) continue;
    std::fill(frame.begin(), frame.end(), 0.0f);
    for (int k = 0; k < total; k++)
      if (all_t[k] >= 1 && all_t[k] <= natoms) frame[all_t[k] - 1] = all_v[k];
    write(reinterpret_cast<const char *>(frame.data()), frame.size() * sizeof(float));
  }
  flush();    // every event reaches the file at once
}

double FixBKFronts::memory_usage()
{
  double bytes = FixBKReader::memory_usage();
  for (const Sample &s : samples)
    bytes += static_cast<double>(s.tag.capacity() * sizeof(tagint) + s.vx.capacity() * 4);
  return bytes;
}
