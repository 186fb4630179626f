"""Is a stress series stationary? Block means, a trend test, the transient, and the error of
a correlated mean (docs/model.md, "Steady state").

Pure functions on arrays, like ``bkflow.observables.stress``.

Trend test. The analysed window [t0, t_end] is cut into ``n_blocks`` equal blocks in time;
their means (batch means: Fishman, *Principles of Discrete Event Simulation*, Wiley 1978;
Flyvbjerg and Petersen, J. Chem. Phys. 91, 461 (1989)) are nearly independent once a block is
much longer than the stress's correlation time (here hundreds of time units against slip
periods of tens). A straight line fitted to them by least squares (``linear_fit``, as
``scipy.stats.linregress``)
gives the change of the stress across the window, ``drift`` (relative to the mean, signed),
its standard error from the scatter of the block means about the line, and ``drift_z`` their
ratio. The window is ``stationary`` when the two-sided t-test of the slope (n_blocks - 2
degrees of freedom) does not reject "no trend" at level ``alpha`` (5%): |drift_z| < 2.31 with
10 blocks. A run that is too short for its noise passes such a test for lack of power, so
``stationarity`` also reports how large a drift it could have missed
(``drift_bound``: |drift| + 2 standard errors), which the run-until-stationary rule bounds.

Transient. Beside the fixed fraction, the start of the stationary part can be detected by
the method of Chodera, J. Chem. Theory Comput. 12, 1799 (2016) (``pymbar.timeseries.
detect_equilibration``): the start t that maximises the number of effectively independent
samples after it.

Error of a mean. ``mean_error`` uses the statistical inefficiency g of Chodera et al.,
J. Chem. Theory Comput. 3, 26 (2007) (``pymbar.timeseries.statistical_inefficiency``, summed
while the autocorrelation stays positive), with the sample variance corrected for the
correlation: error^2 = s^2 g / (n - g) with s^2 the biased sample variance, since
E[s^2] = sigma^2 (1 - g/n). When the lag-one autocorrelation lies inside the 95% band of white
noise (|r_1| < 2 / sqrt(n), Bartlett) g = 1: summing noise-only positive lags would overstate
the error of independent data by 5-8% at n = 64-400. On AR(1) series of n = 400 the mean
estimate is within 3% of the true standard error for rho = 0, 0.2, 0.5 and 0.8
(tests/observables/test_stationarity.py); blocking estimates are 10-30% low there.

>>> import numpy as np
>>> t = np.arange(0, 1000, 0.5)
>>> flat = 1 + 0.01 * np.sin(t)
>>> stationarity(t, flat, t0=200).stationary
True
>>> stationarity(t, flat + 1e-4 * t, t0=200).stationary
False
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: blocks of the trend test
N_BLOCKS = 10
#: level of the trend test (two-sided)
ALPHA = 0.05


def statistical_inefficiency(x, mintime: int = 3, fast: bool = False) -> float:
    """The statistical inefficiency g of a series (Chodera et al., J. Chem. Theory Comput. 3,
    26 (2007)): g = 1 + 2 sum_t (1 - t/n) C(t) w_t, C the normalised autocorrelation, over
    t = 1, 2, 3, ... (``fast``: t = 1, 2, 4, 7, ..., each lag weighted by the stride w_t to
    the next) until C(t) <= 0 with t > ``mintime``; at least 1. This is what
    ``pymbar.timeseries.statistical_inefficiency`` computes (tests/observables/test_stationarity.py
    compares them on many series); bkflow keeps its own because importing pymbar costs 0.7 s
    (it imports scipy.stats, and looks for JAX), more than the analysis of a short run. The
    autocovariance of every lag comes from one FFT. Raises ValueError for a constant
    series."""
    x = np.asarray(x, dtype=float)
    n = len(x)
    d = x - x.mean()
    var = float((d * d).mean())
    if var == 0.0:
        raise ValueError("a constant series has no statistical inefficiency")
    if n < 3:
        return 1.0
    # zero-padded to a power of two at least 2n (no wrap-around for any lag below n): a
    # length of 2n with a large prime factor makes the FFT ten times slower
    size = 1 << (2 * n - 1).bit_length()
    f = np.fft.rfft(d, size)
    acov = np.fft.irfft(f * np.conj(f), size)[:n]   # sum_i d_i d_(i+t), every lag t
    if fast:
        k = np.arange(1, int(math.sqrt(2 * n)) + 3)
        lags = 1 + k * (k - 1) // 2                      # 1, 2, 4, 7, 11, ...
        strides = k
    else:
        lags = np.arange(1, n)
        strides = np.ones(len(lags), dtype=np.int64)
    keep = lags < n - 1
    lags, strides = lags[keep], strides[keep]
    c = acov[lags] / ((n - lags) * var)
    stop = np.flatnonzero((c <= 0.0) & (lags > mintime))
    end = stop[0] if len(stop) else len(lags)
    g = 1.0 + float(np.sum(2.0 * c[:end] * (1.0 - lags[:end] / n) * strides[:end]))
    return max(g, 1.0)


def detect_equilibration(x, fast: bool = True, nskip: int = 1) -> tuple[int, float, float]:
    """Chodera's equilibration detection (J. Chem. Theory Comput. 12, 1799 (2016)): the start t
    (every ``nskip``-th sample) that maximises the effectively independent samples after it,
    (n - t + 1) / g(t); returns (t, g, n_effective), as ``pymbar.timeseries.
    detect_equilibration`` does (its single-precision arrays too, which decide its ties)."""
    x = np.asarray(x, dtype=float)
    n = len(x)
    if x.std() == 0.0:
        return 0, 1.0, 1.0
    g_t = np.ones(n - 1, np.float32)
    neff = np.ones(n - 1, np.float32)
    for t in range(0, n - 1, nskip):
        try:
            g_t[t] = statistical_inefficiency(x[t:], fast=fast)
        except ValueError:   # a constant tail
            g_t[t] = n - t + 1
        neff[t] = (n - t + 1) / g_t[t]
    t = int(neff.argmax())
    return t, float(g_t[t]), float(neff.max())


@dataclass(frozen=True)
class MeanEstimate:
    """Mean of a correlated series with its standard error.

    ``g``: statistical inefficiency (1 for independent samples); ``n_effective`` = n / g;
    ``reliable``: at least ``MIN_EFFECTIVE`` effectively independent samples."""

    mean: float
    error: float
    n: int
    g: float
    n_effective: float
    reliable: bool


#: fewest effectively independent samples for an error to be called reliable
MIN_EFFECTIVE = 10


def mean_error(x) -> MeanEstimate:
    """Mean and standard error of a correlated series (see module doc)."""
    x = np.asarray(x, dtype=float)
    n = len(x)
    if n == 0:
        return MeanEstimate(math.nan, math.nan, 0, math.nan, 0.0, False)
    mean = float(x.mean())
    if n < 3:
        return MeanEstimate(mean, math.nan, n, math.nan, float(n), False)
    var0 = float(x.var())
    if var0 == 0.0:
        return MeanEstimate(mean, 0.0, n, 1.0, float(n), n >= MIN_EFFECTIVE)
    d = x - mean
    r1 = float(np.dot(d[:-1], d[1:]) / (n * var0))
    g = 1.0 if abs(r1) < 2 / math.sqrt(n) else statistical_inefficiency(x, mintime=1)
    err = math.sqrt(var0 * g / (n - g)) if n > g else math.nan
    return MeanEstimate(mean, err, n, g, n / g, n / g >= MIN_EFFECTIVE)


@dataclass(frozen=True)
class Stationarity:
    """The trend test of a series over its analysed window (see module doc)."""

    t0: float
    t1: float
    block_t: np.ndarray      # block centres
    block_means: np.ndarray
    drift: float             # relative change across the window (fitted line), signed
    drift_err: float
    drift_z: float
    p_value: float
    stationary: bool
    alpha: float

    @property
    def drift_bound(self) -> float:
        """The largest |drift| the test could have missed at about 2 standard errors."""
        return abs(self.drift) + 2 * self.drift_err


def block_means(t, x, t0: float, n_blocks: int = N_BLOCKS) -> tuple[np.ndarray, np.ndarray]:
    """Means of ``x`` over ``n_blocks`` equal time blocks of [t0, t[-1]]: (centres, means)."""
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    edges = np.linspace(t0, t[-1], n_blocks + 1)
    # a sample at t belongs to the block whose [edge, next edge) holds it, the last block
    # closed: the samples are in time order, so each block is one slice
    cut = np.searchsorted(t, edges, side="left")
    cut[-1] = len(t)
    counts = np.diff(cut)
    c = np.concatenate([[0.0], np.cumsum(x[cut[0]:])])
    sums = c[cut[1:] - cut[0]] - c[cut[:-1] - cut[0]]
    with np.errstate(invalid="ignore"):
        return 0.5 * (edges[:-1] + edges[1:]), sums / counts


def t_sf(t: float, dof: int) -> float:
    """P(T > t) for Student's t with ``dof`` degrees of freedom: I_x(dof/2, 1/2) / 2 with
    x = dof / (dof + t^2) for t >= 0, the regularized incomplete beta function by its continued
    fraction (Numerical Recipes' betacf, modified Lentz). scipy.stats.t.sf gives the same to
    1e-12 (tests/observables/test_stationarity.py); bkflow keeps its own because importing
    scipy.stats costs 0.8 s, more than the analysis of a short run."""
    if math.isnan(t):
        return math.nan
    if math.isinf(t):
        return 0.0 if t > 0 else 1.0
    a, b = 0.5 * dof, 0.5
    x = dof / (dof + t * t)
    if x <= 0.0:
        tail = 0.0
    elif x >= 1.0:
        tail = 1.0
    else:
        ln_front = (math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b)
                    + a * math.log(x) + b * math.log1p(-x))
        if x < (a + 1) / (a + b + 2):
            tail = math.exp(ln_front) * _betacf(a, b, x) / a
        else:
            tail = 1.0 - math.exp(ln_front) * _betacf(b, a, 1.0 - x) / b
    return 0.5 * tail if t >= 0 else 1.0 - 0.5 * tail


def _betacf(a: float, b: float, x: float) -> float:
    """The continued fraction of the incomplete beta function (modified Lentz)."""
    tiny, eps = 1e-300, 1e-16
    qab, qap, qam = a + b, a + 1.0, a - 1.0
    c, d = 1.0, 1.0 - qab * x / qap
    d = 1.0 / (d if abs(d) > tiny else tiny)
    h = d
    for m in range(1, 10000):
        m2 = 2 * m
        aa = m * (b - m) * x / ((qam + m2) * (a + m2))
        d = 1.0 + aa * d
        d = 1.0 / (d if abs(d) > tiny else tiny)
        c = 1.0 + aa / c
        c = c if abs(c) > tiny else tiny
        h *= d * c
        aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2))
        d = 1.0 + aa * d
        d = 1.0 / (d if abs(d) > tiny else tiny)
        c = 1.0 + aa / c
        c = c if abs(c) > tiny else tiny
        step = d * c
        h *= step
        if abs(step - 1.0) < eps:
            break
    return h


def linear_fit(x, y) -> tuple[float, float, float]:
    """Least squares line through (x, y): (slope, its standard error, the two-sided p-value
    of slope = 0), as scipy.stats.linregress gives them (to rounding)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    n = len(x)
    xm, ym = x.mean(), y.mean()
    sxx = float(((x - xm) ** 2).sum())
    sxy = float(((x - xm) * (y - ym)).sum())
    syy = float(((y - ym) ** 2).sum())
    slope = sxy / sxx
    dof = n - 2
    r2 = 0.0 if syy == 0 else min(1.0, sxy * sxy / (sxx * syy))
    stderr = math.sqrt(max(0.0, (1.0 - r2) * syy / sxx / dof))
    if stderr > 0:
        p = 2.0 * t_sf(abs(slope / stderr), dof)
    else:
        p = 1.0 if slope == 0 else 0.0
    return slope, stderr, p


def stationarity(t, x, t0: float, n_blocks: int = N_BLOCKS,
                 alpha: float = ALPHA) -> Stationarity:
    """The trend test of ``x`` over [t0, t[-1]] (see module doc). Too few samples for
    ``n_blocks`` blocks give NaN and ``stationary`` False."""
    if n_blocks < 3:
        raise ValueError(f"n_blocks must be >= 3, got {n_blocks}")
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    tc, means = block_means(t, x, t0, n_blocks)
    t1 = float(t[-1]) if len(t) else math.nan
    if len(t) == 0 or not np.all(np.isfinite(means)) or not t1 > t0:
        nan = math.nan
        return Stationarity(t0, t1, tc, means, nan, nan, nan, nan, False, alpha)
    slope, stderr, pvalue = linear_fit(tc, means)
    level = float(np.mean(means))
    span = t1 - t0
    scale = span / abs(level) if level != 0 else math.nan
    drift = slope * span / level if level != 0 else math.nan
    err = stderr * scale
    if err > 0:
        z = drift / err
        p = float(pvalue)
    else:  # a perfect line: exactly flat is stationary, any slope is a trend
        z = 0.0 if slope == 0 else math.copysign(math.inf, drift)
        p = 1.0 if slope == 0 else 0.0
    return Stationarity(float(t0), t1, tc, means, float(drift), float(err), float(z), p,
                        bool(p >= alpha), alpha)


def equilibration_time(t, x, bin_time: float | None = None) -> float:
    """The start of the stationary part of ``x(t)`` by Chodera's equilibration detection
    (see module doc), on the series averaged into bins of ``bin_time`` (default: 2000 bins
    over the run) to keep the cost linear."""
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    if len(t) < 10:
        return math.nan
    if bin_time is None:
        bin_time = (t[-1] - t[0]) / 2000
    per = max(1, int(round(bin_time / max(t[1] - t[0], 1e-300))))
    m = len(x) // per
    if m < 10:
        return math.nan
    xb = x[: m * per].reshape(m, per).mean(axis=1)
    tb = t[: m * per].reshape(m, per)[:, 0]
    t_eq, _, _ = detect_equilibration(xb, fast=True, nskip=max(1, m // 200))
    return float(tb[int(t_eq)])
