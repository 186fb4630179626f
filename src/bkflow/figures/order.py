"""The bond-orientational order of the paper's Fig. 3: Psi(inf) against phi per size, and beside
it 1 - Psi(t) from the start, sample by sample, as the run recorded it (the paper's inset).
"""

from __future__ import annotations

import numpy as np

from bkflow.figures.data import SweepData, _nearest
from bkflow.figures.keys import _series, state_key
from bkflow.figures.style import MARKERS, MIN_FONT, _num, _size_label, phi_colour

#: phi of the Psi(t) panel (the paper's Fig. 3 inset)
INSET_PHI = (1e3, 1e2, 10.0, 1.0)

#: samples of Psi(t) (one every ``snapshot_every`` time units) that fig3's Psi(t) panel shows
#: from the start: on a linear time axis, each sample marked, so that the reader sees how few
#: samples the fall of Psi from 1 spans (it is over within the first two or three)
PSI_SAMPLES = 40


def fig3_order(data: SweepData, plt):
    """(a) Psi(inf)(phi) per size; (b) the paper's inset, 1 - Psi(t) from the start of one
    seed for phi in INSET_PHI (N = 400 where swept), on a log axis (the stiff layers' Psi
    all lie within 2% of 1). Psi is recorded every ``snapshot_every`` time units (psi.npy;
    20 by default), and its fall from Psi(0) = 1 is over within two or three samples: a log
    time axis from the first sample would make those samples look like a resolved fall. (b) shows
    the first ``PSI_SAMPLES`` samples on a linear time axis, each one marked, and says the
    sampling interval: the fall is drawn as what the record holds, a step the sampling does
    not resolve, followed by the plateau."""
    fig, (ax, ins) = plt.subplots(1, 2, figsize=(7.6, 3.1), width_ratios=(1.25, 1))
    for (lx, ly), m in zip(data.sizes, MARKERS):
        g = data.results_of(lx, ly)
        _series(ax, g, "psi_inf", m, _size_label(lx, ly))
    ax.set_xscale("log")
    ax.set_xlabel(r"$\phi = k_b/\Delta k_d$")
    ax.set_ylabel(r"$\Psi(\infty)$")
    ax.set_ylim(0.4, 1.05)
    state_key(fig, data, ax=ax)
    ax.set_title(r"Fig. 3: bond-orientational order $\Psi$", fontsize=9)
    inset_size = (40, 10) if (40, 10) in data.sizes else data.sizes[0]
    runs = data.runs_of(*inset_size)
    phis = sorted(set(runs.phi))
    shown, steps = [], []
    for target in INSET_PHI:
        phi = _nearest(phis, target)
        if phi in shown:
            continue
        shown.append(phi)
        p = data.run_dir(data.runs_of(*inset_size, phi).iloc[0]).read_psi()
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
                 label=rf"$\phi$ = {_num(phi)}")
    if not steps:
        fig.delaxes(ins)
        return fig
    ins.set_yscale("log")
    ins.set_xlim(left=0)
    ins.set_xlabel(r"t ($\sqrt{m/k_d}$)")
    ins.set_ylabel(r"$1 - \Psi(t)$")
    lo, hi = f"{min(steps):.3g}", f"{max(steps):.3g}"   # (the runs' time steps differ)
    every = lo if lo == hi else f"{lo} to {hi}"
    ins.set_title(f"the paper's inset: from the start, N = {inset_size[0] * inset_size[1]}, "
                  "one seed;\n"
                  rf"$\Psi$ sampled every {every} time units (dots), $\Psi(0) = 1$",
                  fontsize=MIN_FONT)
    ins.legend(fontsize=MIN_FONT, frameon=False, loc="upper center",
               bbox_to_anchor=(0.5, -0.24), ncol=4, handlelength=1.5, columnspacing=0.8)
    return fig
