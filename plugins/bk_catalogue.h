/* bkflow LAMMPS plugin: one slip's row of the event catalogue and its slip clusters, from the
   unwrapped positions at the slip's maximum and minimum: what bkflow.observables.catalogue.slip_row
   computes from the frames fix bk/slips writes, computed in the run instead (fix bk/slips
   `catalogue`), so that a run keeps a few numbers per slip rather than two frames.

   On bkflow's square lattice of Lx x Ly particles (particle k at site (k mod Lx, k div Lx),
   bonded to its +x and +y neighbours, periodic): a particle slips when its x moved forward by
   more than s_x; the clusters are the connected components of slipping particles through
   bonds joining two of them, numbered by their first particle; for every cluster of two or
   more: N_c, l_x and l_y (docs/model.md: 4 / (n (n - 1)) times the sum over ordered pairs of
   minimum-image distances, of the positions at the maximum), the columns and rows its sites
   occupy, the mean slip delta, the change of the energy k_b/2 (r - 1)^2 of the bonds touching
   it (at their lattice image), and the paper's Eq. 2. tests/observables/test_reduced.py compares every
   number with bkflow.observables.catalogue on the same positions. */

#ifndef BKFLOW_BK_CATALOGUE_H
#define BKFLOW_BK_CATALOGUE_H

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <vector>

namespace LAMMPS_NS {

struct BKSlipRow {
  int64_t n_slipped = 0, n_clusters = 0, cluster_n = 0, cluster_nx = 0, cluster_ny = 0;
  double potency = 0.0, slip_mean = NAN, slip_max = NAN, cluster_lx = NAN, cluster_ly = NAN;
};

struct BKCluster {
  int64_t label = 0, n_c = 0, n_x = 0, n_y = 0;
  double l_x = 0.0, l_y = 0.0, slip = 0.0, bond_change = 0.0, eq2 = 0.0;
};

namespace bk_catalogue {

// the sum over unordered pairs of the minimum-image distance on a ring of `length`
// (bkflow.observables.clusters.periodic_pair_sum): sorted coordinates and prefix sums, O(n log n)
inline double periodic_pair_sum(std::vector<double> x, double length)
{
  const std::size_t n = x.size();
  if (n < 2) return 0.0;
  for (double &v : x) {
    v = std::fmod(v, length);
    if (v < 0) v += length;
  }
  std::sort(x.begin(), x.end());
  std::vector<double> prefix(n + 1, 0.0);
  for (std::size_t i = 0; i < n; i++) prefix[i + 1] = prefix[i] + x[i];
  double near = 0.0, far = 0.0;
  for (std::size_t i = 0; i < n; i++) {
    // the first j with x_j - x_i > L/2
    std::size_t h = std::upper_bound(x.begin(), x.end(), x[i] + 0.5 * length) - x.begin();
    h = std::max(h, i + 1);
    near += (prefix[h] - prefix[i + 1]) - static_cast<double>(h - (i + 1)) * x[i];
    far += static_cast<double>(n - h) * (length + x[i]) - (prefix[n] - prefix[h]);
  }
  return near + far;
}

inline double bond_energy(const double *a, const double *b, double shift_x, double shift_y,
                          double k_b)
{
  const double dx = b[0] - a[0] + shift_x, dy = b[1] - a[1] + shift_y;
  const double r = std::hypot(dx, dy);
  return 0.5 * k_b * (r - 1.0) * (r - 1.0);
}

// the partner of particle k's bond along d (0: +x, 1: +y)
inline int bond_end(int k, int d, int lx, int ly)
{
  const int ix = k % lx, iy = k / lx;
  return d == 0 ? (ix + 1) % lx + lx * iy : ix + lx * ((iy + 1) % ly);
}

/* each particle's slip (its x at the minimum less its x at the maximum), whether it slipped
   (by more than s_x), and the row's count, sum (potency), mean and largest of the slips */
inline void slips(const std::vector<double> &xmax, const std::vector<double> &xmin, int n,
                  double s_x, std::vector<double> &slip, std::vector<char> &mask, BKSlipRow &row)
{
  for (int k = 0; k < n; k++) {
    slip[k] = xmin[2 * k] - xmax[2 * k];
    mask[k] = slip[k] > s_x;
    if (mask[k]) {
      row.n_slipped++;
      row.potency += slip[k];
      row.slip_max = row.n_slipped == 1 ? slip[k] : std::max(row.slip_max, slip[k]);
    }
  }
  if (row.n_slipped) row.slip_mean = row.potency / static_cast<double>(row.n_slipped);
}

/* the clusters: union-find over the bonds joining two slipping particles; label[k] the
   cluster of particle k, 0, 1, ... in order of each cluster's first particle (-1: it did not
   slip). Returns the number of clusters. */
inline int cluster_labels(const std::vector<char> &mask, int lx, int ly, std::vector<int> &label)
{
  const int n = lx * ly;
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  for (int k = 0; k < n; k++)
    for (int d = 0; d < 2; d++) {
      const int j = bond_end(k, d, lx, ly);
      if (mask[k] && mask[j]) {
        const int a = find(k), b = find(j);
        if (a != b) parent[std::max(a, b)] = std::min(a, b);
      }
    }
  std::vector<int> of_root(n, -1);
  int nlabels = 0;
  label.assign(n, -1);
  for (int k = 0; k < n; k++) {
    if (!mask[k]) continue;
    const int r = find(k);
    if (of_root[r] < 0) of_root[r] = nlabels++;
    label[k] = of_root[r];
  }
  return nlabels;
}

/* the change of the bond energies from the maximum to the minimum, summed per cluster each
   bond touches (each end's cluster once): one pass over the bonds, at their lattice image */
inline void bond_changes(const std::vector<double> &xmax, const std::vector<double> &xmin,
                         const std::vector<int> &label, int lx, int ly, double k_b,
                         std::vector<double> &touched)
{
  for (int k = 0; k < lx * ly; k++)
    for (int d = 0; d < 2; d++) {
      const int j = bond_end(k, d, lx, ly);
      if (label[k] < 0 && label[j] < 0) continue;
      const int ix = k % lx, iy = k / lx;
      // the bond's lattice image: +box where it wraps
      const double sx = (d == 0 && ix == lx - 1) ? lx : 0.0;
      const double sy = (d == 1 && iy == ly - 1) ? ly : 0.0;
      const double change = bond_energy(&xmin[2 * k], &xmin[2 * j], sx, sy, k_b) -
          bond_energy(&xmax[2 * k], &xmax[2 * j], sx, sy, k_b);
      if (label[k] >= 0) touched[label[k]] += change;
      if (label[j] >= 0 && label[j] != label[k]) touched[label[j]] += change;
    }
}

/* cluster `label` of particles m (two or more): its size, extent, shape, mean slip, the bond
   energy change `touched` and Eq. 2 */
inline BKCluster cluster_of(int label, const std::vector<int> &m, const std::vector<double> &xmax,
                            const std::vector<double> &slip, int lx, int ly, double k_b,
                            double touched)
{
  BKCluster cl;
  cl.label = label;
  cl.n_c = static_cast<int64_t>(m.size());
  std::vector<double> xs, ys;
  std::vector<char> col(lx, 0), rowhit(ly, 0);
  double sum = 0.0;
  for (int k : m) {
    xs.push_back(xmax[2 * k]);
    ys.push_back(xmax[2 * k + 1]);
    col[k % lx] = 1;
    rowhit[k / lx] = 1;
    sum += slip[k];
  }
  const double pairs = static_cast<double>(cl.n_c) * static_cast<double>(cl.n_c - 1);
  cl.l_x = 8.0 * periodic_pair_sum(xs, lx) / pairs;
  cl.l_y = 8.0 * periodic_pair_sum(ys, ly) / pairs;
  cl.n_x = std::count(col.begin(), col.end(), 1);
  cl.n_y = std::count(rowhit.begin(), rowhit.end(), 1);
  cl.slip = sum / static_cast<double>(cl.n_c);
  cl.bond_change = touched;
  const double delta = cl.slip;
  const double stretch = std::sqrt(delta * delta + 1.0) - 1.0;
  cl.eq2 = (cl.n_x < lx ? k_b * cl.n_y * delta * delta : 0.0) +
      (cl.n_y < ly ? k_b * cl.n_x * stretch * stretch : 0.0);
  return cl;
}

// the row's columns of the largest cluster (the first of the largest)
inline void take_largest(const std::vector<BKCluster> &clusters, BKSlipRow &row)
{
  const BKCluster *big = nullptr;
  for (const auto &cl : clusters)
    if (!big || cl.n_c > big->n_c) big = &cl;
  if (big) {
    row.cluster_n = big->n_c;
    row.cluster_nx = big->n_x;
    row.cluster_ny = big->n_y;
    row.cluster_lx = big->l_x;
    row.cluster_ly = big->l_y;
  }
}

/* the row and clusters of one slip: xmax, xmin (2N, unwrapped x y by particle) */
inline BKSlipRow slip_row(const std::vector<double> &xmax, const std::vector<double> &xmin,
                          int lx, int ly, double s_x, double k_b,
                          std::vector<BKCluster> &clusters)
{
  const int n = lx * ly;
  BKSlipRow row;
  clusters.clear();
  std::vector<double> slip(n);
  std::vector<char> mask(n);
  slips(xmax, xmin, n, s_x, slip, mask, row);
  std::vector<int> label;
  const int nlabels = cluster_labels(mask, lx, ly, label);
  std::vector<std::vector<int>> members(nlabels);
  for (int k = 0; k < n; k++)
    if (label[k] >= 0) members[label[k]].push_back(k);
  // the bonds only where a cluster of two or more exists
  std::vector<double> touched(nlabels, 0.0);
  bool any = false;
  for (auto &m : members) any = any || m.size() >= 2;
  if (any) bond_changes(xmax, xmin, label, lx, ly, k_b, touched);
  for (int c = 0; c < nlabels; c++)
    if (members[c].size() >= 2)
      clusters.push_back(cluster_of(c, members[c], xmax, slip, lx, ly, k_b, touched[c]));
  row.n_clusters = static_cast<int64_t>(clusters.size());
  take_largest(clusters, row);
  return row;
}

}    // namespace bk_catalogue
}    // namespace LAMMPS_NS

#endif
