"""Slips and friction from the shear-stress series sigma_x(t) (docs/model.md, "Observables").

Pure functions on numpy arrays: no file I/O (readers live in ``bkflow.store.formats``). Stress is in
the model's units (k_d l / l^2), so mu_s sigma_n = 1 with docs/model.md's defaults.

Slip events
    docs/model.md defines a slip as a drop of sigma_x from a local maximum to the next local minimum
    larger than a threshold. On a sampled, slightly noisy series the extrema are taken at the
    resolution of that threshold (the "zigzag" or hysteresis rule): a maximum is the highest
    sample before the series falls by more than the threshold, and its minimum is the lowest
    sample before the series rises again by more than the threshold. So a wiggle smaller than
    the threshold neither makes an event nor splits one; on a clean sawtooth the events are
    exactly its teeth. ``fix bk/slips`` (plugins/README.md) runs the same rule inside LAMMPS
    on the same samples, so the snapshots it writes line up with ``slip_events``.

>>> t = np.arange(12.0)
>>> s = np.array([0, .5, 1, .2, .4, .8, .9, .1, .3, .31, .6, .7])
>>> ev = slip_events(t, s, threshold=0.05)
>>> ev.sigma_fail.tolist(), ev.drop.round(2).tolist()
([1.0, 0.9], [0.8, 0.8])
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from bkflow.model.params import TRANSIENT
from bkflow.observables.stationarity import mean_error


@dataclass(frozen=True)
class SlipEvents:
    """Slip events of one series; arrays have one entry per event, in time order.

    ``i_max``/``i_min`` index the input samples; ``sigma_fail`` = sigma_x at the maximum;
    ``drop`` = sigma_fail - sigma_x at the minimum (> threshold).
    """

    i_max: np.ndarray
    i_min: np.ndarray
    t_max: np.ndarray
    t_min: np.ndarray
    sigma_fail: np.ndarray
    drop: np.ndarray
    threshold: float

    def __len__(self) -> int:
        return len(self.i_max)

    def after(self, t0: float) -> SlipEvents:
        """The events whose maximum lies at t >= t0 (transient removed)."""
        keep = self.t_max >= t0
        return SlipEvents(self.i_max[keep], self.i_min[keep], self.t_max[keep],
                          self.t_min[keep], self.sigma_fail[keep], self.drop[keep],
                          self.threshold)


class Zigzag:
    """The zigzag rule as a state machine fed with samples in order (see module doc), so a
    running series (an adaptive run) is scanned once: ``feed`` returns the index pairs
    (i_max, i_min) of the drops confirmed by the new samples, indices counted from the
    first sample ever fed. ``zigzag_extrema`` is one call of it on a whole series.
    """

    def __init__(self, threshold: float):
        if not threshold > 0:
            raise ValueError(f"threshold must be > 0, got {threshold!r}")
        self.threshold = float(threshold)
        self.n = 0
        self.falling = False
        self.imax = self.imin = 0
        self.vmax = self.vmin = 0.0

    def feed(self, values) -> tuple[list[int], list[int]]:
        maxima, minima = [], []
        thr = self.threshold
        falling, imax, imin, vmax, vmin = self.falling, self.imax, self.imin, self.vmax, self.vmin
        i = self.n
        for v in values:  # plain floats: this loop is the only serial part, keep it cheap
            if i == 0:
                imax, vmax = 0, v
            elif not falling:
                if v > vmax:
                    imax, vmax = i, v
                elif vmax - v > thr:
                    falling, imin, vmin = True, i, v
            else:
                if v < vmin:
                    imin, vmin = i, v
                elif v - vmin > thr:
                    maxima.append(imax)
                    minima.append(imin)
                    falling, imax, vmax = False, i, v
            i += 1
        self.n, self.falling, self.imax, self.imin, self.vmax, self.vmin = (
            i, falling, imax, imin, vmax, vmin)
        return maxima, minima


def zigzag_extrema(sigma, threshold: float) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i_max, i_min) of every drop larger than ``threshold`` (see module doc).

    A drop that the series has not yet confirmed by rising again by more than ``threshold``
    (at the end of the series) is left out: its minimum is not known. fix bk/slips applies
    the same rule, so both find the same events.
    """
    s = np.asarray(sigma, dtype=float)
    zigzag = Zigzag(threshold)  # refuses a threshold <= 0
    if s.ndim != 1:
        raise ValueError("sigma must be one-dimensional")
    if not np.all(np.isfinite(s)):
        raise ValueError("sigma contains NaN or inf")
    maxima, minima = zigzag.feed(s.tolist())
    return np.array(maxima, dtype=int), np.array(minima, dtype=int)


def slip_events(t, sigma, threshold: float) -> SlipEvents:
    """Slip events of the series ``sigma`` sampled at times ``t`` (stress units)."""
    t = np.asarray(t, dtype=float)
    s = np.asarray(sigma, dtype=float)
    if t.shape != s.shape:
        raise ValueError(f"t and sigma differ in shape: {t.shape} vs {s.shape}")
    i_max, i_min = zigzag_extrema(s, threshold)
    return SlipEvents(i_max, i_min, t[i_max], t[i_min], s[i_max], s[i_max] - s[i_min],
                      float(threshold))


@dataclass(frozen=True)
class MacroscopicFriction:
    """Macroscopic friction of one run (docs/model.md, "Macroscopic friction").

    ``mu_bar`` = <sigma_fail> / sigma_n over the slips after the transient (sigma_n A, the
    contact's normal load, where the contact area A is not the paper's l^2), ``mu_bar_err`` its
    standard error over successive (correlated) slips
    (``bkflow.observables.stationarity.mean_error``, ``g`` the statistical inefficiency);
    ``mean_stress_ratio`` = time average of sigma_x / sigma_n after the transient (no
    threshold involved). ``events``: every slip of the series, transient included.
    """

    mu_bar: float
    mu_bar_err: float
    n_slips: int
    mean_stress_ratio: float
    threshold: float
    t_transient: float
    g: float
    error_reliable: bool
    events: SlipEvents


def physical_bound(mu_s: float, drag: float) -> float:
    """The most a steady stress ratio can be: each contact holds at most mu_s sigma_n A, and
    on average the damping adds the drag m gamma V_d of a layer moving with the plate (``drag``
    in units of sigma_n A); a mean above it is a fault of the model's set-up or its analysis,
    not a result."""
    return mu_s + drag


#: the slack over ``physical_bound`` a ratio of the run's own numbers may show: an instant's
#: inertia (a slip's maximum), the sums' rounding
BOUND_SLACK = 0.05


def bound_problem(name: str, value: float, mu_s: float, drag: float) -> str | None:
    """Why ``value`` (a stress ratio) breaks ``physical_bound`` (with ``BOUND_SLACK``), or
    None."""
    bound = physical_bound(mu_s, drag)
    if math.isfinite(value) and value > bound * (1 + BOUND_SLACK):
        return (f"{name} = {value:.4g} is above mu_s = {mu_s:g} (plus the damping's drag, "
                f"{drag:.2g}), which no contact of this model can hold")
    return None


def macroscopic_friction(t, sigma, sigma_n: float, threshold: float,
                         transient_fraction: float = TRANSIENT,
                         t_transient: float | None = None,
                         events: SlipEvents | None = None, weights=None) -> MacroscopicFriction:
    """mu_bar with its error and the time-averaged stress ratio of one series.

    ``threshold`` in stress units (docs/model.md's 1% of mu_s sigma_n is 0.01); the transient is the
    first ``transient_fraction`` of the series' time span, or everything before
    ``t_transient`` when that is given. ``events``: the slips at ``threshold`` when the
    series is not the raw one (block means: ``bkflow.observables.reduced``), found from its records,
    and ``weights`` the samples behind each block mean (the time average is the samples').
    """
    t = np.asarray(t, dtype=float)
    s = np.asarray(sigma, dtype=float)
    if not 0 <= transient_fraction < 1:
        raise ValueError(f"transient_fraction must lie in [0, 1), got {transient_fraction!r}")
    if len(t) < (1 if events is not None else 2):   # block means: one block is a mean
        raise ValueError("the stress series has fewer than two samples")
    t0 = t[0] + transient_fraction * (t[-1] - t[0]) if t_transient is None else t_transient
    if events is None:
        events = slip_events(t, s, threshold)
    ev = events.after(t0)
    est = mean_error(ev.sigma_fail / sigma_n)
    late = t >= t0
    return MacroscopicFriction(mu_bar=est.mean, mu_bar_err=est.error, n_slips=len(ev),
                               mean_stress_ratio=float(np.average(
                                   s[late] / sigma_n, weights=None if weights is None
                                   else np.asarray(weights, float)[late]))
                               if late.any() else math.nan,
                               threshold=float(threshold), t_transient=float(t0),
                               g=est.g, error_reliable=est.reliable,
                               events=events)


@dataclass(frozen=True)
class PowerLawFit:
    """Continuous power law p(x) ~ x^-alpha for x >= x_min, fitted by maximum likelihood.

    ``alpha_err`` = (alpha - 1) / sqrt(n_tail), the asymptotic standard error; ``ks`` the
    Kolmogorov-Smirnov distance between the tail and the fit.
    """

    alpha: float
    alpha_err: float
    x_min: float
    n_tail: int
    ks: float


def _fit_tail(x_sorted_tail: np.ndarray, x_min: float) -> tuple[float, float]:
    n = len(x_sorted_tail)
    alpha = 1.0 + n / float(np.sum(np.log(x_sorted_tail / x_min)))
    emp = np.arange(n) / n
    model = 1.0 - (x_sorted_tail / x_min) ** (1.0 - alpha)
    ks = float(np.max(np.abs(emp - model)))
    return alpha, ks


def _scan_tails(x: np.ndarray, candidates: np.ndarray, cells: int = 1 << 20,
                loop_from: int = 4096):
    """``_fit_tail`` of the tail of sorted ``x`` above each of ``candidates`` (values of x), as
    arrays of alpha and KS distance. Up to ``loop_from`` samples, the candidates in chunks of
    about ``cells`` array cells, each a row over the chunk's columns with the part below its
    cut masked out (a call per candidate costs more than its tail there); above, one call
    of ``_fit_tail`` per candidate (its arrays are long enough to pay for the call)."""
    m = len(x)
    first = np.searchsorted(x, candidates)
    if m > loop_from:
        fits = [_fit_tail(x[j:], xm) for j, xm in zip(first.tolist(), candidates.tolist())]
        return np.array([f[0] for f in fits]), np.array([f[1] for f in fits])
    alphas, kss = [], []
    c = 0
    while c < len(candidates):
        j0 = int(first[c])   # the chunk's columns start at its first cut
        step = max(1, cells // (m - j0))
        xm, j = candidates[c:c + step, None], first[c:c + step, None]
        n = m - j
        col = np.arange(j0, m)
        inside = col >= j
        r = x[j0:] / xm
        alpha = 1.0 + n[:, 0] / np.log(np.where(inside, r, 1.0)).sum(axis=1)
        model = 1.0 - r ** (1.0 - alpha[:, None])
        kss.append(np.where(inside, np.abs((col - j) / n - model), 0.0).max(axis=1))
        alphas.append(alpha)
        c += step
    return np.concatenate(alphas), np.concatenate(kss)


def power_law_fit(x, x_min: float | None = None, min_tail: int = 10) -> PowerLawFit:
    """Maximum-likelihood exponent of a continuous power law (Clauset, Shalizi and Newman,
    SIAM Rev. 51, 661 (2009), Eq. 3.1): alpha = 1 + n / sum ln(x_i / x_min).

    ``x_min`` given: the lower cut. ``x_min=None``: chosen among the sample values as the one
    that minimises the KS distance between the tail and its fit (their Sec. 3.3), keeping at
    least ``min_tail`` samples. Fewer than ``min_tail`` samples above the cut give NaN.
    """
    x = np.sort(np.asarray(x, dtype=float))
    x = x[np.isfinite(x) & (x > 0)]
    nan = PowerLawFit(math.nan, math.nan, math.nan if x_min is None else float(x_min), 0, math.nan)
    if x_min is not None:
        tail = x[x >= x_min]
        if len(tail) < min_tail or np.all(tail == x_min):
            return PowerLawFit(math.nan, math.nan, float(x_min), len(tail), math.nan)
        alpha, ks = _fit_tail(tail, x_min)
        return PowerLawFit(alpha, (alpha - 1) / math.sqrt(len(tail)), float(x_min), len(tail), ks)
    if len(x) < min_tail:
        return nan
    candidates = np.unique(x[: len(x) - min_tail + 1])
    candidates = candidates[candidates < x[-1]]   # a tail of one value has no fit
    if len(candidates) == 0:
        return nan
    alpha, ks = _scan_tails(x, candidates)
    k = int(np.argmin(ks))   # the first of equal distances, as a scan in order keeps
    alpha, ks, xm = float(alpha[k]), float(ks[k]), float(candidates[k])
    n = len(x) - int(np.searchsorted(x, xm))
    return PowerLawFit(alpha, (alpha - 1) / math.sqrt(n), float(xm), n, ks)


#: Clauset et al.'s rule: a power law is ruled out when fewer than this share of synthetic
#: power-law samples fit worse than the data
P_REJECT = 0.1
#: synthetic samples of the goodness-of-fit test: p is known to about +-0.01 near P_REJECT
N_BOOT = 1000


@dataclass(frozen=True)
class PowerLawTest:
    """Is a power law a plausible description of the tail? (Clauset, Shalizi and Newman 2009,
    Sec. 4 and 5.)

    ``p``: the goodness of fit, the share of ``n_boot`` synthetic samples drawn from the fitted
    law (same size, alpha and x_min) whose KS distance to their own refit is at least the data's.
    ``p < P_REJECT`` rules the power law out (``verdict`` "rejected"); otherwise it is
    "plausible", and "no fit" when there was no fit. ``lognormal_R`` and ``lognormal_p``: the
    normalised log-likelihood ratio of the power law against a lognormal over the same tail and
    its significance (Vuong's test, computed by the ``powerlaw`` package): R < 0 favours the
    lognormal; ``preferred`` names the favoured law when p < P_REJECT.
    """

    fit: PowerLawFit
    p: float
    n_boot: int
    lognormal_R: float
    lognormal_p: float

    @property
    def verdict(self) -> str:
        if not math.isfinite(self.fit.alpha):
            return "no fit"
        return "rejected" if self.p < P_REJECT else "plausible"

    @property
    def preferred(self) -> str:
        if not (math.isfinite(self.lognormal_R) and self.lognormal_p < P_REJECT):
            return "undecided"
        return "power law" if self.lognormal_R > 0 else "lognormal"

    def describe(self) -> str:
        """One phrase for a legend or a report: "alpha = 1.90 +- 0.04 (p = 0.43)", or "power
        law rejected (p < 0.001, lognormal favoured)"."""
        f = self.fit
        if self.verdict == "no fit":
            return "no fit"
        p = f"p < {1 / self.n_boot:.2g}" if self.p == 0 else f"p = {self.p:.3g}"
        better = ", lognormal favoured" if self.preferred == "lognormal" else ""
        if self.verdict == "rejected":
            return f"power law rejected ({p}{better})"
        # plausible by the bootstrap; the likelihood ratio may still prefer a lognormal
        return rf"alpha = {f.alpha:.2f} +- {f.alpha_err:.2f} ({p}{better})"


def power_law_p(fit: PowerLawFit, n_boot: int = N_BOOT, seed: int = 0) -> float:
    """Clauset et al.'s goodness-of-fit p-value of a power-law fit (their Sec. 4.1): the share
    of synthetic samples of the fitted law whose KS distance to their own maximum-likelihood fit
    is at least the fit's own ``ks``.

    The synthetic tails have the fit's size, alpha and x_min; x_min is held at the fit's (the
    slip threshold is a physical cut, not a fitted one; for an x_min chosen by the KS rule this
    makes p lenient, so a rejection stands and a "plausible" is weaker). Deterministic for a
    given ``seed``. NaN for a fit that failed.
    """
    n, alpha = fit.n_tail, fit.alpha
    if not (math.isfinite(alpha) and n > 0 and n_boot > 0):
        return math.nan
    rng = np.random.default_rng(seed)
    emp = np.arange(n) / n
    worse = 0
    rows = max(1, min(n_boot, 2_000_000 // n))  # about 16 MB per block
    for start in range(0, n_boot, rows):
        b = min(rows, n_boot - start)
        # inverse transform of the continuous power law above x_min
        # ln(x / x_min) = -ln(v) / (alpha - 1), v uniform on (0, 1]: sorted by sorting -ln v
        lr = np.sort(-np.log(1.0 - rng.random((b, n))), axis=1) / (alpha - 1.0)
        a = 1.0 + n / lr.sum(axis=1)
        ks = np.max(np.abs(emp - (1.0 - np.exp((1.0 - a[:, None]) * lr))), axis=1)
        worse += int(np.count_nonzero(ks >= fit.ks))
    return worse / n_boot


def import_powerlaw():
    """The ``powerlaw`` package, imported when first needed, without matplotlib.pyplot, which
    it imports at its top for its plots (a third of a second; bkflow's analysis never plots
    through it): while it is imported, ``matplotlib.pyplot`` is a stand-in that imports the
    real pyplot at its first use, and is gone from ``sys.modules`` afterwards, so that any
    later ``import matplotlib.pyplot`` (bkflow's figures, a user's) is the real one."""
    import sys

    if "powerlaw" in sys.modules or "matplotlib.pyplot" in sys.modules:
        import powerlaw

        return powerlaw
    import types

    class _Pyplot(types.ModuleType):
        def __getattr__(self, name):
            import importlib

            return getattr(importlib.import_module("matplotlib.pyplot"), name)

    stand_in = _Pyplot("matplotlib.pyplot")
    sys.modules["matplotlib.pyplot"] = stand_in
    try:
        import powerlaw
    finally:
        if sys.modules.get("matplotlib.pyplot") is stand_in:
            del sys.modules["matplotlib.pyplot"]
        parent = sys.modules.get("matplotlib")
        if parent is not None and getattr(parent, "__dict__", {}).get("pyplot") is stand_in:
            del parent.pyplot
    return powerlaw


def lognormal_comparison(x, x_min: float) -> tuple[float, float]:
    """Normalised log-likelihood ratio of a power law against a lognormal over x >= x_min, and
    its p-value (Clauset et al. Sec. 5; Vuong's test), from the ``powerlaw`` package (Alstott,
    Bullmore and Plenz, PLoS ONE 9, e85777 (2014)). R > 0 favours the power law. NaN pair when
    fewer than two distinct values lie in the tail."""
    x = np.asarray(x, dtype=float)
    tail = x[np.isfinite(x) & (x >= x_min)]
    if len(np.unique(tail)) < 2:
        return math.nan, math.nan
    powerlaw = import_powerlaw()
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        f = powerlaw.Fit(tail, xmin=x_min, verbose=False)
        R, p = f.distribution_compare("power_law", "lognormal", normalized_ratio=True)
    return float(R), float(p)


def power_law_test(x, x_min: float | None = None, min_tail: int = 10,
                   n_boot: int = N_BOOT) -> PowerLawTest:
    """``power_law_fit``, its goodness of fit (``power_law_p``) and the comparison with a
    lognormal (``lognormal_comparison``) in one ``PowerLawTest``."""
    fit = power_law_fit(x, x_min=x_min, min_tail=min_tail)
    if not math.isfinite(fit.alpha):
        return PowerLawTest(fit, math.nan, n_boot, math.nan, math.nan)
    R, p = lognormal_comparison(x, fit.x_min)
    return PowerLawTest(fit, power_law_p(fit, n_boot), n_boot, R, p)


def drop_distribution(drops, bins: int = 20) -> tuple[np.ndarray, np.ndarray]:
    """Probability density of stress-drop sizes in logarithmic bins: (bin centres, density).

    Centres are geometric means of the bin edges; empty bins have density 0.
    """
    d = np.asarray(drops, dtype=float)
    d = d[np.isfinite(d) & (d > 0)]
    if len(d) == 0:
        return np.empty(0), np.empty(0)
    lo, hi = d.min(), d.max()
    if hi <= lo:
        hi = lo * 1.0001
    edges = np.geomspace(lo, hi, bins + 1)
    counts, _ = np.histogram(d, edges)
    density = counts / (len(d) * np.diff(edges))
    return np.sqrt(edges[:-1] * edges[1:]), density
