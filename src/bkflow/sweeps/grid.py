"""The grid of a sweep: phi values, lattice sizes and seeds turned into validated RunSpecs.

>>> phi_values("1e-1:1e3")[:4]
[0.1, 0.215443, 0.464159, 1.0]
>>> len(phi_values("1e-1:1e3"))
13
>>> phi_values("1,10,100")
[1.0, 10.0, 100.0]
"""

from __future__ import annotations

import itertools
import math

from bkflow.lammps.limits import cost
from bkflow.model.checks import SpecError
from bkflow.model.params import RunSpec

#: default sampling of a --phi range
POINTS_PER_DECADE = 3
#: default number of seeds (1 .. K) per (phi, size)
SEEDS = 3
#: default Lx / Ly of --sizes (the paper's lattices have Ly = Lx / 4)
ASPECT = 4


def _sig(x: float) -> float:
    # six significant digits: the same phi reached from two ranges is the same job
    return float(f"{x:.6g}")


#: the most phi values a range expands to (a guard against a typo's endless list)
MAX_PHI_VALUES = 100_000


def phi_values(text: str, points_per_decade: int = POINTS_PER_DECADE) -> list[float]:
    """``"A:B"`` -> log-spaced phi from A to B, ``points_per_decade`` per decade, both ends
    included when B/A is a whole number of steps; ``"a,b,c"`` -> that list. Values are
    rounded to 6 significant digits. Raises ``SpecError`` naming what is wrong."""
    text = str(text).strip()
    if not isinstance(points_per_decade, int) or points_per_decade < 1:
        raise SpecError(f"--points-per-decade must be a whole number >= 1, "
                        f"got {points_per_decade!r}")
    if ":" in text:
        return _phi_range(text, points_per_decade)
    items = text.split(",")
    if not text or any(not s.strip() for s in items):
        raise SpecError(f"--phi {text}: an empty item; give a range A:B or a list a,b,c" if text
                        else "--phi: give a range A:B or a list a,b,c")
    vals = [_phi_number(text, s) for s in items]
    return sorted({_sig(v) for v in vals})


def _phi_number(text: str, s: str) -> float:
    """The phi value ``s`` (an item of the --phi ``text``), or a SpecError naming it."""
    try:
        v = float(s)
    except ValueError:
        raise SpecError(f"--phi {text}: {s!r} is not a number") from None
    if not (math.isfinite(v) and v > 0):
        raise SpecError(f"--phi {text}: phi must be > 0 (phi = k_b / dk_d), got {s}")
    return v


def _phi_range(text: str, points_per_decade: int) -> list[float]:
    """The phi values of the range ``"A:B"`` (``phi_values``)."""
    parts = text.split(":")
    if len(parts) != 2:
        raise SpecError(f"--phi {text}: a range is A:B (e.g. 1e-1:1e3)")
    a, b = _phi_number(text, parts[0]), _phi_number(text, parts[1])
    if not b > a:
        example = (f"--phi {parts[1]}:{parts[0]}" if b < a
                   else f"--phi {parts[0]} for the one value")
        raise SpecError(f"--phi {text}: the range must increase (A < B), e.g. {example}")
    decades = math.log10(b) - math.log10(a)  # b / a may overflow
    n = int(math.floor(decades * points_per_decade + 1e-9))
    if n > MAX_PHI_VALUES:
        raise SpecError(f"--phi {text} with {points_per_decade} points per decade is "
                        f"{n + 1} values (at most {MAX_PHI_VALUES}): lower "
                        "--points-per-decade")
    vals = [10 ** (math.log10(a) + k / points_per_decade) for k in range(n + 1)]
    if b / vals[-1] > 1 + 1e-9:
        vals.append(b)  # the end of the range is always swept
    return sorted({_sig(v) for v in vals})


def sweep_specs(phis, sizes, seeds, axes: dict | None = None, fields=None,
                **common) -> list[RunSpec]:
    """Every (phi, size, other axes, seed) as a validated RunSpec (a SpecError before anything
    runs).

    ``seeds``: a count K (seeds 1..K) or an explicit list; ``axes``: {parameter: [values]},
    further axes of the grid (the CLI's ``--vary``), every combination taken; ``fields``: a
    function of one combination giving the fields common to its runs (where an axis feeds a
    rule, as the protocol's start and companion), else ``common``."""
    if isinstance(seeds, int):
        if seeds < 1:
            raise SpecError(f"--seeds must be >= 1, got {seeds}")
        seeds = range(1, seeds + 1)
    axes = axes or {}
    combos = [dict(zip(axes, values)) for values in itertools.product(*axes.values())]
    # an axis overrides the value the options gave (a preset's t_end, the default start)
    def of(extra):
        return {**(fields(extra) if fields is not None else common), **extra}

    return [RunSpec(phi=phi, Lx=lx, Ly=ly, seed=s, **of(extra))
            for (lx, ly) in sizes for extra in combos for phi in phis for s in seeds]


def run_cost(spec: RunSpec) -> float:
    """Atom-steps of a run, its companion's included: what its wall time scales with."""
    return cost(spec).atom_steps
