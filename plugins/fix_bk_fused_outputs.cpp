/* bkflow LAMMPS plugin: the outputs of `fix bk/substrate ... fused` (fix_bk_fused.h), computed
   from the fix's own arrays in lattice order: sigma_x, the contact breaks, the longest bond,
   the bond energy (the scalar), the energies of the step and the contacts' phase sums, and
   each contact's first break. Sums over the lattice are made row by row and added in row order
   (BKRowBlocks::row_totals), so that they are the same bits on any number of ranks; each is
   computed once per step, when first asked. */

#include "fix_bk_fused.h"

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "force.h"
#include "update.h"

#include <cmath>
#include <cstring>
#include <vector>

using namespace LAMMPS_NS;

/* sigma_x = sum_k k_d^k (plate shift - (X_k - anchor_k)) / (Lx Ly), summed in lattice order
   within each row and then over rows, from the positions of the step, computed once per step
   when first asked (bk/stress, thermo) */

double FixBKFused::sigma_x()
{
  const bigint step = update->ntimestep;
  if (sigma_step != step) {
    std::vector<double> rows(blocks.nrows, 0.0);
    bkfused::sigma_rows(arr, Lx, blocks.nrows, plate_shift, rows.data());
    sigma_value = blocks.row_sum_total(rows, world) / (domain->xprd * domain->yprd);
    sigma_step = step;
  }
  return sigma_value;
}

// the contact breaks of the last step or since the fix was defined, over every rank
double FixBKFused::breaks(bool total)
{
  double b = static_cast<double>(total ? nbreak_total : nbreak_step);
  if (blocks.slab()) MPI_Allreduce(MPI_IN_PLACE, &b, 1, MPI_DOUBLE, MPI_SUM, world);
  return b;
}

double FixBKFused::longest_bond()
{
  const bigint step = update->ntimestep;
  if (rmax_step != step) {
    double r2max = bkfused::longest_bond2(arr, Lx, Ly, blocks.slab(), blocks.nloc);
    if (blocks.slab()) MPI_Allreduce(MPI_IN_PLACE, &r2max, 1, MPI_DOUBLE, MPI_MAX, world);
    rmax_value = sqrt(r2max);
    rmax_step = step;
  }
  return rmax_value;
}

void FixBKFused::clear_first_breaks()
{
  FixBKLayer::clear_first_breaks();
  if (lattice_ready)
    for (int k = 0; k < blocks.nloc; k++) arr.fb[k] = -1.0;
}

double FixBKFused::first_break_of(int i) const
{
  if (!lattice_ready) return FixBKLayer::first_break_of(i);
  const double b = arr.fb[atom->tag[i] - 1 - static_cast<tagint>(blocks.row0) * Lx];
  return b >= break_mark ? b : -1.0;
}

int FixBKFused::path_code() const
{
  return strcmp(kernel.isa, "avx512") == 0 ? BK_PATH_FUSED_AVX512
      : strcmp(kernel.isa, "avx2") == 0    ? BK_PATH_FUSED_AVX2
                                           : BK_PATH_FUSED_BASELINE;
}

// the contacts' phase sums from the fix's own arrays, row by row (BKRowBlocks::row_totals)
void FixBKFused::contact_phase(double *sums)
{
  if (!lattice_ready || !have_state) return FixBKLayer::contact_phase(sums);
  const int nrows = blocks.nrows;
  std::vector<double> rows(static_cast<size_t>(nrows) * BK_NPHASE, 0.0);
  if (contact != BK_NO_CONTACT)
    for (int r = 0; r < nrows; r++)
      kernel.phase(arr.drx + r * Lx, arr.dry + r * Lx, Lx, ke / fmax, &rows[r * BK_NPHASE]);
  blocks.row_totals(rows, BK_NPHASE, sums, world);
}

/* the energies of the current step from the fix's own arrays (the kernel's, vectorized):
   bonds, drive springs, contacts, kinetic (the full-step velocities), row by row and summed
   over the lattice in row order (BKRowBlocks::row_totals, collective), the same bits on any
   number of ranks; rank 0 holds them and the others zeros, so the caller's sum over ranks
   adds only zeros to them */
void FixBKFused::local_energies(double *e)
{
  e[0] = e[1] = e[2] = e[3] = 0.0;
  if (!lattice_ready || !have_state) return;
  std::vector<double> rows(static_cast<size_t>(blocks.nrows) * 4, 0.0);
  kernel.energies(model, arr, plate_shift, rows.data());
  blocks.row_totals(rows, 4, e, world);
  e[3] *= 0.5 * model.mass;
  e[3] *= force->mvv2e;    // energy units, as the kicks' ftm2v (1 in lj units)
  if (!model.drive) e[1] = 0.0;
  if (model.contact == BK_NO_CONTACT) e[2] = 0.0;
  if (comm->me != 0) e[0] = e[1] = e[2] = e[3] = 0.0;
}

// the bond energy sum k_b/2 (r - r0)^2, row by row (BKRowBlocks::row_sum_total)
double FixBKFused::compute_scalar()
{
  if (!lattice_ready || !have_state) return 0.0;    // before the first setup: no state yet
  std::vector<double> rows(blocks.nrows, 0.0);
  bkfused::bond_energy_rows(arr, Lx, Ly, blocks.slab(), blocks.nrows, kb, r0, rows.data());
  return blocks.row_sum_total(rows, world);
}
