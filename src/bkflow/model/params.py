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

from bkflow.model import validity
from bkflow.model.checks import (
    SpecError,
    boolean,
    check_fields,
    checked,
    choice,
    fraction,
    integer,
    number,
)
from bkflow.model.scenes import DEFAULT_SCENE, FRONTS_IN_FULL, SCENES, records
from bkflow.model.timestep import (
    ACCURACY,
    omega_contact,
    omega_max,
    time_step,
)
from bkflow.model.validity import BLOCK_EVERY, RECORDED

#: The paper's lattice sizes by particle number (Ly = Lx / 4).
PAPER_SIZES = {100: (20, 5), 400: (40, 10), 900: (60, 15)}

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
#: The paths differ in the order of floating-point sums only (tests/plugins/test_fused.py).
PATHS = ("auto", "general", "fused")

#: implicit: the damping force -m gamma v uses the end-of-step velocity, solved for (second
#: order); half: the half-step velocity (docs/model.md's literal scheme, first order in dt)
DAMPING_MODES = ("implicit", "half")

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
#: that forgets fastest (STEADY_START, measured: benchmarks/measure/stiff_states.py's runs from four
#: starts, its records benchmarks/records/stiff_states/), run
#: until the run is steady (RunSpec.until_steady), the preset's t_cap its cap. paper: the
#: paper's synchronized start, a fixed t_end (the preset's)
PROTOCOLS = ("steady", "paper")
#: the start of the steady protocol: the one that forgets fastest
STEADY_START = "random"
#: the start of the steady protocol's companion run: from the other side of the steady state
#: (the stratified and random starts approach a stiff layer's plateau from below, the partial
#: one from above: benchmarks/measure/stiff_states.py's runs, benchmarks/records/stiff_states/)
STEADY_COMPANION = "partial"
#: a run and its companion agree when their mean stresses over the analysed window differ by
#: at most this (relative): then neither remembers its start (the verdict's false-steady rate on
#: the long runs of benchmarks/measure/stiff_states.py, benchmarks/report/stiff_states.py's
#: verdicts)
STEADY_AGREEMENT = 0.005

#: a run until steady (RunSpec.until_steady) must be able to exclude a drift of the stress
#: larger than this across its analysed window (|drift| + 2 standard errors, relative)
STEADY_DRIFT_BOUND = 0.01
#: a run until steady is first checked at this length (time units), and then every
#: ADAPTIVE_CHUNK_T
STEADY_T_MIN = ADAPTIVE_T_MIN


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


#: why a lattice needs 3 cells along each axis (RunSpec.Lx, Ly)
_TWO_CELLS = (": with 2 cells along an axis the bonds to the neighbours on either side join the "
              "same pair of particles at exactly half the box, where the bond's periodic image "
              "is undefined")


def size_from_n(n: int) -> tuple[int, int]:
    """The paper's lattice for N = 100, 400 or 900 particles."""
    if n not in PAPER_SIZES:
        # the factor pairs of n (up to its square root, both ways round), sides of 3 or more
        pairs = [(a, n // a) for a in range(3, math.isqrt(n) + 1) if n % a == 0 and n // a >= 3]
        shapes = sorted({s for a, b in pairs for s in ((a, b), (b, a))},
                        key=lambda s: abs(s[0] / s[1] - 4))
        example = f"--size {shapes[0][0]}x{shapes[0][1]}" if shapes else "--size 20x5"
        raise SpecError(f"--n {n}: the paper's sizes are N = {', '.join(map(str, PAPER_SIZES))}; "
                        f"for any other lattice give --size LXxLY (e.g. {example})")
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
    #: velocity of the damping force (DAMPING_MODES; benchmarks/measure/convergence.py)
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
    #: mu_s sigma_n A / (k_e V_d) = 5 time units, which this resolves; at most MAX_PHASE_EVERY
    #: (a tenth of a block), so that the verdict and the mean do not depend on it
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
        validity.check(self)  # and what joins them (bkflow.model.validity)

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
        """The slip threshold in stress units: slip_threshold * mu_s * sigma_n A."""
        return self.slip_threshold * self.mu_s * self.stress_unit

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
        return records(self.scene, "series")

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
        return min((self.slip_threshold, scaled) + REPORT_THRESHOLDS) * self.mu_s * \
            self.stress_unit

    @property
    def writes_snapshots(self) -> bool:
        """Whether the run records Psi(t) (fix bk/psi, in the run: scenes order, figures,
        full)."""
        return records(self.scene, "snapshots")

    @property
    def writes_frames(self) -> bool:
        """Whether the run also writes whole position frames every snapshot_every (scene
        full: snapshots.lammpstrj, for OVITO and the like)."""
        return records(self.scene, "frames")

    @property
    def writes_slips(self) -> bool:
        """Whether the run follows its slips with fix bk/slips (their clusters)."""
        return records(self.scene, "slips")

    @property
    def writes_slip_frames(self) -> bool:
        """Whether the run writes the positions at each slip's maximum and minimum
        (slips.lammpstrj: scenes clusters, events, full), from which the analysis finds the
        clusters at any s_x; the figures scene keeps each slip's clusters computed in the run
        instead (at S_X)."""
        return records(self.scene, "slip_frames")

    @property
    def writes_energy(self) -> bool:
        """Whether the run keeps the energy ledger and writes the event catalogue (scenes
        events, full)."""
        return records(self.scene, "energy")

    @property
    def writes_fronts(self) -> bool:
        return records(self.scene, "fronts")

    @property
    def fronts_limit(self) -> int | None:
        """How many slips' fronts the run records (None: all)."""
        return FRONTS_IN_FULL if self.scene == "full" else None

    @property
    def stress_unit(self) -> float:
        """sigma_n A, the normal load on one particle's contact: the unit of every stress ratio
        (mu_bar, <sigma_x>/sigma_n, the slip thresholds' fractions of mu_s sigma_n). sigma_x
        is the drive's force per particle (per cell l^2), so that its ratio to sigma_n A is a
        friction coefficient, at most mu_s in steady sliding; the paper's A = l^2 makes it
        sigma_n."""
        return self.sigma_n * self.area

    @property
    def friction_threshold(self) -> float:
        """mu_s sigma_n A, the largest contact force before the contact breaks."""
        return self.mu_s * self.sigma_n * self.area

    @property
    def label(self) -> str:
        """How messages name the run: phi, lattice and seed."""
        return f"phi={self.phi:g}, {self.Lx}x{self.Ly}, seed {self.seed}"

    def replace(self, **changes) -> RunSpec:
        """This spec with ``changes``; a recorded run's sampling (made before its bound) stays
        readable in its companion and continuation when the changes leave it as it was."""
        keeps = not ({"phase_every", "stress_every"} & set(changes))
        token = RECORDED.set(True) if keeps else None
        try:
            return dataclasses.replace(self, **changes)
        finally:
            if token is not None:
                RECORDED.reset(token)

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
        token = RECORDED.set(True)   # a record's run is read as it was made
        try:
            return cls(**d)
        finally:
            RECORDED.reset(token)
