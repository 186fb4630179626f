"""The states of a layer and the error that covers its switching (bkflow.observables.states), on
synthetic series whose truth is known: a slow two-state component (a telegraph process between a
quiet and a coherent level, residence times longer than the windows) under fast noise."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bkflow.model import calibration
from bkflow.observables import pair, states, switching
from bkflow.observables.stationarity import mean_error

QUIET, COHERENT = 0.1030, 0.1048     # the two levels (stress ratio), as at phi = 1000
TAU_Q, TAU_C = 40, 40                # mean residence (blocks of 1000 time units)
NOISE, RHO = 3e-4, 0.6               # fast noise of a block mean: AR(1)
TRUTH = (QUIET * TAU_Q + COHERENT * TAU_C) / (TAU_Q + TAU_C)


def telegraph(rng, n_blocks):
    """Block means of the synthetic layer: (means, in the quiet state)."""
    quiet = np.empty(n_blocks, bool)
    state, k = rng.random() < TAU_Q / (TAU_Q + TAU_C), 0
    while k < n_blocks:
        stay = 1 + rng.geometric(1 / (TAU_Q if state else TAU_C))
        quiet[k:k + stay] = state
        k += stay
        state = not state
    e = np.empty(n_blocks)
    e[0] = rng.standard_normal() * NOISE
    for i in range(1, n_blocks):
        e[i] = RHO * e[i - 1] + math.sqrt(1 - RHO ** 2) * NOISE * rng.standard_normal()
    return np.where(quiet, QUIET, COHERENT) + e, quiet


WINDOWS = [4e3, 1e4, 2e4, 5e4, 1e5, 2e5]


def _calibration(rng):
    """A calibration made as benchmarks/report/stiff_states.py makes it: three layers, four long
    runs each, the truth of each layer its runs' pooled mean."""
    layers = []
    for _ in range(3):
        runs = [telegraph(rng, 2000)[0] for _ in range(4)]
        layers.append((float(np.mean(np.concatenate(runs))), runs))
    cal = switching.calibrate({1000.0: layers}, WINDOWS)
    return {"phi": cal["phi"], "windows": cal["windows"], "stress": cal["table"]}


@pytest.mark.parametrize("W", [5e3, 2e4, 8e4])
def test_the_calibrated_error_covers_the_switching(W):
    """Fresh windows of W time units (W / tau from 0.06 to 1): the interval mean +- 1.96
    (the calibrated error) holds the long-run mean at least 90% of the time, where the
    window's own error (mean_error of its block means) does not."""
    rng = np.random.default_rng(7)
    size = _calibration(rng)
    var = states.window_variance("stress", 1000.0, 100, W, size=size)
    k = int(W / 1000)
    hit_cal = hit_own = 0
    trials = 400
    for _ in range(trials):
        x = telegraph(rng, k + 200)[0][200:]   # a window from a random moment
        m = x.mean()
        hit_cal += abs(m - TRUTH) <= 1.96 * math.sqrt(var) * m
        own = mean_error(x).error if k >= 3 else 0.0
        hit_own += abs(m - TRUTH) <= 1.96 * (own if math.isfinite(own) else 0.0)
    assert hit_cal / trials >= 0.90, (W, hit_cal / trials)
    assert hit_own / trials < 0.80, "the window's own error should miss the switching"


def test_windows_much_longer_than_the_switching_need_no_calibration():
    """Far beyond the residence times the window's own error is right (and the calibration
    falls as 1 / W), so the verdict's test of dominance says the window averaged over it."""
    rng = np.random.default_rng(11)
    size = _calibration(rng)
    x = telegraph(rng, 4000)[0]
    own = mean_error(x).error
    var = states.window_variance("stress", 1000.0, 100, 4e6, size=size)
    assert math.sqrt(var) * x.mean() < 2 * own
    assert abs(x.mean() - TRUTH) <= 1.96 * own * 1.5


def test_blocks_name_the_state_by_the_independent_phases_level():
    n = 100
    t = np.arange(0.0, 4000.0)
    R = np.where(t < 2000, 0.04, 0.25)     # quiet, then coherent
    ratio = np.where(t < 2000, QUIET, COHERENT)
    b = states.blocks(t, R, t, ratio, 0.0, n, block_t=1000.0)
    assert list(b.state) == ["quiet", "quiet", "coherent", "coherent"]
    c = states.composition(b, t_fail=[100.0, 3500.0], sigma_fail_ratio=[0.106, 0.112])
    assert c.name == "quiet+coherent" and c.fraction["quiet"] == pytest.approx(0.5, abs=0.01)
    assert c.mean_stress["quiet"] == pytest.approx(QUIET)
    assert (c.mu_bar["quiet"], c.mu_bar["coherent"]) == (0.106, 0.112)
    assert states.r_independent(n) == pytest.approx(math.sqrt(math.pi / 400))


@pytest.mark.parametrize("stationary, chi, seen, dominating, pair, want", [
    (True, 0.8, ("coherent",), False, False, "steady"),
    (False, 0.8, ("coherent",), False, False, "drifting"),
    (True, 50.0, ("coherent",), False, False, "metastable"),
    (True, 0.8, ("coherent",), False, True, "metastable"),
    (True, 0.5, ("quiet",), True, False, "quiet"),
    (False, 2.0, ("quiet", "coherent"), False, False, "quiet+coherent"),
    (False, 2.0, ("coherent",), True, False, "coherent"),
])
def test_the_verdict(stationary, chi, seen, dominating, pair, want):
    comp = states.Composition({s: (1.0 / len(seen) if s in seen else 0.0)
                               for s in states.STATE_NAMES}, {}, {})
    assert states.verdict(stationary, chi, comp, 100, dominating, pair) == want


def _approach(t, truth, amp, tau, noise, rng):
    """Block means of a stress ratio approaching ``truth`` as truth (1 + amp e^(-t/tau)),
    with white noise of relative size ``noise`` per block."""
    return truth * (1 + amp * np.exp(-t / tau) + noise * rng.standard_normal(len(t)))


@pytest.mark.parametrize("amp, tau", [(-0.015, 2e4), (-0.02, 5e4), (-0.01, 1e4)])
def test_the_pair_does_not_stop_inside_a_slow_approach_from_below(amp, tau):
    """A run whose start approaches the steady state slowly from below (as the random start
    does at the stiff end, benchmarks/RESULTS.md "Time to steady") beside a companion already
    there: at no check may the pair stop while the run's window still lies further below than
    the error target, whatever its own errors say, and where it stops the pair's estimate is
    within the target of the truth."""
    from bkflow.model.params import RunSpec

    rng = np.random.default_rng(7)
    spec = RunSpec(phi=10.0, target_error=2e-4, until_steady=True, companion="partial")
    truth, mu_over_stress = 0.1133, 1.043
    t = np.arange(0.0, 3e5, 20.0)
    main = _approach(t, truth, amp, tau, 2e-4, rng) * spec.sigma_n
    comp = _approach(t, truth, 0.0, tau, 2e-4, rng) * spec.sigma_n
    stopped = None
    for check in np.arange(1000.0, 3e5, 1000.0):
        upto = t <= check
        legs = []
        for sigma in (main, comp):
            w = states.window(spec, t[upto], sigma[upto], None, 0.2 * check)
            legs.append(pair.Leg(w, w.mean * mu_over_stress, w.err * mu_over_stress, True))
        both = states.window(spec, t[upto], 0.5 * (main + comp)[upto], None, 0.2 * check)
        d = pair.pair_rule(legs[0], legs[1], both, spec.target_error, 0.005, 0.01)
        late = (t >= 0.2 * check) & upto
        deficit = 1 - np.mean(1 + amp * np.exp(-t[late] / tau))   # the approach's, noise-free
        target_rel = spec.target_error / d.mu_bar.value
        if deficit > 2 * target_rel:
            assert not d.stop, (check, deficit)
        if d.stop:
            stopped = check
            break
    assert stopped is not None
    both = 0.5 * (legs[0].window.mean + legs[1].window.mean)
    assert abs(both / truth - 1) <= spec.target_error / d.mu_bar.value
    # the error it reports covers what is left of the approach
    assert abs(d.mu_bar.value / (truth * mu_over_stress) - 1) <= 2 * d.mu_bar.err / d.mu_bar.value


def test_the_pairs_error_covers_half_its_difference():
    m = pair.pair_mean(0.110, 1e-4, 0.106, 1e-4)
    assert m.value == pytest.approx(0.108) and m.bracket == pytest.approx(0.002)
    assert m.err == pytest.approx(0.002) and m.noise == pytest.approx(math.hypot(1e-4, 1e-4) / 2)
    close = pair.pair_mean(0.1080, 1e-3, 0.1081, 1e-3)
    assert close.err == pytest.approx(close.noise)
    assert math.isnan(pair.pair_mean(0.1, math.nan, 0.1, 1e-3).noise)


def test_a_pair_apart_by_more_than_the_target_does_not_stop_whatever_its_errors():
    """Two runs whose mean stresses differ by 1.5 times the error target, each flat and each
    precise: the pair's error (half their difference) is within the target, but they do not
    agree within it, and one of them still carries its start: no stop. Together, and at every
    check, the pair's error is at least half the difference of its two mu_bar."""
    from bkflow.model.params import RunSpec

    rng = np.random.default_rng(3)
    spec = RunSpec(phi=10.0, target_error=2e-4, until_steady=True, companion="partial")
    truth, mu_over_stress = 0.1133, 1.043
    rel = spec.target_error / (truth * mu_over_stress)
    t = np.arange(0.0, 3e5, 20.0)
    main = _approach(t, truth * (1 - 1.5 * rel), 0.0, 1.0, 1e-4, rng) * spec.sigma_n
    comp = _approach(t, truth, 0.0, 1.0, 1e-4, rng) * spec.sigma_n
    for check in np.arange(5000.0, 3e5, 5000.0):
        upto = t <= check
        legs = []
        for sigma in (main, comp):
            w = states.window(spec, t[upto], sigma[upto], None, 0.2 * check)
            legs.append(pair.Leg(w, w.mean * mu_over_stress, 1e-6, True))
        both = states.window(spec, t[upto], 0.5 * (main + comp)[upto], None, 0.2 * check)
        d = pair.pair_rule(legs[0], legs[1], both, spec.target_error, 0.005, 0.01)
        assert d.mu_bar.err <= spec.target_error   # the error alone would allow it
        assert d.mu_bar.err >= 0.5 * abs(legs[0].mu_bar - legs[1].mu_bar)
        assert not d.stop, check


def test_where_nothing_is_calibrated_the_errors_borrow_wide():
    """Another N, aspect or model parameter: the error of a window covers the nearest
    calibrated layer's slow fluctuations, widened (N_calibrated / N for a smaller layer,
    BORROWED_FACTOR for other parameters or another aspect), never the run's own alone; and
    the run says why."""
    from bkflow.model.params import RunSpec

    rng = np.random.default_rng(5)
    t = np.arange(0.0, 2e4, 20.0)
    home = RunSpec(phi=100.0)
    base = states.window_variance("stress", 100.0, 100, 1.6e4)
    for spec, factor in ((RunSpec(phi=100.0, Lx=12, Ly=3), 100 / 36),
                         (RunSpec(phi=100.0, gamma=0.1), states.BORROWED_FACTOR),
                         (RunSpec(phi=100.0, Lx=10, Ly=10), states.BORROWED_FACTOR),
                         (RunSpec(phi=100.0, Lx=200, Ly=50), 1.0)):
        assert states.calibrated(spec) is not None
        sigma = spec.sigma_n * 0.107 * (1 + 1e-5 * rng.standard_normal(len(t)))
        w = states.window(spec, t, sigma, None, 0.2 * t[-1])
        near = min(map(int, calibration.switching()["sizes"]),
                   key=lambda n: abs(math.log(n / spec.N)))
        v = states.window_variance("stress", 100.0, near, w.t1 - w.t0)
        assert w.var_borrowed == pytest.approx(v * max(factor, 1.0), rel=1e-9)
        assert w.err >= math.sqrt(w.var_borrowed) * w.mean > 10 * w.err_run
    assert states.calibrated(home) is None and base > 0
