"""The contacts' load phases over a window: how coherent they are, and whether that coherence
is the start's (docs/model.md, "Contact phase" and "Steady state").

Pure functions on arrays, like ``bkflow.observables.stress``. The plugin records (phase.csv, fix
bk/phase) the complex order parameter Z(t) = (1/N) sum_i exp(2 pi i u_i) of the phases
u_i = k_e |dr_i| / (mu_s sigma_n A) in [0, 1), its second harmonic and the spread of u.

Coherence and its kind. R = |Z| alone cannot tell a layer that remembers its start from one
that has forgotten it: a layer in its steady state keeps a non-uniform phase distribution (its
contacts spend longer in some parts of their load cycle than in others), so R settles at a
level that depends on phi (about 0.28 at phi = 0.1 and 0.1-0.2 at phi = 1000, N = 100). What
tells them apart is whether the phases *move together*. Write Z(t) = Zbar + dZ(t), Zbar its
mean over the window. A steady phase distribution that is the same at every time gives a
constant Zbar; contacts that advance and break independently add a fluctuation dZ of variance
(1 - |Zbar|^2) / N. Contacts that keep a common phase, the memory of the synchronized start,
carry the whole distribution round their load cycle together: Z turns, and dZ is as large as
R itself. The phase fluctuation

    chi = N <|Z - Zbar|^2>

is therefore about 1 (at most 1) for independent contacts and about N R^2 for contacts that
still share the start's phase: 20-40 on the synchronized plateau at N = 100, where R is
0.55-0.65 (the long runs of benchmarks/measure/stiff_states.py keep the synchronized start's
chi). It needs no reference for what
the steady state looks like at the run's phi, and it grows with N where a memory is held.

>>> import numpy as np
>>> t = np.arange(0.0, 1000.0)
>>> turning = 0.6 * np.exp(2j * np.pi * t / 5.3)       # one common phase, turning
>>> coherence(t, turning, 200.0, 100).fluctuation > 30
True
>>> still = np.full(len(t), 0.28 + 0j)                   # a steady, non-uniform distribution
>>> round(coherence(t, still, 200.0, 100).fluctuation, 12)
0.0
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bkflow.observables.stationarity import Stationarity, stationarity


@dataclass(frozen=True)
class Coherence:
    """The contacts' phase statistics over the window [t0, t1] (see module doc).

    ``R``: mean of |Z|; ``R_static``: |mean of Z|, the part of the coherence that stands
    still; ``fluctuation``: chi = N <|Z - Zbar|^2>; ``R2``, ``u_std``: the means of the second
    harmonic's modulus and of the spread of u (1/sqrt(12) = 0.289 for uniform phases);
    ``trend``: the trend test of R over the window (bkflow.observables.stationarity), ``n``:
    samples."""

    t0: float
    t1: float
    R: float
    R_static: float
    fluctuation: float
    R2: float
    u_std: float
    n: int
    trend: Stationarity


def coherence(t, Z, t0: float, n_contacts: int, R2=None, u_std=None,
              n_blocks: int = 10, alpha: float = 0.05, R=None, Z2=None) -> Coherence:
    """The phase statistics of the series Z(t) (complex) over [t0, t[-1]] for a layer of
    ``n_contacts`` contacts; ``R2`` and ``u_std`` (series at the same times) are averaged
    too when given. Fewer than two samples in the window give NaN. For a series of block
    means (``bkflow.observables.reduced``), ``R`` and ``Z2`` are the blocks' means of |Z| and |Z|^2
    (the mean of Z's modulus is not the modulus of its mean)."""
    t = np.asarray(t, dtype=float)
    Z = np.asarray(Z, dtype=complex)
    late = t >= t0
    z = Z[late]
    t1 = float(t[-1]) if len(t) else math.nan
    R = np.abs(Z) if R is None else np.asarray(R, float)
    trend = stationarity(t, R, t0, n_blocks, alpha)

    def mean(x):
        return float(np.mean(np.asarray(x, float)[late])) if x is not None and len(z) \
            else math.nan

    if len(z) < 2:
        nan = math.nan
        return Coherence(float(t0), t1, nan, nan, nan, mean(R2), mean(u_std), len(z), trend)
    zbar = z.mean()
    if Z2 is None:
        chi = float(n_contacts * np.mean(np.abs(z - zbar) ** 2))
    else:   # N (<|Z|^2> - |<Z>|^2), the same variance from the blocks' sums
        chi = float(n_contacts * (np.mean(np.asarray(Z2, float)[late]) - abs(zbar) ** 2))
    return Coherence(float(t0), t1, float(R[late].mean()), float(abs(zbar)), chi, mean(R2),
                     mean(u_std), int(len(z)), trend)
