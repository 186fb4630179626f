/* bkflow LAMMPS plugin: finding bkflow's square lattice among LAMMPS's atoms
   (bk_lattice_detect.h). Every test that reduces over ranks is reached by all ranks alike:
   each return before it depends only on values every rank holds. */

#include "bk_lattice_detect.h"

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "lammps.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <mpi.h>

using namespace LAMMPS_NS;

bool bk_lattice::bonds_match(const tagint *tag, const int *num_bond,
                             const tagint *const *bond_atom, int nlocal, int n, int lx)
{
  const int ly = n / lx;
  for (int i = 0; i < nlocal; i++) {
    if (num_bond[i] != 4) return false;
    const int k = static_cast<int>(tag[i]) - 1;
    const int ix = k % lx, iy = k / lx;
    tagint want[4] = {(ix + 1) % lx + lx * iy + 1, (ix + lx - 1) % lx + lx * iy + 1,
                      ix + lx * ((iy + 1) % ly) + 1, ix + lx * ((iy + ly - 1) % ly) + 1};
    tagint got[4];
    for (int b = 0; b < 4; b++) got[b] = bond_atom[i][b];
    std::sort(want, want + 4);
    std::sort(got, got + 4);
    if (!std::equal(want, want + 4, got)) return false;
  }
  return true;
}

double bk_lattice::rows_off_line(double y, tagint tag, int lx, int ly, double lo, double a,
                                 bool periodic)
{
  const double site = lo + (static_cast<double>((tag - 1) / lx) + 0.5) * a;
  double d = std::fabs(y - site) / a;
  if (periodic) {
    d = std::fmod(d, static_cast<double>(ly));
    d = std::min(d, ly - d);
  }
  return d;
}

namespace {

// the ranks' layout the fused path needs on K > 1 ranks: a column of bricks; "" if it has it
std::string rank_layout_problem(LAMMPS *lmp)
{
  const Comm *comm = lmp->comm;
  const int K = comm->nprocs;
  if (K > 1 && comm->layout == Comm::LAYOUT_TILED)
    return fmt::format(" on {} ranks needs LAMMPS's brick layout, each rank a block of "
                       "lattice rows: drop `comm_style tiled` (and `balance ... rcb`)", K);
  if (K > 1 && (comm->procgrid[0] != 1 || comm->procgrid[2] != 1))
    return fmt::format(" on {} ranks needs them in one column, each holding a block of "
                       "lattice rows: add `processors 1 * 1` before read_data (the grid is "
                       "{}x{}x{}{})", K, comm->procgrid[0], comm->procgrid[1],
                       comm->procgrid[2], comm->layout == Comm::LAYOUT_TILED ? ", tiled" : "");
  return {};
}

// an atom map, bonds, at most 2e9 atoms; "" if the atoms have them
std::string topology_problem(const Atom *atom)
{
  if (atom->map_style == Atom::MAP_NONE) return " needs an atom map: atom_modify map array";
  if (!atom->molecular || !atom->num_bond)
    return " needs the bonds (the lattice): add bonds k_b r0";
  if (atom->natoms > 2000000000) return fmt::format(": {} atoms", atom->natoms);
  return {};
}

// atom IDs 1..n (with natoms = n and LAMMPS's IDs unique, every one is present) and one
// positive mass; "" if so. Collective.
std::string ids_and_mass_problem(LAMMPS *lmp, int n)
{
  const Atom *atom = lmp->atom;
  auto mass_of = [atom](int i) {
    return atom->rmass ? atom->rmass[i] : atom->mass ? atom->mass[atom->type[i]] : 0.0;
  };
  double local[3] = {0.0, std::numeric_limits<double>::infinity(),
                     -std::numeric_limits<double>::infinity()};
  for (int i = 0; i < atom->nlocal; i++) {
    if (atom->tag[i] < 1 || atom->tag[i] > n) local[0] = 1.0;
    local[1] = std::min(local[1], mass_of(i));
    local[2] = std::max(local[2], mass_of(i));
  }
  local[1] = -local[1];
  double all[3];
  MPI_Allreduce(local, all, 3, MPI_DOUBLE, MPI_MAX, lmp->world);
  if (all[0] != 0.0) return fmt::format(" needs atom IDs 1..{} (the lattice's)", n);
  if (-all[1] != all[2])
    return fmt::format(" needs one mass for every atom ({} and {})", -all[1], all[2]);
  if (!(all[2] > 0.0)) return ": mass must be > 0";
  return {};
}

// the first divisor lx >= 3 of n (n / lx >= 3) for which every rank's atoms are bonded as
// the lattice of rows of lx; 0 if none. Collective.
int lattice_width(LAMMPS *lmp, int n)
{
  const Atom *atom = lmp->atom;
  for (int lx = 3; lx <= n / 3; lx++) {
    if (n % lx) continue;
    int ok = bk_lattice::bonds_match(atom->tag, atom->num_bond, atom->bond_atom, atom->nlocal,
                                     n, lx) ? 1 : 0;
    int all_ok = 0;
    MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, lmp->world);
    if (all_ok) return lx;
  }
  return 0;
}

// on K > 1 ranks, each particle within a quarter row of its row's line (the ranks' cuts fall
// half a row from these lines); "" if so. Collective.
std::string off_line_problem(LAMMPS *lmp, int K, int n, int lx)
{
  const Atom *atom = lmp->atom;
  const Domain *domain = lmp->domain;
  const int ly = n / lx;
  const double a = domain->yprd / ly, lo = domain->boxlo[1];
  double far = 0.0;    // the farthest off its line, in rows, and its ID (the lowest at a tie)
  tagint who = std::numeric_limits<tagint>::max();
  for (int i = 0; i < atom->nlocal; i++) {
    const double d = bk_lattice::rows_off_line(atom->x[i][1], atom->tag[i], lx, ly, lo, a,
                                               domain->yperiodic);
    if (d > far || (d == far && atom->tag[i] < who)) far = d, who = atom->tag[i];
  }
  double far_all = 0.0;
  MPI_Allreduce(&far, &far_all, 1, MPI_DOUBLE, MPI_MAX, lmp->world);
  tagint mine = far == far_all ? who : std::numeric_limits<tagint>::max(), tag = mine;
  MPI_Allreduce(&mine, &tag, 1, MPI_LMP_TAGINT, MPI_MIN, lmp->world);
  if (far_all > 0.25)
    return fmt::format(" on {} ranks needs every particle within a quarter row of its "
                       "row's line y = ylo + (iy + 1/2) yprd / Ly (the ranks' cuts fall "
                       "half a row from these lines, where bkflow's lattices sit); "
                       "particle {} (row {}) is {:.2f} rows off it", K, tag,
                       (tag - 1) / lx, far_all);
  return {};
}

// what the lattice of rows of lx lacks on K ranks: a row per rank, rows near their lines;
// "" if nothing. Collective.
std::string rows_problem(LAMMPS *lmp, int n, int lx)
{
  const int K = lmp->comm->nprocs;
  if (K > n / lx)
    return fmt::format(" on {} ranks needs at least one lattice row per rank (the lattice "
                       "has {}): run on at most {} ranks", K, n / lx, n / lx);
  if (K > 1) return off_line_problem(lmp, K, n, lx);
  return {};
}

}    // namespace

int LAMMPS_NS::bk_fused_lattice(LAMMPS *lmp, std::string *why)
{
  auto no = [why](std::string reason) {
    if (why) *why = std::move(reason);
    return 0;
  };
  std::string problem = rank_layout_problem(lmp);
  if (problem.empty()) problem = topology_problem(lmp->atom);
  if (!problem.empty()) return no(problem);
  const int n = static_cast<int>(lmp->atom->natoms);
  problem = ids_and_mass_problem(lmp, n);
  if (!problem.empty()) return no(problem);
  const int lx = lattice_width(lmp, n);
  if (!lx)
    return no(": the bonds are not a periodic square lattice with atom ID 1 + ix + Lx iy bonded "
              "to its neighbours at ix +- 1 and iy +- 1 (Lx, Ly >= 3), which the fused path "
              "needs: drop `fused`");
  problem = rows_problem(lmp, n, lx);
  if (!problem.empty()) return no(problem);
  return lx;
}
