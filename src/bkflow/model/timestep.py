"""The time step from accuracy (docs/model.md "Integration"): the accuracy presets, the
layer's fastest mode and its contacts' frequency, and the rule that turns them into dt."""

from __future__ import annotations

import math
from typing import NamedTuple

#: Largest accepted C = dt omega_max, omega_max^2 = (4 k_b + k_e + k_d + dk_d) / m the layer's
#: fastest mode: the measured stability bound (benchmarks/measure/stability.py: every phi from
#: 0.1 to 1e4 stable at C = 1.9, phi >= 100 blowing up at C = 2.0, velocity Verlet's
#: omega dt < 2).
#: Any time step, from a preset's rule or from --dt-factor, is refused above it.
DT_FACTOR_MAX = 1.9


class Preset(NamedTuple):
    """An accuracy preset, defined by ``dt_error``: the largest bias its time step may put on
    the steady observables (<sigma_x>/sigma_n and mu_bar, relative), at every phi. Its time
    step follows the rule of ``time_step``, dt = min(c_contact / omega_c, c_stable /
    omega_max), the two constants the largest that meet ``dt_error`` at every phi measured
    (benchmarks/measure/timestep.py, its records benchmarks/records/timestep/). Beside it: the
    length of a fixed run (the paper's protocol), the cap of a run until steady (the steady
    protocol) and the standard error of mu_bar that the steady protocol waits for (absolute; mu_bar
    is 0.10-0.12, so 2e-4 is about 0.2%)."""

    dt_error: float
    c_contact: float
    c_stable: float
    t_end: float
    t_cap: float
    target_error: float


#: accuracy presets (Preset): the time step's error target and the rule's constants from the
#: work-precision of benchmarks/measure/timestep.py, errors and costs in benchmarks/RESULTS.md. The
#: stiff layers take the stability margin's step: fast's, 1.8 of the bound's 1.9, where its 1%
#: target allows it (the measured bias at C = 1.9 is within 0.7% at phi = 215 and 1000, N = 100
#: and 400), default's 1.5 (0.2%), precise's 1.0 (0.1%)
ACCURACY = {"fast": Preset(0.01, 0.2, 1.8, 2000.0, 16000.0, 5e-4),
            "default": Preset(0.002, 0.1, 1.5, 8000.0, 1e5, 2e-4),
            "precise": Preset(0.001, 0.05, 1.0, 16000.0, 1e5, 1e-4)}


def omega_max(k_b: float, k_e: float, k_d: float, dk_d: float, mass: float) -> float:
    """The layer's fastest angular frequency, sqrt((4 k_b + k_e + k_d + dk_d) / m): a particle
    held by its four bonds, its contact and the stiffest drive spring; the stability bound is
    dt omega_max < 2."""
    return math.sqrt((4 * k_b + k_e + k_d + dk_d) / mass)


def omega_contact(k_e: float, k_d: float, dk_d: float, mass: float) -> float:
    """The angular frequency of a contact's load cycle, sqrt((k_e + k_d + dk_d) / m): a particle
    on its contact spring and its stiffest drive spring, the bonds left out. It sets what the
    observables need resolved (docs/model.md "Integration")."""
    return math.sqrt((k_e + k_d + dk_d) / mass)


def time_step(preset: Preset, w_max: float, w_contact: float) -> float:
    """The time step of an accuracy preset: dt = min(c_contact / omega_c, c_stable /
    omega_max). Soft layers (bonds slower than the contacts) take the contacts' step; stiff
    ones the stability bound's, with its margin: their bond modes barely move the contacts,
    so resolving them buys no accuracy (benchmarks/measure/timestep.py, its records
    benchmarks/records/timestep/).

    >>> dt = time_step(ACCURACY["default"], omega_max(0.1, 10, 1, 1, 1), omega_contact(10, 1, 1, 1))
    >>> round(dt * omega_contact(10, 1, 1, 1), 6)
    0.1
    """
    return min(preset.c_contact / w_contact, preset.c_stable / w_max)
