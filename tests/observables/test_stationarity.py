"""Stationarity and error bars on synthetic series whose answers are known: a flat series is
stationary, a drift of 3 standard errors is not, a known transient is found, and the error of
a correlated mean is calibrated on AR(1) series."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bkflow.observables.stationarity import (
    block_means,
    equilibration_time,
    mean_error,
    stationarity,
)


def ar1(rng, n, rho, m=1):
    e = rng.standard_normal((m, n))
    x = np.empty((m, n))
    x[:, 0] = e[:, 0] / math.sqrt(1 - rho ** 2)
    for i in range(1, n):
        x[:, i] = rho * x[:, i - 1] + e[:, i]
    return x


def true_error_of_mean(n, rho):
    """The exact standard deviation of the mean of n samples of a stationary AR(1)."""
    k = np.arange(1, n)
    return math.sqrt((n + 2 * np.sum((n - k) * rho ** k)) / (1 - rho ** 2)) / n


@pytest.mark.parametrize("rho", [0.0, 0.5, 0.8])
def test_error_of_a_correlated_mean_is_calibrated(rho):
    """The mean estimate over 2000 AR(1) series of n = 400 is within 5% of the true error
    (blocking, bkflow's estimator before, gave 0.79-0.84 of it at rho = 0.5 and 0.8)."""
    rng = np.random.default_rng(int(rho * 10) + 11)
    x = ar1(rng, 400, rho, 2000)
    est = np.array([mean_error(s).error for s in x])
    truth = true_error_of_mean(400, rho)
    assert np.mean(est) == pytest.approx(truth, rel=0.05)
    # and it is a real estimate, not a constant: it tracks the series' own scatter
    assert np.std(est) > 0


def test_error_of_a_mean_in_the_corner_cases():
    assert math.isnan(mean_error([]).mean)
    e = mean_error([2.0, 2.0, 2.0, 2.0])
    assert e.error == 0.0 and e.mean == 2.0
    assert math.isnan(mean_error([1.0, 2.0]).error) and not mean_error([1.0, 2.0]).reliable


def test_block_means_are_exact():
    t = np.arange(100.0)
    tc, m = block_means(t, t, 0.0, 3)
    np.testing.assert_allclose(tc, [16.5, 49.5, 82.5])
    # blocks [0, 33), [33, 66), [66, 99]
    np.testing.assert_allclose(m, [16.0, 49.0, 82.5])


def _noise(seed, n=20000, rho=0.9):
    rng = np.random.default_rng(seed)
    return np.arange(n) * 0.5, 1.0 + 0.01 * ar1(rng, n, rho)[0]


@pytest.mark.parametrize("seed", [1, 3])
def test_a_stationary_series_is_stationary(seed):
    t, x = _noise(seed)
    s = stationarity(t, x, t0=0.2 * t[-1])
    assert s.stationary and abs(s.drift_z) < 2.3 and s.drift_err > 0
    assert len(s.block_means) == 10 and np.all(np.isfinite(s.block_means))
    assert s.drift_bound == pytest.approx(abs(s.drift) + 2 * s.drift_err)


@pytest.mark.slow
def test_stationary_series_are_called_non_stationary_at_the_tests_level():
    """Over 300 stationary series the test rejects about alpha = 5% of them (a test, not a
    guarantee: a sweep of 39 stationary runs shows about two flagged by chance)."""
    rejected = [not stationarity(*_noise(seed, n=4000), t0=400.0).stationary
                for seed in range(300)]
    assert 0.02 < np.mean(rejected) < 0.09


@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.parametrize("sign", [1, -1])
def test_a_drift_of_three_standard_errors_is_not_stationary(seed, sign):
    t, x = _noise(seed)
    t0 = 0.2 * t[-1]
    s0 = stationarity(t, x, t0)
    # add the straight line that makes the fitted drift exactly 3 standard errors (a line
    # added to the data leaves the residuals, hence the error, as they were)
    span, level = t[-1] - t0, np.mean(s0.block_means)
    want = sign * 3 * s0.drift_err
    slope = (want - s0.drift) * level / span
    s = stationarity(t, x + slope * (t - t0), t0)
    assert s.drift_err == pytest.approx(s0.drift_err, rel=0.01)  # the level moved a little
    assert s.drift_z == pytest.approx(3 * sign, rel=0.02)
    assert not s.stationary and s.p_value < 0.05


def test_a_series_too_short_for_its_blocks_is_not_called_stationary():
    s = stationarity([0.0, 1.0, 2.0], [1.0, 1.0, 1.0], t0=0.0)
    assert not s.stationary and math.isnan(s.drift)


def test_equilibration_detection_finds_a_known_transient():
    """An exponential relaxation (time constant 200) onto noise: the detected start lies a
    few time constants in, far from both ends."""
    t, x = _noise(4, n=40000, rho=0.5)
    y = x + 0.2 * np.exp(-t / 200.0)
    t_eq = equilibration_time(t, y)
    assert 300 < t_eq < 3000
    assert equilibration_time(t, x) < 0.1 * t[-1]


def _pymbar():
    import contextlib
    import io
    import logging

    logging.getLogger("pymbar").setLevel(logging.ERROR)
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        from pymbar import timeseries
    return timeseries


@pytest.mark.parametrize("rho", [0.0, 0.3, 0.8, 0.97])
@pytest.mark.parametrize("fast", [False, True])
def test_the_statistical_inefficiency_is_pymbars(rho, fast):
    """bkflow's own statistical inefficiency and equilibration detection against pymbar's, on
    AR(1) series and a series with a transient: the same numbers (to rounding: one FFT here, a
    sum per lag there) and the same start."""
    from bkflow.observables.stationarity import detect_equilibration, statistical_inefficiency

    ts = _pymbar()
    rng = np.random.default_rng(int(100 * rho) + fast)
    for n in (50, 400, 3000):
        x = np.empty(n)
        x[0] = rng.standard_normal()
        for i in range(1, n):
            x[i] = rho * x[i - 1] + math.sqrt(1 - rho ** 2) * rng.standard_normal()
        for mintime in (1, 3):
            assert statistical_inefficiency(x, mintime, fast) == pytest.approx(
                ts.statistical_inefficiency(x, mintime=mintime, fast=fast), rel=1e-9)
        y = x + 3.0 * np.exp(-np.arange(n) / (0.05 * n))
        for nskip in (1, 7):
            mine = detect_equilibration(y, fast=fast, nskip=nskip)
            theirs = ts.detect_equilibration(y, fast=fast, nskip=nskip)
            assert mine[0] == theirs[0]
            assert mine[1:] == pytest.approx(theirs[1:], rel=1e-6)


def test_the_t_test_and_the_line_are_scipys():
    """bkflow's Student-t tail and least-squares line against scipy.stats (t.sf, linregress)."""
    from scipy import stats

    from bkflow.observables.stationarity import linear_fit, t_sf

    for dof in (1, 2, 3, 8, 30, 1000):
        for t in (0.0, 0.3, 1.0, 2.31, 4.0, 12.0, 80.0, -2.0):
            assert t_sf(t, dof) == pytest.approx(stats.t.sf(t, dof), rel=1e-11, abs=1e-300)
    rng = np.random.default_rng(9)
    for _ in range(20):
        x = np.sort(rng.uniform(0, 100, 10))
        y = rng.normal(0, 1, 10) + rng.uniform(-0.05, 0.05) * x
        fit = stats.linregress(x, y)
        assert linear_fit(x, y) == pytest.approx((fit.slope, fit.stderr, fit.pvalue), rel=1e-10)
