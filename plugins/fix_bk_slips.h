/* bkflow LAMMPS plugin: fix bk/slips, the atom positions at the maximum and at the following
   minimum of every slip event of a fix bk/substrate's sigma_x (zigzag rule of
   src/bkflow/observables/stress.py), without dumping every step. See plugins/README.md. */

#ifndef BKFLOW_FIX_BK_SLIPS_H
#define BKFLOW_FIX_BK_SLIPS_H

#include "bk_catalogue.h"
#include "bk_npy.h"
#include "fix_bk_reader.h"

#include <vector>

namespace LAMMPS_NS {

class FixBKSlips : public FixBKEvents {
 public:
  FixBKSlips(class LAMMPS *, int, char **);
  ~FixBKSlips() override;
  void init() override;
  void post_run() override;
  double memory_usage() override;

 private:
  int ncol = 5;    // columns of a snapshot (6 with `breaks`)
  /* a snapshot of the local atoms. Taken at every new running extremum of sigma_x (every
     sample while the layer loads), so it copies LAMMPS's arrays as they are (x, tags, image
     flags, with the box lengths the substrate fix had taken out of the flags then), and is
     turned into columns (cols()) only for the slips that are written. With `breaks`, or a
     group other than all, the columns are made at once. */
  struct Snap {
    std::vector<double> x;        // 3 per atom, LAMMPS's x
    std::vector<tagint> tag;
    std::vector<imageint> image;
    bigint base[2] = {0, 0};
    std::vector<double> columns;  // tag, x, y, ix, iy (and brk): ncol per atom
    bool raw = false;
  };
  Snap snap_max, snap_min;
  std::vector<double> cols(const Snap &s) const;

  int frames = 1;    // frames written (`file none`: not)
  BKNpy slip_rows, cluster_rows;    // `catalogue`
  std::vector<BKCluster> found;
  std::chrono::steady_clock::time_point rows_written = std::chrono::steady_clock::now();

  void sample() override;
  void snapshot(Snap &s);
  // the snapshot gathered on rank 0, sorted by atom ID (ncol values per atom); empty elsewhere
  std::vector<double> gather(const std::vector<double> &buf);
  void write_frame(const std::vector<double> &all, bigint step);
  void catalogue(const std::vector<double> &amax, const std::vector<double> &amin,
                 bigint step_max, bigint step_min);
};

}    // namespace LAMMPS_NS

#endif
