"""Bond-orientational order Psi(t) of the layer (docs/model.md, "Observables": Order).

Psi = (1/N) sum_i |psi_i|, psi_i = (1/n_i) sum_{j bonded to i} exp(4 i theta_ij), theta_ij the
angle of the bond vector to x and n_i the number of bonds of i (4 on the lattice, which is
docs/model.md's 1/4). Psi = 1 on the square lattice at any rotation; bond angles drawn
uniformly at random give E|sum of 4 unit phasors| / 4 = 0.4498
(tests/observables/test_exact_answers.py derives it).

Bond vectors. A minimum image would only be right while every bond is shorter than half
the box. A soft layer (phi = 0.1 on 20x5) stretches bonds past 2.5 l, where the
minimum image jumps to another partner image. So for runs the bond vector keeps the lattice
image, exactly as fix bk/substrate does: with unwrapped positions R (image flags applied) and
the per-bond box shift s_b taken once from the reference lattice,
d_b = R_j - R_i + s_b. ``bond_vectors`` also offers the minimum image (``box=...``) for
configurations that are not runs (and to compare with freud, which uses it).

Everything is vectorised over bonds and over frames; no Python loop over atoms.

>>> from bkflow.model.lattice import square_lattice
>>> lat = square_lattice(4, 3)
>>> shifts = lattice_shifts(lat.positions, lat.bonds, lat.box)
>>> float(psi(bond_vectors(lat.positions, lat.bonds, shifts=shifts), lat.bonds, 12))
1.0
"""

from __future__ import annotations

import numpy as np

from bkflow.model.params import PSI_LATE_FRACTION as DEFAULT_LATE_FRACTION


def minimum_image(d, box) -> np.ndarray:
    """Minimum-image of displacement(s) ``d`` (..., 2) in an orthogonal periodic box (Lx, Ly)."""
    box = np.asarray(box, dtype=float)[:2]
    return d - box * np.round(d / box)


def lattice_shifts(reference, bonds, box) -> np.ndarray:
    """Per-bond box shift s_b (Nb, 2) that turns R_j - R_i of the reference lattice into its
    lattice (minimum-image) bond vector; it stays valid for unwrapped positions at any time."""
    reference = np.asarray(reference, dtype=float)[:, :2]
    bonds = np.asarray(bonds)
    d0 = reference[bonds[:, 1]] - reference[bonds[:, 0]]
    return minimum_image(d0, box) - d0


def bond_vectors(positions, bonds, box=None, shifts=None) -> np.ndarray:
    """Bond vectors R_j - R_i of every bond (i, j), for one frame (N, 2) or many (F, N, 2).

    ``shifts`` (Nb, 2): the fixed lattice images of ``lattice_shifts``, for unwrapped
    positions of a run. ``box`` (Lx, Ly): minimum image instead. Exactly one must be given.
    """
    if (box is None) == (shifts is None):
        raise ValueError("give exactly one of box (minimum image) or shifts (lattice images)")
    r = np.asarray(positions, dtype=float)[..., :2]
    bonds = np.asarray(bonds)
    d = r[..., bonds[:, 1], :] - r[..., bonds[:, 0], :]
    if shifts is not None:
        return d + np.asarray(shifts, dtype=float)
    return minimum_image(d, box)


def _incidence(bonds, n_atoms: int):
    import scipy.sparse as sp  # (here: a run without snapshots never pays for scipy.sparse)

    bonds = np.asarray(bonds)
    nb = len(bonds)
    rows = np.concatenate([bonds[:, 0], bonds[:, 1]])
    cols = np.concatenate([np.arange(nb), np.arange(nb)])
    return sp.csr_matrix((np.ones(2 * nb), (rows, cols)), shape=(n_atoms, nb))


def particle_order(vectors, bonds, n_atoms: int, k: int = 4) -> np.ndarray:
    """Complex psi_i = (1/n_i) sum_j exp(k i theta_ij), shape (N,) or (F, N) like ``vectors``.

    Each bond counts for both of its ends (theta and theta + pi give the same phase for even
    k). Particles without bonds get 0.
    """
    v = np.asarray(vectors, dtype=float)
    z = (v[..., 0] + 1j * v[..., 1]) / np.hypot(v[..., 0], v[..., 1])
    if k % 2:
        raise ValueError("k must be even: a bond is shared by its two ends")
    zk = z ** k
    inc = _incidence(bonds, n_atoms)
    degree = np.asarray(inc.sum(axis=1)).ravel()
    with np.errstate(invalid="ignore", divide="ignore"):
        norm = np.where(degree > 0, 1.0 / degree, 0.0)
    if zk.ndim == 1:
        return (inc @ zk) * norm
    return (inc @ zk.T).T * norm


def psi(vectors, bonds, n_atoms: int, k: int = 4):
    """Psi = mean_i |psi_i|: a float for one frame, an array (F,) for frames (F, Nb, 2)."""
    p = np.abs(particle_order(vectors, bonds, n_atoms, k)).mean(axis=-1)
    return float(p) if np.ndim(p) == 0 else p


def psi_inf(t, psi_t, late_fraction: float = DEFAULT_LATE_FRACTION) -> float:
    """Psi(inf): the mean of Psi(t) over the last ``late_fraction`` of the time span."""
    t = np.asarray(t, dtype=float)
    p = np.asarray(psi_t, dtype=float)
    if len(t) == 0:
        return float("nan")
    late = t >= t[-1] - late_fraction * (t[-1] - t[0])
    return float(p[late].mean())
