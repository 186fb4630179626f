"""The friction figures of the paper: the stick-slip of one run's shear stress (Fig. 1b), the
macroscopic friction mu_bar against phi per size with the regimes written above it (Fig. 2a),
and the slip clusters' asymmetry <l_x>/<l_y> against phi (Fig. 2b).
"""

from __future__ import annotations

import numpy as np

from bkflow.figures.data import SweepData, _nearest
from bkflow.figures.keys import _series, protocol_label, regime_key, state_key
from bkflow.figures.style import MARKERS, MIN_FONT, REGIME_COLOURS, STATE_FILL, _num, _size_label
from bkflow.model.lattice import box_extent


def fig1b_stress(data: SweepData, plt, window: float = 150.0):
    """sigma_x(t) over the last ``window`` time units of two runs (phi nearest 1e3 and 1),
    slips' sigma_fail marked. Both panels on one y range, fitted to the traces so that a
    reader compares their stick-slip by eye; the Amontons-Coulomb line mu_s sigma_n, far
    above the traces in a layer whose contacts break one by one, is drawn where it lies in
    that range and otherwise named in the right margin, its arrow pointing up (or down) to
    it (a range stretched to it would leave the traces a sliver of each panel)."""
    lx, ly = data.sizes[0]
    phis = sorted(set(data.runs_of(lx, ly).phi))
    chosen = list(dict.fromkeys([_nearest(phis, 1e3), _nearest(phis, 1.0)]))
    fig, axes = plt.subplots(len(chosen), 1, figsize=(6.0, 2.1 * len(chosen) + 0.5),
                             squeeze=False)
    lows, highs, tops = [], [], []
    outline = False
    for ax, phi, colour, marker in zip(axes[:, 0], chosen, ("black", "tab:red"), ("s", "o")):
        row = data.runs_of(lx, ly, phi).iloc[0]
        rd = data.run_dir(row)
        t, sigma = rd.stress_outline(rd.spec())   # the turning points, or the raw series
        ev = rd.read_events()
        t0 = t[-1] - window
        keep = t >= t0
        # the raw series where the run kept it, else the line through its turning points
        outline = outline or not rd.keeps_raw_stress()
        ax.plot(t[keep], sigma[keep], color=colour, lw=0.8,
                label=rf"$\phi$ = {_num(phi)}, {_size_label(lx, ly)}, seed {int(row.seed)}")
        k = ev.t_max >= t0
        fill = STATE_FILL.get(str(row.get("state", "drifting")), "none")
        ax.plot(ev.t_max[k], ev.sigma_fail[k], marker, color=colour, fillstyle=fill,
                mfc=colour if fill != "none" else "white", mfcalt="white", ls="none",
                label=r"$\sigma_{\rm fail}$ (slip maxima; " + str(row.get("state", "n/a"))
                + ")")
        ax.set_ylabel(r"$\sigma_x$ ($k_d/l$)")
        ax.set_xlabel(r"t ($\sqrt{m/k_d}$)")  # each panel: the two runs' times differ
        lows.append(float(np.min(sigma[keep])))
        highs.append(float(max(np.max(sigma[keep]),
                               np.max(ev.sigma_fail[k].to_numpy(float), initial=-np.inf))))
        tops.append(float(row.mu_s * row.sigma_n * getattr(row, "area", 1.0)))
    # one y range for both panels, fitted to the traces, so that their stresses compare by eye
    lo, hi = min(lows), max(highs)
    pad = 0.06 * (hi - lo) if hi > lo else 0.05 * abs(hi) or 0.05
    lo, hi = lo - pad, hi + pad
    for ax, top in zip(axes[:, 0], tops):
        ax.set_ylim(lo, hi)
        words = rf"Amontons-Coulomb $\mu_s\sigma_n$ = {top:.3g}"
        if lo <= top <= hi:
            ax.axhline(top, color="tab:blue", ls="-.", lw=1, label=words)
        else:  # outside the range: named in the right margin, the arrow pointing to it
            up = top > hi
            ax.annotate("Amontons-Coulomb\n" + rf"$\mu_s\sigma_n$ = {top:.3g}",
                        xy=(1.012, 1.0 if up else 0.0),
                        xycoords="axes fraction", xytext=(1.012, 0.5),
                        textcoords="axes fraction", rotation=90, ha="left", va="center",
                        fontsize=MIN_FONT, color="tab:blue", annotation_clip=False,
                        arrowprops={"arrowstyle": "->", "color": "tab:blue", "lw": 0.8,
                                    "shrinkA": 2, "shrinkB": 0})
        # the key above the panel: inside, it would sit on the trace
        ax.legend(loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=3, frameon=False,
                  fontsize=MIN_FONT, borderaxespad=0.1, handlelength=1.5, columnspacing=1.0)
    fig.suptitle(r"Fig. 1b: stick-slip of the shear stress $\sigma_x(t)$ ("
                 + protocol_label(data) + ")"
                 + ("\nthe lines join its turning points (the drops above 0.1% of "
                    r"$\mu_s\sigma_n$; --scene series keeps every sample)" if outline else ""),
                 fontsize=9)
    return fig


def fig2a_friction(data: SweepData, plt):
    """mu_bar(phi) (every slip above the threshold), mu_bar over the large drops, and
    <sigma_x>/sigma_n(phi), per size, with error bars; markers by state (``STATE_FILL``);
    the majority regime of the smallest size written above each phi in the paper's colours,
    keyed below (``regime_key``)."""
    fig, (a, c, b) = plt.subplots(1, 3, figsize=(10.0, 3.1))
    for (lx, ly), m in zip(data.sizes, MARKERS):
        g = data.results_of(lx, ly)
        for ax, f in ((a, "mu_bar"), (c, "mu_bar_large"), (b, "mean_stress_ratio")):
            if f in g:
                _series(ax, g, f, m, _size_label(lx, ly))
    shown = _regime_labels(a, data)
    a.set_ylabel(r"$\overline{\mu} = \langle\sigma_{\rm fail}\rangle/\sigma_n$")
    c.set_ylabel(r"$\overline{\mu}$ over large drops")
    b.set_ylabel(r"$\langle\sigma_x\rangle/\sigma_n$")
    for ax in (a, c, b):
        ax.set_xscale("log")
        ax.set_xlabel(r"$\phi = k_b/\Delta k_d$")
    state_key(fig, data, ax=a, extra=regime_key(shown))
    a.set_title(f"Fig. 2a: macroscopic friction (letters: regime, {data.sizes[0][0]}x"
                f"{data.sizes[0][1]})", fontsize=8)
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
    for (lx, ly), m in zip(data.sizes, MARKERS):
        g = data.results_of(lx, ly)
        _series(ax, g, "lx_over_ly", m, _size_label(lx, ly))
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
    state_key(fig, data, ax=ax, extra=([Line2D([], [], color="grey", ls=":", lw=0.8)], [
        "the box's Lx/Ly" + (f"; a whole-box slip on an odd side\nreaches {whole}"
                             if whole else "")]))
    return fig
