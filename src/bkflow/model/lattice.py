"""The square lattice of docs/model.md: positions, the 2N periodic bonds, and the drive stiffnesses.

Particle i = ix + Lx * iy sits at ((ix + 1/2) l, (iy + 1/2) l) in the box [0, Lx l) x [0, Ly l).
Each particle owns two bonds, to its +x and its +y neighbour (periodic), so every particle has
four bonds and there are 2N in all.

>>> lat = square_lattice(4, 2)
>>> lat.positions.shape, lat.bonds.shape
((8, 2), (16, 2))
>>> lat.bonds[:2].tolist()
[[0, 1], [0, 4]]
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bkflow.model.params import PARTIAL_FRACTION, RunSpec


@dataclass(frozen=True)
class Lattice:
    """Positions (N, 2), 0-based bond pairs (2N, 2), box lengths and per-particle k_d^i."""

    Lx: int
    Ly: int
    positions: np.ndarray
    bonds: np.ndarray
    k_d: np.ndarray

    @property
    def box(self) -> tuple[float, float]:
        return float(self.Lx), float(self.Ly)


def square_lattice(Lx: int, Ly: int) -> Lattice:
    """Lattice geometry (l = 1) with every k_d^i = 1 (use ``lattice_for`` for a run's
    k_d^i)."""
    ix, iy = np.meshgrid(np.arange(Lx), np.arange(Ly), indexing="xy")
    ix, iy = ix.ravel(), iy.ravel()
    positions = np.column_stack([ix + 0.5, iy + 0.5]).astype(float)
    idx = ix + Lx * iy
    right = (ix + 1) % Lx + Lx * iy
    up = ix + Lx * ((iy + 1) % Ly)
    bonds = np.empty((2 * Lx * Ly, 2), dtype=np.int64)
    bonds[0::2, 0] = idx
    bonds[0::2, 1] = right
    bonds[1::2, 0] = idx
    bonds[1::2, 1] = up
    return Lattice(Lx, Ly, positions, bonds, np.ones(Lx * Ly))


def box_extent(n_along: int, n_across: int) -> float:
    """l along a side of ``n_along`` sites of the whole box of n_along x n_across sites (unit
    spacing), every particle in the cluster: 4 n_across^2 n_along S / (N (N - 1)), N the
    particles, S = floor(n_along^2 / 4) the ring distances from one site to the others.
    That is L N/(N-1) for an even side and a further 1 - 1/L^2 for an odd one: the odd side's
    whole-box extent is the smaller, so l/L would call a whole-box slip longer along the
    even side (tests/observables/test_exact_answers.py)."""
    n_along, n_across = int(n_along), int(n_across)
    n = n_along * n_across
    if n < 2:
        return math.nan
    return 4.0 * n_across ** 2 * n_along * (n_along * n_along // 4) / (n * (n - 1))


def box_fractions(l_x, l_y, box) -> tuple[np.ndarray, np.ndarray]:
    """l_x and l_y as fractions of the whole box's own extent on each side (``box_extent``;
    ``box`` in lattice units, one site per unit): 1 on both for a whole-box slip on any
    lattice, odd or even sides."""
    lx_sites, ly_sites = int(round(float(box[0]))), int(round(float(box[1])))
    return (np.asarray(l_x, dtype=float) / box_extent(lx_sites, ly_sites),
            np.asarray(l_y, dtype=float) / box_extent(ly_sites, lx_sites))


def drive_stiffness(spec: RunSpec) -> np.ndarray:
    """k_d^i uniform in (k_d - dk_d, k_d + dk_d), from ``numpy.random.default_rng(seed)``."""
    rng = np.random.default_rng(spec.seed)
    return rng.uniform(spec.k_d - spec.dk_d, spec.k_d + spec.dk_d, spec.N)


def contact_start(spec: RunSpec) -> np.ndarray:
    """The contact displacement of each particle at t = 0, along x (docs/model.md "Starting
    state"), as the phase u_i times mu_s sigma_n A / k_e: 0 for the synchronized start; for the
    random start u_i uniform in [0, 1); for the stratified start u_i = (k_i + 1/2) / N with k_i
    a random permutation of 0..N-1 (the phases evenly spread); for the partial start, M =
    round(PARTIAL_FRACTION N) contacts chosen at random share the phase 1/(2N) and the others
    are stratified among themselves, u = (k + 1/2) / (N - M) (so R = M / N at t = 0). All draw
    from a stream of the run's seed that is independent of the k_d^i draw (the child
    ``spawn_key=(1,)`` of the seed's ``numpy.random.SeedSequence``).

    >>> spec = RunSpec(phi=10.0, Lx=4, Ly=3, start="stratified")
    >>> u = contact_start(spec) * spec.k_e / spec.friction_threshold
    >>> (np.sort(u) * spec.N).round(12).tolist()
    [0.5, 1.5, 2.5, 3.5, 4.5, 5.5, 6.5, 7.5, 8.5, 9.5, 10.5, 11.5]
    """
    if spec.start == "synchronized":
        return np.zeros(spec.N)
    rng = np.random.default_rng(np.random.SeedSequence(spec.seed, spawn_key=(1,)))
    if spec.start == "stratified":
        phases = (rng.permutation(spec.N) + 0.5) / spec.N
    elif spec.start == "partial":
        n = spec.N
        m = int(round(PARTIAL_FRACTION * n))
        chosen = rng.permutation(n)
        phases = np.empty(n)
        phases[chosen[:m]] = 0.5 / n
        phases[chosen[m:]] = (rng.permutation(n - m) + 0.5) / (n - m)
    else:
        phases = rng.uniform(0.0, 1.0, spec.N)
    return phases * (spec.friction_threshold / spec.k_e)


def lattice_for(spec: RunSpec) -> Lattice:
    """The lattice of a run, with its seeded drive stiffnesses."""
    lat = square_lattice(spec.Lx, spec.Ly)
    return Lattice(lat.Lx, lat.Ly, lat.positions, lat.bonds, drive_stiffness(spec))
