"""The bond-orientational order of the paper's Fig. 3: Psi(inf) against phi per size, below it
1 - Psi(inf) on a log axis (where the sizes part at the stiff end), and beside them 1 - Psi(t)
from the start, sample by sample, as the run recorded it (the paper's inset).
"""

from __future__ import annotations

import numpy as np

from bkflow.figures.data import SweepData, nearest_log
from bkflow.figures.legends import draw_series, state_legend
from bkflow.figures.style import (
    COLUMN_WIDTH,
    MIN_FONT,
    phi_colour,
    plain_log_ticks,
    size_label,
    value_label,
)

#: phi of the Psi(t) panel (the paper's Fig. 3 inset)
INSET_PHI = (1e3, 1e2, 10.0, 1.0)

#: fig3's (b) shows 1 - Psi(inf) of the points whose Psi(inf) is at least this (all points
#: where none is): the stiff layers, where (a)'s curves flatten near 1 and the sizes' Psi(inf)
#: differ by little in value and by many standard errors
PSI_ZOOM = 0.9

#: samples of Psi(t) (one every ``snapshot_every`` time units) that fig3's Psi(t) panel shows
#: from the start: on a linear time axis, each sample marked, so that the reader sees how few
#: samples the fall of Psi from 1 spans (it is over within the first two or three)
PSI_SAMPLES = 40


def fig3_order(data: SweepData, plt):
    """(a) Psi(inf)(phi) per size; below it, on the same phi, (b) 1 - Psi(inf) on a log axis:
    the stiff layers' Psi(inf) all lie within 1% of 1, where (a)'s curves meet although the
    sizes differ by many standard errors; (c) the paper's inset, 1 - Psi(t) from the start of
    one seed for phi in INSET_PHI (N = 400 where swept), on a log axis. Psi is recorded every
    ``snapshot_every`` time units (psi.npy; 20 by default), and its fall from Psi(0) = 1 is
    over within two or three samples: a log time axis from the first sample would make those
    samples look like a resolved fall. (c) shows the first ``PSI_SAMPLES`` samples on a
    linear time axis, each one marked, and says the sampling interval: the fall is drawn as
    what the record holds, a step the sampling does not resolve, followed by the plateau."""
    fig = plt.figure(figsize=(COLUMN_WIDTH - 0.2, 4.8))
    panels = fig.subplot_mosaic([["a", "c"], ["b", "c"]], width_ratios=(1.25, 1),
                                height_ratios=(1.1, 1))
    ax, low, ins = panels["a"], panels["b"], panels["c"]
    low.sharex(ax)
    _order_panels(ax, low, data)
    state_legend(fig, data, ax=ax)
    inset_size = (40, 10) if (40, 10) in data.sizes else data.sizes[0]
    runs = data.runs_of(*inset_size)
    phis = sorted(set(runs.phi))
    shown, steps = [], []
    for target in INSET_PHI:
        phi = nearest_log(phis, target)
        if phi in shown:
            continue
        shown.append(phi)
        p = data.run_dir(data.runs_of(*inset_size, phi).iloc[0]).read_psi_table()
        if p is None or len(p) < 2:
            continue
        t, psi = p.t.to_numpy(dtype=float), p.psi.to_numpy(dtype=float)
        step = float(np.median(np.diff(t)))
        steps.append(step)
        k = t <= t[0] + PSI_SAMPLES * step * (1 + 1e-9)
        # 1 - Psi on a log axis: Psi(0) = 1 exactly, and a sample at 1 has no place on it
        t, dis = t[k], 1.0 - psi[k]
        k = dis > 0
        ins.plot(t[k], dis[k], "o-", color=phi_colour(phi), lw=0.6, ms=2.2,
                 label=rf"$\phi$ = {value_label(phi)}")
    if not steps:
        fig.delaxes(ins)
        return fig
    _inset_axes(ins, steps, inset_size)
    return fig


def _order_panels(ax, low, data: SweepData) -> None:
    """fig3's (a), Psi(inf) against phi per size, and (b), 1 - Psi(inf) on a log axis of the
    points with Psi(inf) >= ``PSI_ZOOM`` (of all where none is)."""
    lowest = 1.0
    zoom = PSI_ZOOM if (data.results.psi_inf >= PSI_ZOOM).any() else -np.inf
    for k, (lx, ly) in enumerate(data.sizes):
        g = data.results_of(lx, ly)
        draw_series(ax, g, "psi_inf", k, size_label(lx, ly))
        lowest = min(lowest, float(g.psi_inf.min()))
        # the seeds' error of 1 - Psi is Psi's: the same column under the new name
        disorder = g.assign(disorder=1.0 - g.psi_inf,
                            **{f"disorder{tail}": g[f"psi_inf{tail}"] for tail in
                               ("_err", "_sem", "_err_within_run") if f"psi_inf{tail}" in g})
        disorder = disorder[(disorder.disorder > 0) & (disorder.psi_inf >= zoom)]
        if len(disorder):
            draw_series(low, disorder, "disorder", k, "_nolegend_")
    ax.set_xscale("log")
    ax.set_ylabel(r"$\Psi(\infty)$")
    ax.set_ylim(min(0.4, lowest - 0.03), 1.05)
    ax.tick_params(labelbottom=False)
    ax.set_title(r"Fig. 3: (a) bond-orientational order $\Psi(\infty)$", fontsize=9)
    low.set_yscale("log")
    low.set_xlabel(r"$\phi = k_b/\Delta k_d$")
    low.set_ylabel(r"$1 - \Psi(\infty)$")
    low.set_title(r"(b) $1 - \Psi(\infty)$ on a log axis"
                  + (rf" where $\Psi(\infty) \geq$ {PSI_ZOOM:g}" if zoom > 0 else "")
                  + ":\nthe sizes apart where (a)'s curves meet", fontsize=MIN_FONT)
    plain_log_ticks(low.yaxis, *low.get_ylim())


def _inset_axes(ins, steps, inset_size) -> None:
    """The axes, title and key of fig3's (c), the Psi(t) samples of ``inset_size`` drawn at
    intervals ``steps``."""
    ins.set_yscale("log")
    ins.set_xlim(left=0)
    ins.set_xlabel(r"t ($\sqrt{m/k_d}$)")
    ins.set_ylabel(r"$1 - \Psi(t)$")
    lo, hi = f"{min(steps):.3g}", f"{max(steps):.3g}"   # (the runs' time steps differ)
    every = lo if lo == hi else f"{lo} to {hi}"
    ins.set_title("(c) the paper's inset: from the start,\n"
                  f"N = {inset_size[0] * inset_size[1]}, one seed; " + r"$\Psi$ sampled" + "\n"
                  rf"every {every} time units (dots), $\Psi(0) = 1$", fontsize=MIN_FONT)
    ins.legend(fontsize=MIN_FONT, frameon=False, loc="upper center",
               bbox_to_anchor=(0.5, -0.14), ncol=4, handlelength=1.5, columnspacing=0.8)
