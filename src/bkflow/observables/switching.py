"""Calibrating a layer's switching between states from long runs: the window means slid along
each run's blocks, their deviations from the layer's long-run mean, and the table of
``bkflow.observables.states.window_variance`` they give (``benchmarks/report/stiff_states.py``
writes it to switching.json, the model's calibration: ``bkflow.model.calibration``)."""

from __future__ import annotations

import math

import numpy as np

from bkflow.observables.states import (
    BLOCK_T,
    COHERENT,
    QUIET,
    Composition,
    not_averaged,
    r_independent,
    trend_within_fluctuations,
    verdict,
    window_variance,
)


def slide(x, k: int, step: int | None = None) -> np.ndarray:
    """Means of ``x`` over windows of k consecutive entries, a window starting every ``step``
    (default k / 4): the windows a calibration slides along a long run's blocks."""
    x = np.asarray(x, float)
    step = max(1, k // 4) if step is None else step
    if len(x) < k:
        return np.empty(0)
    c = np.concatenate([[0.0], np.cumsum(x)])
    a = np.arange(0, len(x) - k + 1, step)
    return (c[a + k] - c[a]) / k


def window_deviations(runs, truth: float, k: int) -> np.ndarray:
    """Relative squared deviations from ``truth`` (the layer's long-run mean) of the means of
    windows of k blocks slid along each of ``runs`` (arrays of block means of one layer, or
    pairs (sums, counts) of a ratio such as mu_bar: a window's sum over its count)."""
    out = []
    for r in runs:
        if isinstance(r, tuple):
            with np.errstate(invalid="ignore", divide="ignore"):
                m = slide(r[0], k) / slide(r[1], k)
            m = m[np.isfinite(m)]
        else:
            m = slide(r, k)
        out.append((m / truth - 1) ** 2)
    return np.concatenate(out) if out else np.empty(0)


def calibrate(layers: dict, windows, block_t: float = BLOCK_T) -> dict:
    """The window-variance table of ``window_variance`` for one size: ``layers`` maps phi to
    a list of layers (one disorder each), each a pair (long-run mean, [each of its runs: block
    means, or (block sums, block counts) of a ratio]); for each phi and window W (time
    units), the largest over the layers of the mean relative squared deviation of W-window
    means from their layer's long-run mean: the disorder changes how a layer switches (one
    seed's layer spends more of its time coherent than another's), and the error must cover
    the layer that switches most. A window
    longer than every run takes the last one's value times W_last / W (the 1/W of a window
    much longer than the switching)."""
    phis = sorted(layers)
    table = []
    for phi in phis:
        row = []
        for W in windows:
            k = max(1, int(round(W / block_t)))
            per_layer = [window_deviations(runs, truth, k) for truth, runs in layers[phi]]
            per_layer = [d.mean() for d in per_layer if len(d)]
            row.append(float(np.max(per_layer)) if per_layer else math.nan)
        for j in range(1, len(row)):
            if not math.isfinite(row[j]):
                row[j] = row[j - 1] * windows[j - 1] / windows[j]
        table.append(row)
    return {"phi": phis, "windows": list(windows), "table": table}


def block_verdict(t0, t1, stress, R, R2abs, Zre, Zim, samples, phi: float, n: int,
                  n_blocks: int = 10, alpha: float = 0.05):
    """The verdict of ``window`` from block averages of a window instead of its series (the
    long runs' records: blocks of BLOCK_T): per block its edges, mean stress ratio, mean R,
    mean |Z|^2, mean Z and sample count. The trend test's ``n_blocks`` blocks are groups of
    these, chi comes from the blocks' moments; the calibration is the installed one (the
    model's defaults). Returns (verdict, mean stress ratio, its error as ``Window.err``
    with the groups' scatter as the run's own)."""
    from bkflow.observables.stationarity import Stationarity, linear_fit

    t0, t1 = np.asarray(t0, float), np.asarray(t1, float)
    w = np.asarray(samples, float)
    s = np.asarray(stress, float)
    mean = float(np.average(s, weights=w))
    groups = np.array_split(np.arange(len(s)), n_blocks)
    gm = np.array([np.average(s[g], weights=w[g]) for g in groups])
    gt = np.array([0.5 * (t0[g[0]] + t1[g[-1]]) for g in groups])
    slope, stderr, p = linear_fit(gt, gm)
    span, level = float(t1[-1] - t0[0]), float(gm.mean())
    trend = Stationarity(float(t0[0]), float(t1[-1]), gt, gm, slope * span / level,
                         stderr * span / level, slope / stderr if stderr else 0.0, p,
                         p >= alpha, alpha)
    trend = trend_within_fluctuations(trend, window_variance("stress", phi, n, span / 2))
    err_block = float(gm.std(ddof=1) / math.sqrt(len(gm)))
    chi = n * (np.average(R2abs, weights=w) - np.average(Zre, weights=w) ** 2
               - np.average(Zim, weights=w) ** 2)
    quiet = float(np.mean(np.asarray(R, float) < r_independent(n)))
    comp = Composition({QUIET: quiet, COHERENT: 1 - quiet}, {}, {})
    var = window_variance("stress", phi, n, span)
    switching = not_averaged(var, err_block, mean, phi, n)
    state = verdict(bool(trend.stationary), float(chi), comp, n, switching)
    err = max(err_block, math.sqrt(var) * mean if var is not None else 0.0)
    return state, mean, err
