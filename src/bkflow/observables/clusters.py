"""Clusters of slipping particles, their extents l_x, l_y, and the regime of a run
(docs/model.md, "Observables": Slip clusters, Asymmetry, Regimes).

For one slip event the slipping particles are those whose x moved forward (signed) by more
than S_x between the stress maximum and the following minimum; clusters are the connected
components of those particles through the bond network (``scipy.sparse.csgraph``). For a
cluster of N_c >= 2 particles, with minimum-image distances and positions at the event onset,

    l_x = 4 / (N_c (N_c - 1)) * sum over ordered pairs i != j of |dx_ij|,   l_y likewise,

so that a cluster filling the periodic box gives l_x = Lx N/(N-1) and l_y = Ly N/(N-1) (the
"lattice's discreteness" of docs/model.md: the distances from one of L equally spaced sites on a
ring to the others sum to L^2/4; for odd L it is (L^2 - 1)/4, a further factor 1 - 1/L^2),
and one full row gives l_x = Lx Lx/(Lx-1), l_y = 0. The regimes compare each extent with the
whole box's own on that side (``box_extent``), so that the parity of a side decides nothing.
The pair sum is computed in O(N_c log N_c) from sorted coordinates and prefix sums, so a
cluster of the whole 120x30 layer costs no more memory than its positions.

>>> import numpy as np
>>> from bkflow.model.lattice import square_lattice
>>> lat = square_lattice(6, 3)
>>> row = np.zeros(18, bool); row[6:12] = True
>>> labels = slip_clusters(row, lat.bonds)
>>> ext = cluster_extents(lat.positions, labels, lat.box)
>>> ext.n_c.tolist(), ext.l_x.round(3).tolist(), ext.l_y.tolist()
([6], [7.2], [0.0])
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bkflow.model.lattice import box_fractions
from bkflow.model.params import PSI_CRYSTAL as DEFAULT_PSI_CRYSTAL
from bkflow.model.params import S_X as DEFAULT_S_X
from bkflow.model.params import SPAN_FRACTION as DEFAULT_SPAN_FRACTION


def slipping(x_onset, x_end, s_x: float = DEFAULT_S_X) -> np.ndarray:
    """Boolean mask of particles whose unwrapped x moved forward by more than ``s_x``."""
    return (np.asarray(x_end, dtype=float) - np.asarray(x_onset, dtype=float)) > s_x


def slip_clusters(mask, bonds) -> np.ndarray:
    """Cluster label per particle (0, 1, ... in order of first particle; -1 = not slipping):
    connected components of the masked particles through the bonds joining two of them."""
    import scipy.sparse as sp  # (here: a run without slips never pays for scipy.sparse)
    from scipy.sparse.csgraph import connected_components

    mask = np.asarray(mask, dtype=bool)
    bonds = np.asarray(bonds)
    n = len(mask)
    keep = mask[bonds[:, 0]] & mask[bonds[:, 1]]
    b = bonds[keep]
    graph = sp.coo_matrix((np.ones(len(b)), (b[:, 0], b[:, 1])), shape=(n, n))
    _, comp = connected_components(graph, directed=False)
    labels = np.full(n, -1, dtype=np.int64)
    if mask.any():
        # relabel the components of slipping particles 0, 1, ... in order of appearance
        _, first, inverse = np.unique(comp[mask], return_index=True, return_inverse=True)
        rank = np.argsort(np.argsort(first))
        labels[mask] = rank[inverse]
    return labels


def periodic_pair_sum(x, length: float) -> float:
    """Sum over unordered pairs of the minimum-image distance |dx| on a ring of ``length``."""
    x = np.sort(np.mod(np.asarray(x, dtype=float), length))
    n = len(x)
    if n < 2:
        return 0.0
    prefix = np.concatenate([[0.0], np.cumsum(x)])
    i = np.arange(n)
    # partners j > i closer than half the ring forward (direct) or not (wrapped around)
    h = np.searchsorted(x, x + 0.5 * length, side="right")  # first j with x_j - x_i > L/2
    h = np.maximum(h, i + 1)
    n_near = h - (i + 1)
    near = (prefix[h] - prefix[i + 1]) - n_near * x
    n_far = n - h
    far = n_far * (length + x) - (prefix[n] - prefix[h])
    return float(np.sum(near) + np.sum(far))


def extent(x, length: float) -> float:
    """docs/model.md's l along one axis: 4 / (n (n - 1)) * sum over ordered pairs of |dx_ij|."""
    n = len(x)
    if n < 2:
        return math.nan
    return 4.0 * 2.0 * periodic_pair_sum(x, length) / (n * (n - 1))


@dataclass(frozen=True)
class ClusterExtents:
    """One entry per cluster of at least ``min_size`` particles: label, N_c, l_x, l_y."""

    label: np.ndarray
    n_c: np.ndarray
    l_x: np.ndarray
    l_y: np.ndarray

    def __len__(self) -> int:
        return len(self.label)


def cluster_extents(positions, labels, box, min_size: int = 2) -> ClusterExtents:
    """l_x, l_y of every labelled cluster (positions (N, 2) at the onset, any image)."""
    r = np.asarray(positions, dtype=float)[:, :2]
    labels = np.asarray(labels)
    Lx, Ly = float(box[0]), float(box[1])
    out = {"label": [], "n_c": [], "l_x": [], "l_y": []}
    order = np.argsort(labels, kind="stable")
    sl = labels[order]
    starts = np.searchsorted(sl, np.unique(sl[sl >= 0]))
    ends = np.append(starts[1:], len(sl))
    for s, e in zip(starts, ends):  # one iteration per cluster, vectorised inside
        idx = order[s:e]
        if len(idx) < min_size:
            continue
        out["label"].append(int(sl[s]))
        out["n_c"].append(len(idx))
        out["l_x"].append(extent(r[idx, 0], Lx))
        out["l_y"].append(extent(r[idx, 1], Ly))
    return ClusterExtents(np.array(out["label"], dtype=np.int64),
                          np.array(out["n_c"], dtype=np.int64),
                          np.array(out["l_x"], dtype=float), np.array(out["l_y"], dtype=float))


def event_clusters(x_onset, x_end, bonds, box, s_x: float = DEFAULT_S_X) -> ClusterExtents:
    """Clusters of one slip event from unwrapped positions (N, 2) at its maximum and minimum."""
    x_onset = np.asarray(x_onset, dtype=float)
    mask = slipping(x_onset[:, 0], np.asarray(x_end, dtype=float)[:, 0], s_x)
    return cluster_extents(x_onset, slip_clusters(mask, bonds), box)


@dataclass(frozen=True)
class ClusterShape:
    """Means over all clusters of a run: <l_x/Lx>, <l_y/Ly>, <l_x>/<l_y>; the fraction of
    clusters in each regime and the run's regime (the most frequent one)."""

    lx_mean_over_Lx: float
    ly_mean_over_Ly: float
    lx_over_ly: float
    n_clusters: int
    regime_fractions: dict
    regime: str | None


REGIMES = ("C", "W", "LC", "DP", "DT")


def regime(fx, fy, psi_inf: float, span: float = DEFAULT_SPAN_FRACTION,
           psi_crystal: float = DEFAULT_PSI_CRYSTAL):
    """Regime of a cluster from its extents as fractions of the whole box's own on each side
    (``box_fractions``) and the run's Psi(inf), in docs/model.md's terms (Fig. 4a of the paper
    is this classification of single clusters):

    - ``C``  (crystalline, the whole system slips): fx >= span and fy >= span, in a
      crystalline layer (Psi(inf) >= psi_crystal);
    - ``W``  (the whole box slips in a layer that is not crystalline): fx >= span and
      fy >= span otherwise. A slip that spans both axes is never DP or DT: their
      comparison of fx with fy is noise for it (both about 1);
    - ``LC`` (laminar crystalline, whole rows): fx >= span and fy < span;
    - ``DP`` (disorder-parallel): x not spanned, fx >= fy;
    - ``DT`` (disorder-transverse): x not spanned, fx < fy.

    ``span`` = 0.9 by default: whole rows give fx = (N-1)/N Lx/(Lx-1) >= 1 (even Lx), and
    4 of 5 rows give fy = 0.94. Works on scalars (a label, None for NaN) and on arrays (an
    array of labels, "" for NaN).
    """
    fx, fy = np.asarray(fx, dtype=float), np.asarray(fy, dtype=float)
    crystal = math.isfinite(psi_inf) and psi_inf >= psi_crystal
    label = np.where(fx >= fy, "DP", "DT").astype(object)
    label = np.where((fx >= span) & (fy < span), "LC", label)
    label = np.where((fx >= span) & (fy >= span), "C" if crystal else "W", label)
    label = np.where(np.isfinite(fx) & np.isfinite(fy), label, "")
    if label.ndim == 0:
        return str(label) or None
    return label


def cluster_shape(l_x, l_y, box, psi_inf: float = math.nan,
                  span: float = DEFAULT_SPAN_FRACTION,
                  psi_crystal: float = DEFAULT_PSI_CRYSTAL) -> ClusterShape:
    """Averages over all clusters of a run (each cluster counts once), and its regime: every
    cluster is classified by ``regime`` of its ``box_fractions`` and the run takes the most
    frequent label (ties go to the first in REGIMES' order: C, W, LC, DP, DT)."""
    l_x = np.asarray(l_x, dtype=float)
    l_y = np.asarray(l_y, dtype=float)
    if len(l_x) == 0:
        return ClusterShape(math.nan, math.nan, math.nan, 0, {}, None)
    fx = float(np.mean(l_x) / box[0])
    fy = float(np.mean(l_y) / box[1])
    my = float(np.mean(l_y))
    ratio = float(np.mean(l_x) / my) if my > 0 else math.inf
    labels = regime(*box_fractions(l_x, l_y, box), psi_inf, span, psi_crystal)
    fractions = {r: float(np.mean(labels == r)) for r in REGIMES}
    best = max(REGIMES, key=lambda r: (fractions[r], -REGIMES.index(r)))
    return ClusterShape(fx, fy, ratio, len(l_x), fractions, best)
