"""The friction figures of the paper: the stick-slip of one run's shear stress (Fig. 1b), the
macroscopic friction mu_bar against phi per size with the regimes written above it (Fig. 2a),
and the slip clusters' asymmetry <l_x>/<l_y> against phi (Fig. 2b).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from bkflow.figures.data import SweepData, nearest_log, point_states
from bkflow.figures.legends import draw_series, protocol_label, regime_legend, state_legend
from bkflow.figures.style import (
    COLUMN_WIDTH,
    MIN_FONT,
    REGIME_COLOURS,
    size_label,
    state_marker,
    value_label,
)
from bkflow.model.lattice import box_extent


def fig1b_stress(data: SweepData, plt, window: float = 150.0):
    """sigma_x(t) over the last ``window`` time units of two runs (phi nearest 1e3 and 1),
    slips' sigma_fail marked by the run's state (``state_marker``). Both panels on one y
    range, fitted to the traces so that a reader compares their stick-slip by eye, and the
    Amontons-Coulomb line mu_s sigma_n inside it: where the line lies far from the traces
    (a layer whose contacts break one by one stays well below it) the y axis is broken
    (``_broken_axis``): the traces' range, a short gap marked on both spines, and a narrow
    band around the line at the same scale, its value a tick of the axis."""
    lx, ly = data.sizes[0]
    phis = sorted(set(data.runs_of(lx, ly).phi))
    chosen = list(dict.fromkeys([nearest_log(phis, 1e3), nearest_log(phis, 1.0)]))
    traces = [_stress_trace(data, data.runs_of(lx, ly, phi).iloc[0], window) for phi in chosen]
    fig, axes = plt.subplots(len(chosen), 1, figsize=(6.0, 2.3 * len(chosen) + 0.5),
                             squeeze=False)
    # one y range for both panels, fitted to the traces, so that their stresses compare by eye
    lo, hi = min(tr["low"] for tr in traces), max(tr["high"] for tr in traces)
    pad = 0.06 * (hi - lo) if hi > lo else 0.05 * abs(hi) or 0.05
    lo, hi = lo - pad, hi + pad
    for ax, tr, colour in zip(axes[:, 0], traces, ("black", "tab:red")):
        row, state = tr["row"], str(tr["row"].get("state", "n/a"))
        ax.plot(tr["t"], tr["sigma"], color=colour, lw=0.8,
                label=rf"$\phi$ = {value_label(row.phi)}, {size_label(lx, ly)}, "
                      f"seed {int(row.seed)}")
        ax.plot(tr["t_max"], tr["fail"], ls="none",
                label=r"$\sigma_{\rm fail}$ (slip maxima; " + state + ")",
                **state_marker(str(point_states(pd.DataFrame([row]))[0]), colour, 5.5))
        ax.set_ylabel(r"$\sigma_x$ ($k_d/l$)")
        ax.set_xlabel(r"t ($\sqrt{m/k_d}$)")  # each panel: the two runs' times differ
        ax.axhline(tr["top"], color="tab:blue", ls="-.", lw=1,
                   label=rf"Amontons-Coulomb $\mu_s\sigma_n$ = {tr['top']:.3g}")
        if lo <= tr["top"] <= hi:
            ax.set_ylim(lo, hi)
        else:
            _broken_axis(ax, lo, hi, tr["top"])
        # the key above the panel: inside, it would sit on the trace
        ax.legend(loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=3, frameon=False,
                  fontsize=MIN_FONT, borderaxespad=0.1, handlelength=1.5, columnspacing=1.0)
    outline = any(tr["outline"] for tr in traces)
    fig.suptitle(r"Fig. 1b: stick-slip of the shear stress $\sigma_x(t)$ ("
                 + protocol_label(data) + ")"
                 + ("\nthe lines join its turning points (the drops above 0.1% of "
                    r"$\mu_s\sigma_n$; --scene series keeps every sample)" if outline else ""),
                 fontsize=9)
    return fig


def _stress_trace(data: SweepData, row, window: float) -> dict:
    """The last ``window`` time units of a run's sigma_x (the raw series where the run kept
    it, else the line through its turning points: ``outline``), its slips' maxima in them,
    their lowest and highest stress and mu_s sigma_n (``top``)."""
    rd = data.run_dir(row)
    t, sigma = rd.stress_outline(rd.spec())   # the turning points, or the raw series
    ev = rd.read_events()
    keep = t >= t[-1] - window
    k = (ev.t_max >= t[-1] - window).to_numpy()
    fail = ev.sigma_fail[k].to_numpy(float)
    return {"row": row, "t": t[keep], "sigma": sigma[keep], "t_max": ev.t_max[k].to_numpy(),
            "fail": fail, "outline": not rd.keeps_raw_stress(),
            "low": float(np.min(sigma[keep])),
            "high": float(max(np.max(sigma[keep]), np.max(fail, initial=-np.inf))),
            "top": float(row.mu_s * row.sigma_n * getattr(row, "area", 1.0))}


def _piecewise(xp, fp):
    """The piecewise-linear map through (xp, fp), xp and fp increasing, continued with slope
    1 beyond them (a ``FuncScale``'s forward or, swapped, inverse)."""
    xp, fp = np.asarray(xp, float), np.asarray(fp, float)

    def f(v):
        v = np.asarray(v, float)
        out = np.interp(v, xp, fp)
        out = np.where(v < xp[0], fp[0] + (v - xp[0]), out)
        return np.where(v > xp[-1], fp[-1] + (v - xp[-1]), out)

    return f


def _broken_axis(ax, lo: float, hi: float, top: float) -> None:
    """A y axis of ``ax`` that shows lo..hi and, beyond a short gap, a narrow band around
    ``top`` at the same scale (a ``FuncScale`` that squeezes the stresses between them into
    the gap): every tick a value of the axis (lo..hi's round values and ``top``), the gap
    marked by two slanted strokes on each spine."""
    from matplotlib.path import Path as MPath
    from matplotlib.ticker import FixedLocator, FuncFormatter, MaxNLocator, NullLocator

    span = hi - lo
    half, gap = 0.06 * span, 0.1 * span   # the band's half height; the gap's height
    if top > hi:
        xp, fp = [lo, hi, top - half, top + half], [lo, hi, hi + gap, hi + gap + 2 * half]
        ylim, at = (lo, top + half), hi + gap / 2
    else:
        xp, fp = [top - half, top + half, lo, hi], [lo - gap - 2 * half, lo - gap, lo, hi]
        ylim, at = (top - half, hi), lo - gap / 2
    ax.set_yscale("function", functions=(_piecewise(xp, fp), _piecewise(fp, xp)))
    ax.set_ylim(*ylim)
    ticks = [v for v in MaxNLocator(nbins=5).tick_values(lo, hi) if lo <= v <= hi]
    ax.yaxis.set_major_locator(FixedLocator(ticks + [top]))
    ax.yaxis.set_minor_locator(NullLocator())
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:.3g}"))
    # where the axis skips: the gap's middle, as a fraction of the axes' height
    frac = (at - fp[0]) / (fp[-1] - fp[0])
    strokes = MPath([(-1, -1.4), (1, -0.4), (-1, 0.4), (1, 1.4)],
                    [MPath.MOVETO, MPath.LINETO, MPath.MOVETO, MPath.LINETO])
    # the spines cut between the strokes (a white bar over each), the strokes over the cut
    ax.plot([0, 1], [frac, frac], transform=ax.transAxes, ls="none", marker="|", ms=5, mew=3,
            color="white", clip_on=False, zorder=3, label="_nolegend_")
    ax.plot([0, 1], [frac, frac], transform=ax.transAxes, ls="none", marker=strokes, ms=9,
            mew=0.9, color="black", clip_on=False, zorder=3.1, label="_nolegend_")


def fig2a_friction(data: SweepData, plt):
    """mu_bar(phi) (every slip above the threshold), mu_bar over the large drops, and
    <sigma_x>/sigma_n(phi), per size, with error bars; markers by state (``state_marker``);
    the majority regime of the smallest size written above each phi in the paper's colours,
    keyed below (``regime_legend``). The paper's panel, mu_bar with the regimes, across the
    figure's width, the other two below it side by side, every panel on one phi axis: the
    figure fits a 7 in column (``COLUMN_WIDTH``)."""
    fig = plt.figure(figsize=(COLUMN_WIDTH - 0.2, 6.0))
    panels = fig.subplot_mosaic([["a", "a"], ["c", "b"]], sharex=True)
    a, c, b = panels["a"], panels["c"], panels["b"]
    for k, (lx, ly) in enumerate(data.sizes):
        g = data.results_of(lx, ly)
        for ax, f in ((a, "mu_bar"), (c, "mu_bar_large"), (b, "mean_stress_ratio")):
            if f in g:
                draw_series(ax, g, f, k, size_label(lx, ly))
    shown = _regime_labels(a, data)
    a.set_ylabel(r"$\overline{\mu} = \langle\sigma_{\rm fail}\rangle/\sigma_n$")
    c.set_ylabel(r"$\overline{\mu}$ over large drops")
    b.set_ylabel(r"$\langle\sigma_x\rangle/\sigma_n$")
    for ax in (a, c, b):
        ax.set_xscale("log")
        ax.set_xlabel(r"$\phi = k_b/\Delta k_d$")
        ax.xaxis.set_tick_params(labelbottom=True)
    state_legend(fig, data, ax=a, extra=regime_legend(shown))
    a.set_title(f"Fig. 2a: macroscopic friction (letters: regime, {data.sizes[0][0]}x"
                f"{data.sizes[0][1]})", fontsize=9)
    c.set_title("large drops only (drop > mean drop)", fontsize=8)
    b.set_title("time-averaged stress", fontsize=9)
    return fig


def _regime_labels(ax, data: SweepData) -> list[str]:
    """The majority regime of the smallest size, written above each phi; the regimes
    written."""
    lx, ly = data.sizes[0]
    g = data.results_of(lx, ly)
    if "regime" not in g or g.regime.isna().all():
        return []
    ax.margins(y=0.18)
    tr = ax.get_xaxis_transform()
    shown = []
    for phi, reg in zip(g.phi, g.regime):
        if isinstance(reg, str):
            ax.text(phi, 0.98, reg, transform=tr, ha="center", va="top", fontsize=MIN_FONT,
                    color=REGIME_COLOURS.get(reg, "grey"))
            shown.append(reg)
    return shown


def fig2b_asymmetry(data: SweepData, plt):
    """<l_x>/<l_y>(phi) per size; the box's Lx/Ly dotted, and in the key what a whole-box
    slip reaches on a lattice with an odd side (not Lx/Ly: ``bkflow.model.lattice.box_extent``)."""
    from matplotlib.lines import Line2D

    fig, ax = plt.subplots(figsize=(4.6, 2.9))
    for k, (lx, ly) in enumerate(data.sizes):
        g = data.results_of(lx, ly)
        draw_series(ax, g, "lx_over_ly", k, size_label(lx, ly))
    aspects = sorted({lx / ly for lx, ly in data.sizes})
    for r in aspects:
        ax.axhline(r, color="grey", ls=":", lw=0.8)
    # a whole-box slip's l_x/l_y is not Lx/Ly: N/(N-1) cancels, an odd side's ring distances
    # (L^2 - 1)/4 do not (bkflow.model.lattice.box_extent)
    whole = ", ".join(f"{box_extent(lx, ly) / box_extent(ly, lx):.3g} on "
                      f"{lx}x{ly}" for lx, ly in data.sizes
                      if (lx % 2 or ly % 2) and lx > 1 and ly > 1)
    ax.set_xscale("log")
    ax.set_xlabel(r"$\phi = k_b/\Delta k_d$")
    ax.set_ylabel(r"$\langle l_x\rangle / \langle l_y\rangle$")
    ax.set_title("Fig. 2b: cluster asymmetry", fontsize=9)
    # the notes in the key below, where they cover no point
    state_legend(fig, data, ax=ax, extra=([Line2D([], [], color="grey", ls=":", lw=0.8)], [
        "the box's Lx/Ly" + (f"; a whole-box slip on an odd side\nreaches {whole}"
                             if whole else "")]))
    return fig
