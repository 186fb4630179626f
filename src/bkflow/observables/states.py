"""The long-lived states a layer visits, and the error of a mean that covers its switching
between them (docs/model.md, "The stiff end's states"; measured by
benchmarks/measure/stiff_states.py, its records benchmarks/records/stiff_states/).

Pure functions on arrays, like ``bkflow.observables.stress``.

States. A stiff layer (phi >= 215 at N = 100) spends long stretches, 10^4-10^5 time units, in
one of two kinds of state, told apart by the coherence of its contacts' load phases over a
block of ``BLOCK_T`` time units, R = |Z| with Z = <exp(2 pi i u)>:

- **quiet**: R below ``r_independent(N)`` = sqrt(pi / 4N), the level of N independent uniform
  phases: the phases are spread more evenly than chance, contacts break one at a time, and the
  stress is flat at its lowest (0.1027-0.1031 sigma_n at phi = 1000, N = 100);
- **coherent**: R above it: groups of contacts share their phase and break together, and the
  stress rises with R (up to 5% above the quiet level at phi = 1000). Soft layers are always
  here: their contacts keep a static, uneven phase distribution (R about 0.23 at phi = 30,
  at any N).

Error of a mean. A window of length W shorter than the switching's time scale cannot show,
from its own samples, how far its mean is from the layer's long-run mean: a layer that sat in
the quiet state throughout looks precise and is not. The variance of W-window means about the
long-run mean of the same layer, relative, was measured on long runs (10^6-10^7 time units,
benchmarks/measure/stiff_states.py) for the model's default parameters at N = 100 and 400, at
several phi and W: the model's switching calibration (``bkflow.model.calibration``, written
by ``benchmarks/report/stiff_states.py``). ``window_variance`` interpolates it (log phi, log W); the
error of a run's mean is the larger of its own estimate
(``bkflow.observables.stationarity.mean_error``) and the calibrated one. Where the calibration does
not reach (another N, other model parameters), only the run's own estimate is left, and the result
says so.

>>> round(r_independent(100), 4)
0.0886
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bkflow.model.calibration import switching

#: the states (the verdict names those a window visited)
QUIET, COHERENT = "quiet", "coherent"
STATE_NAMES = (QUIET, COHERENT)
#: block length (time units) over which the coherence R is averaged to name the state
BLOCK_T = 1000.0
#: the parameters the calibration holds for: the model's defaults (RunSpec) of these fields
CALIBRATED_FIELDS = ("k_e", "mu_s", "sigma_n", "area", "V_d", "gamma", "mass", "k_d", "dk_d",
                     "contact_rule", "damping")


def r_independent(n: int) -> float:
    """E|Z| of n independent uniform phases, sqrt(pi / 4n) (the Rayleigh mean, n large)."""
    return math.sqrt(math.pi / (4 * n))


@dataclass(frozen=True)
class Blocks:
    """Block averages of a window: edges (t0, t1), the mean coherence R and stress ratio of
    each block, and its state (``QUIET`` or ``COHERENT``)."""

    t0: np.ndarray
    t1: np.ndarray
    R: np.ndarray
    stress: np.ndarray
    state: np.ndarray

    def __len__(self) -> int:
        return len(self.t0)


def blocks(t_phase, R, t_stress, ratio, t_start: float, n_contacts: int,
           block_t: float = BLOCK_T) -> Blocks:
    """The blocks of [t_start, end]: as many whole blocks of about ``block_t`` as fit (at
    least one), each with its mean R (phase samples) and stress ratio (stress samples)."""
    t_phase, R = np.asarray(t_phase, float), np.asarray(R, float)
    t_stress, ratio = np.asarray(t_stress, float), np.asarray(ratio, float)
    t_end = float(t_stress[-1]) if len(t_stress) else t_start
    span = t_end - t_start
    n = max(1, int(round(span / block_t))) if span > 0 else 0
    edges = np.linspace(t_start, t_end, n + 1)

    def means(t, x):
        # samples in time order: block k is the slice [edge k, edge k + 1), the last closed
        cut = np.searchsorted(t, edges, side="left")
        cut[-1] = np.searchsorted(t, t_end, side="right")
        c = np.concatenate([[0.0], np.cumsum(x[cut[0]:cut[-1]])])
        with np.errstate(invalid="ignore", divide="ignore"):
            return (c[cut[1:] - cut[0]] - c[cut[:-1] - cut[0]]) / np.diff(cut)

    r = means(t_phase, R) if n else np.array([])
    s = means(t_stress, ratio) if n else np.array([])
    # a block without a phase sample (the phase series lags the stress's) has no state
    state = np.where(np.isnan(r), "", np.where(r < r_independent(n_contacts), QUIET, COHERENT))
    return Blocks(edges[:-1], edges[1:], r, s, state)


@dataclass(frozen=True)
class Composition:
    """Which states a window visited: the share of its time in each, and each state's mean
    stress ratio and mu_bar (NaN where the state was not visited, or saw no slip)."""

    fraction: dict
    mean_stress: dict
    mu_bar: dict

    @property
    def visited(self) -> tuple:
        return tuple(s for s in STATE_NAMES if self.fraction.get(s, 0.0) > 0)

    @property
    def name(self) -> str:
        """The states visited, joined by '+' (``quiet+coherent``)."""
        return "+".join(self.visited) or "none"

    def row(self) -> dict:
        out = {"states_visited": self.name}
        for s in STATE_NAMES:
            out[f"time_{s}"] = self.fraction.get(s, 0.0)
            out[f"mean_stress_ratio_{s}"] = self.mean_stress.get(s, math.nan)
            out[f"mu_bar_{s}"] = self.mu_bar.get(s, math.nan)
        return out


def composition(b: Blocks, t_fail=None, sigma_fail_ratio=None) -> Composition:
    """The composition of a window's blocks; with the slips' times and sigma_fail / sigma_n,
    each state's mu_bar over the slips whose maximum falls in its blocks."""
    frac, stress, mu = {}, {}, {}
    w = b.t1 - b.t0
    total = w[b.state != ""].sum()   # the blocks whose state is known
    t_fail = None if t_fail is None else np.asarray(t_fail, float)
    for s in STATE_NAMES:
        m = b.state == s
        frac[s] = float(w[m].sum() / total) if total > 0 else 0.0
        stress[s] = float(np.average(b.stress[m], weights=w[m])) if m.any() else math.nan
        mu[s] = math.nan
        if t_fail is not None and m.any() and len(t_fail):
            k = np.clip(np.searchsorted(b.t0, t_fail, side="right") - 1, 0, len(b) - 1)
            inside = m[k] & (t_fail >= b.t0[0]) & (t_fail <= b.t1[-1])
            if inside.any():
                mu[s] = float(np.mean(np.asarray(sigma_fail_ratio, float)[inside]))
    return Composition(frac, stress, mu)


# ------------------------------------------------------------------------- the calibration
def calibrated(spec) -> str | None:
    """Why the calibration does not hold for ``spec`` (a RunSpec), or None when it does."""
    cal = switching()
    if not cal:
        return "no calibration of the switching is installed"
    from bkflow.model.params import RunSpec

    default = RunSpec(phi=1.0)
    other = [f for f in CALIBRATED_FIELDS if getattr(spec, f) != getattr(default, f)]
    if other:
        return f"the switching is calibrated for the model's defaults, not {', '.join(other)}"
    if str(spec.N) not in cal.get("sizes", {}):
        sizes = ", ".join(sorted(cal.get("sizes", {}), key=int))
        return f"the switching is calibrated at N = {sizes}, not N = {spec.N}"
    lattice = _calibrated_lattice(spec.N)
    if lattice is not None and (spec.Lx, spec.Ly) != lattice:
        return (f"the switching is calibrated on the {lattice[0]}x{lattice[1]} lattice at "
                f"N = {spec.N}, not {spec.Lx}x{spec.Ly}")
    return None


def _calibrated_lattice(n: int) -> tuple[int, int] | None:
    """The lattice the calibration's long runs used at N = n (the paper's, Ly = Lx / 4)."""
    from bkflow.model.params import PAPER_SIZES

    return PAPER_SIZES.get(n)


def _interp(x, xs, ys):
    """Linear interpolation of ys(xs) at x, held constant beyond the ends."""
    return float(np.interp(x, xs, ys, left=ys[0], right=ys[-1]))


def window_variance(observable: str, phi: float, n: int, window: float,
                    size: dict | None = None) -> float | None:
    """The calibrated relative variance of a window mean of ``observable`` ("stress" or
    "mu_bar") over ``window`` time units at (phi, N = n) about the layer's long-run mean;
    None where the calibration has no such size. ``size``: a calibration's entry for one size
    ({"phi", "windows", observable: table}) instead of the installed one's. Interpolated in
    log phi and log window (held at the ends in phi; beyond the longest window it falls as
    1 / window, below the shortest it is held); None for an empty window."""
    size = size if size is not None else switching().get("sizes", {}).get(str(n))
    if not size or not window > 0:   # no calibration, or no window (a run shorter than it)
        return None
    windows = np.log(np.asarray(size["windows"], float))
    phis = np.log(np.asarray(size["phi"], float))
    table = np.log(np.asarray(size[observable], float))   # [phi][window]
    lw = math.log(window)
    tail = max(0.0, lw - windows[-1])   # beyond the longest window: 1 / W
    at_w = np.array([_interp(min(lw, windows[-1]), windows, row) for row in table]) - tail
    return math.exp(_interp(math.log(phi), phis, at_w))


#: where the calibration does not hold (another size, other model parameters), the error of a
#: mean still covers slow fluctuations as the nearest calibrated layer has them, wider: the
#: variance of the nearest calibrated size, times N_calibrated / N where the layer is smaller
#: (a smaller layer fluctuates more: the calibrated variance falls as 1/N or faster from N =
#: 100 to 400), times BORROWED_FACTOR where the model's parameters or the lattice's aspect are
#: not the calibrated ones
#: (measured on the held-out long runs of benchmarks/measure/offgrid.py: benchmarks/RESULTS.md,
#: "The verdict off the grid")
BORROWED_FACTOR = 2.0


def borrowed_variance(observable: str, spec, window: float,
                      widen: bool = True) -> float | None:
    """The relative window variance an uncalibrated run's error borrows (see
    BORROWED_FACTOR); None where no calibration is installed or the window is empty.
    ``widen`` False: the nearest calibrated layer's own, unwidened (what the trend test takes
    for the slow fluctuations it must not call a drift)."""
    sizes = switching().get("sizes", {})
    if not sizes or not window > 0:
        return None
    near = min(sizes, key=lambda k: abs(math.log(int(k) / spec.N)))
    v = window_variance(observable, spec.phi, int(near), window, sizes[near])
    if v is None:
        return None
    from bkflow.model.params import RunSpec

    default = RunSpec(phi=1.0)
    if not widen:
        return v
    other = any(getattr(spec, f) != getattr(default, f) for f in CALIBRATED_FIELDS) or (
        _calibrated_lattice(spec.N) not in (None, (spec.Lx, spec.Ly)))
    return v * max(1.0, int(near) / spec.N) * (BORROWED_FACTOR if other else 1.0)


# ------------------------------------------------------------------------- the verdict
#: what a window's verdict may say (docs/model.md "Steady state"): steady (its own statistics
#: give the long-run mean), drifting (the stress trends, and no switching explains it),
#: metastable (the start's memory is shown), or the states it visited where the layer switches
#: between states more slowly than the window averages over them
VERDICTS = ("steady", "drifting", "metastable", QUIET, COHERENT, f"{QUIET}+{COHERENT}")
#: the windows whose verdict names the states they visited
SWITCHING = (QUIET, COHERENT, f"{QUIET}+{COHERENT}")
#: the calibrated error dominates the run's own when it is more than this times larger
DOMINATES = 2.0
#: the phase fluctuation chi above which the contacts hold the start's common phase (the
#: synchronized start's memory) where no calibration gives a threshold of its own
MEMORY_CHI_DEFAULT = 10.0


def memory_chi(n: int) -> float:
    """The phase fluctuation above which a window's contacts still hold the start's common
    phase, at N = n: the calibration's, the largest chi of a window of the long runs from
    every start once their start was forgotten, with a margin (of the nearest calibrated N);
    MEMORY_CHI_DEFAULT without a calibration."""
    sizes = switching().get("sizes", {})
    if not sizes:
        return MEMORY_CHI_DEFAULT
    nearest = min(sizes, key=lambda k: abs(math.log(int(k) / n)))
    return float(sizes[nearest].get("memory_chi", MEMORY_CHI_DEFAULT))


#: a layer has two states where the calibrated share of time in the rarer one is at least this
TWO_STATES = 0.01


def two_states(phi: float, n: int) -> bool | None:
    """Whether the calibration shows the layer at (phi, N = n) in both states (the rarer one
    at least TWO_STATES of the time, interpolated in log phi); None where it has no such N."""
    size = switching().get("sizes", {}).get(str(n))
    if not size or "quiet" not in size:
        return None
    q = _interp(math.log(phi), np.log(size["phi"]), np.asarray(size["quiet"], float))
    return min(q, 1 - q) >= TWO_STATES


#: a window's mean is taken for the long-run mean (steady) only where the layer's slow
#: fluctuations over a window of its length move the mean by less than this, relative (a 95%
#: band of 0.5%: the false-steady tolerance the verdict is calibrated for); beyond it the
#: window names the states it visited even in a layer with one state (N = 400's stiff end
#: wanders in its coherent state)
SLOW_FLUCTUATION = 0.0025


def not_averaged(calibrated_var: float | None, own_err: float, mean: float, phi: float,
                 n: int) -> bool:
    """Whether a window has not averaged over the layer's slow dynamics, so that its numbers
    are those of the states it visited: the calibrated switching error dominates its own
    (``dominates``), and the layer has two states (``two_states``) or its slow fluctuations
    alone exceed SLOW_FLUCTUATION."""
    if not dominates(calibrated_var, own_err, mean):
        return False
    return bool(two_states(phi, n)) or math.sqrt(calibrated_var) > SLOW_FLUCTUATION


def dominates(calibrated_var: float | None, own_err: float, mean: float) -> bool:
    """Whether the calibrated relative variance of a window's mean says more than the window's
    own error does: the window has not averaged over the layer's switching."""
    if calibrated_var is None or not (mean and math.isfinite(mean)):
        return False
    own = own_err / abs(mean) if own_err is not None and math.isfinite(own_err) else 0.0
    return math.sqrt(calibrated_var) > DOMINATES * own


def verdict(stationary: bool, chi: float | None, comp: Composition | None, n: int,
            switching_dominates: bool, pair_disagrees: bool = False) -> str:
    """The verdict of a window (``VERDICTS``), in this order: the start's memory shown
    (``metastable``: the contacts' phase fluctuation above ``memory_chi``, or a companion run
    from another start whose mean differs beyond both errors); the states visited, where
    the window saw both, or where it has not averaged over the layer's slow dynamics
    (``switching_dominates``: ``not_averaged``); ``drifting`` where the stress trends; else
    ``steady``."""
    if (chi is not None and chi > memory_chi(n)) or pair_disagrees:
        return "metastable"
    if comp is not None and (len(comp.visited) == 2 or switching_dominates):
        return comp.name
    return "steady" if stationary else "drifting"


@dataclass(frozen=True)
class Window:
    """One run's analysed window [t0, t1]: its mean stress ratio with the run's own error and
    the calibrated switching variance, the error that covers both (``err``), the stress's
    trend test, the contacts' phase statistics, the states visited, and the verdict."""

    t0: float
    t1: float
    mean: float
    err_run: float              # the run's own error (stationarity.mean_error), or NaN
    err_block: float            # ... from the trend test's block means: what the verdict reads
    var_switching: float | None
    calibration: str | None     # why the switching is not calibrated here (None: it is)
    trend: object               # bkflow.observables.stationarity.Stationarity
    contacts: object | None     # bkflow.observables.phases.Coherence, None without a phase series
    comp: Composition | None
    state: str
    n: int                      # the layer's contacts
    #: where the switching is not calibrated: the variance borrowed from the nearest
    #: calibrated layer, wider (``borrowed_variance``), which the errors cover (not the verdict)
    var_borrowed: float | None = None
    spec: object = None

    @property
    def var_error(self) -> float | None:
        """The relative variance the errors cover: the calibrated, or the borrowed one."""
        return self.var_switching if self.var_switching is not None else self.var_borrowed

    @property
    def err(self) -> float:
        """The error of the mean as an estimate of the layer's long-run mean: the larger of
        the run's own and the calibrated switching's (where not calibrated, the borrowed
        one's)."""
        if self.var_error is None:
            return self.err_run
        cal = math.sqrt(self.var_error) * abs(self.mean)
        return cal if not math.isfinite(self.err_run) else max(self.err_run, cal)

    @property
    def err_verdict(self) -> float:
        """The error the verdict compares with (the block means' own, or the calibrated)."""
        cal = 0.0 if self.var_switching is None else math.sqrt(self.var_switching) * abs(
            self.mean)
        return max(self.err_block, cal) if math.isfinite(self.err_block) else cal

    def err_of(self, observable: str, value: float, own: float, phi: float, n: int) -> float:
        """The error of another window mean (``observable`` "mu_bar") in the same way."""
        if not math.isfinite(value):
            return own
        if self.calibration is None:
            v = window_variance(observable, phi, n, self.t1 - self.t0)
        else:
            v = None if self.spec is None else borrowed_variance(observable, self.spec,
                                                                 self.t1 - self.t0)
        cal = math.sqrt(v) * abs(value) if v is not None else math.nan
        if not math.isfinite(cal):
            return own
        return cal if own is None or not math.isfinite(own) else max(own, cal)


def window(spec, t, sigma, phase: dict | None, t0: float, n_blocks: int = 10,
           alpha: float = 0.05, t_fail=None, sigma_fail=None, own_error: bool = True,
           weights=None) -> Window:
    """The window [t0, end] of one run (a RunSpec ``spec``; its stress series ``t``,
    ``sigma``; its phase series ``phase`` with columns t, R, Z_re, Z_im (and R2, u_std), or
    None), with the slips' times and sigma_fail for each state's mu_bar. The verdict reads
    only the trend test's block means, the contacts and the calibration (the same at every
    check of a run in progress and in its summary); ``own_error`` False leaves out the run's
    own error of the mean (the costly part, which only the summary reports); ``weights``: the
    samples behind each value of a series of block means (bkflow.observables.reduced), for its
    mean."""
    from bkflow.observables.stationarity import mean_error, stationarity

    t, sigma = np.asarray(t, float), np.asarray(sigma, float)
    ratio = sigma / spec.stress_unit
    late = t >= t0
    w = None if weights is None else np.asarray(weights, float)[late]
    mean = float(np.average(ratio[late], weights=w)) if late.any() else math.nan
    err_run = mean_error(ratio[late]).error if own_error else math.nan
    trend = stationarity(t, sigma, t0, n_blocks, alpha)
    why = calibrated(spec)
    t1 = float(t[-1]) if len(t) else t0
    # the drift's error no smaller than the layer's slow fluctuations imply: the calibrated
    # ones, or where nothing is calibrated the nearest calibrated layer's (a slowly wandering
    # layer is not called drifting for want of a calibration)
    trend = trend_within_fluctuations(trend, window_variance(
        "stress", spec.phi, spec.N, (t1 - t0) / 2) if why is None else borrowed_variance(
        "stress", spec, (t1 - t0) / 2, widen=False))
    bm = np.asarray(trend.block_means, float) / spec.stress_unit
    err_block = float(bm.std(ddof=1) / math.sqrt(len(bm))) \
        if len(bm) > 1 and np.isfinite(bm).all() else math.nan
    var = None if why is not None else window_variance("stress", spec.phi, spec.N, t1 - t0)
    borrowed = None if why is None else borrowed_variance("stress", spec, t1 - t0)
    contacts, comp = _contacts(spec, t, ratio, phase, t0, late.any(), n_blocks, alpha,
                               t_fail, sigma_fail)
    chi = None if contacts is None or not math.isfinite(contacts.fluctuation) \
        else contacts.fluctuation
    switching = not_averaged(var, err_block, mean, spec.phi, spec.N)
    state = verdict(bool(trend.stationary), chi, comp, spec.N, switching)
    return Window(float(t0), t1, mean, err_run, err_block, var, why, trend, contacts, comp,
                  state, spec.N, borrowed, spec)


def _contacts(spec, t, ratio, phase, t0: float, any_late: bool, n_blocks: int, alpha: float,
              t_fail, sigma_fail):
    """The contacts' phase statistics over the window and the states its blocks visited
    (None, None without a phase series)."""
    from bkflow.observables.phases import coherence

    if phase is None or not len(phase["t"]):
        return None, None
    contacts = coherence(phase["t"], np.asarray(phase["Z_re"]) + 1j * np.asarray(
        phase["Z_im"]), t0, spec.N, phase.get("R2"), phase.get("u_std"), n_blocks, alpha,
        phase.get("R"), phase.get("Z2"))
    comp = None
    if any_late:
        b = blocks(phase["t"], phase["R"], t, ratio, t0, spec.N)
        fail = None if sigma_fail is None else np.asarray(sigma_fail, float) / spec.stress_unit
        comp = composition(b, t_fail, fail)
    return contacts, comp


def trend_within_fluctuations(trend, half_var: float | None):
    """The trend test with the drift's error no smaller than the layer's calibrated
    fluctuations imply. A layer whose stress wanders on times longer than a block of the test
    (10^3-10^4 time units at phi >= 30) gives block means that scatter more, and more alike,
    than the test's independent-blocks error says, and the test alone calls such a window
    drifting far more often than its 5%. With ``half_var`` the calibrated relative variance of
    the mean of half the window about the long-run mean: the two halves' means differ by half
    the drift (a straight line's), and by chance with a variance of at most 2 half_var (their
    fluctuations alike or independent), so the drift's error is at least 2 sqrt(2 half_var);
    a drift within it is not one. None: the test as it is."""
    import dataclasses

    from bkflow.observables.stationarity import t_sf

    if half_var is None or not math.isfinite(trend.drift):
        return trend
    err = 2.0 * math.sqrt(2.0 * half_var)
    if not err > trend.drift_err:
        return trend
    dof = len(trend.block_t) - 2
    z = trend.drift / err
    p = 2.0 * t_sf(abs(z), dof)
    return dataclasses.replace(trend, drift_err=err, drift_z=z, p_value=p,
                               stationary=bool(p >= trend.alpha))


def needed_length(spec, mu_bar: float, legs: int = 1) -> float | None:
    """The run length at which the calibrated switching error of mu_bar falls to the run's
    target_error (what the layer's physics asks of a run, the cap aside), for the mean of
    ``legs`` runs of the layer side by side (a run and its companion: 2, each window's
    variance over ``legs``); None where the calibration does not hold or gives no
    switching error. It depends on the measured mu_bar only through target_error / mu_bar,
    so that it is the same, to a few percent, for every run of the layer."""
    if calibrated(spec) is not None or spec.target_error is None or not mu_bar > 0:
        return None
    want = legs * (spec.target_error / mu_bar) ** 2
    lo, hi = math.log(10.0), math.log(1e12)
    if (window_variance("mu_bar", spec.phi, spec.N, math.exp(lo)) or 0.0) <= want:
        return None
    if window_variance("mu_bar", spec.phi, spec.N, math.exp(hi)) > want:
        return None   # beyond any run (a target far below the layer's fluctuations)
    for _ in range(60):   # the variance falls with the window: bisect in log W
        mid = 0.5 * (lo + hi)
        if window_variance("mu_bar", spec.phi, spec.N, math.exp(mid)) > want:
            lo = mid
        else:
            hi = mid
    return math.exp(hi) / (1 - spec.transient)
