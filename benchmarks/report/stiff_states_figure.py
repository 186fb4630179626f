"""The figure of the stiff end's long runs, benchmarks/stiff_states.png (``python -m
benchmarks.report.stiff_states`` draws it, ``--figure-only`` it alone), from the records of
benchmarks/measure/stiff_states.py as benchmarks/report/stiff_states.py loads them.

For each (N, phi) of CASES, a column: one seed's four starts over their common length (the
stress and the contacts' coherence R in blocks of 1000 time units), that seed's longest run
smoothed with the quiet share of its stretches, and the histogram of R over every kept block
of the layer (all seeds and starts, the first 20% of each run left out). A block is quiet when
its R is below sqrt(pi / 4N) (bkflow.observables.states.r_independent): that line is on every
panel of R. The seed shown is, of the seeds with the layer's longest run, the one whose blocks
are nearest half quiet (ties: the smallest), so that a layer with two states shows both.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from benchmarks.harness import BENCH
from bkflow.figures.style import COLUMN_WIDTH
from bkflow.observables.states import r_independent

FIGURE = BENCH / "stiff_states.png"
CASES = ((100, 215.0), (100, 1000.0), (400, 1000.0))
STARTS = {"synchronized": "tab:red", "random": "tab:blue", "stratified": "tab:green",
          "partial": "tab:orange"}
QUIET_FILL = "tab:cyan"
#: the smallest text, in points at the saved size
MIN_FONT = 7.0

#: the stress's and R's time axes
T_LABEL = r"$t$ ($10^6\,\sqrt{m/k_d}$)"
#: the histogram's axis: a probability density of R is per unit of R (R is a pure number, so
#: that the density is one too), as the package's densities say their unit
R_DENSITY = "probability density of $R$\n(per unit of $R$)"


def quiet_share(blocks: pd.DataFrame, n: int) -> float:
    return float((blocks.R < r_independent(n)).mean()) if len(blocks) else 0.0


def shown_seed(g: pd.DataFrame, n: int) -> int:
    """Of the seeds of layer ``g`` (benchmarks/report/stiff_states.py's ``load``, the rows of
    one (N, phi)) that hold its longest run, the one whose kept blocks are nearest half quiet
    (ties: the smallest)."""
    longest = max(len(w) for w in g.whole)
    seeds = sorted(g[[len(w) == longest for w in g.whole]].seed.unique())

    def off_half(seed):
        kept = pd.concat(list(g[g.seed == seed].blocks), ignore_index=True)
        return abs(quiet_share(kept, n) - 0.5)
    return min(seeds, key=lambda s: (off_half(s), s))


def _sci(t: float) -> str:
    """A length of time as 10^k or m x 10^k (mathtext)."""
    k = int(np.floor(np.log10(t)))
    m = t / 10 ** k
    return f"$10^{{{k}}}$" if abs(m - 1) < 0.01 else f"${m:.3g}\\times10^{{{k}}}$"


def _traces(top, mid, g: pd.DataFrame, n: int, seed: int) -> None:
    """The seed's starts over their common length: stress (top) and R (mid), the threshold."""
    mine = g[g.seed == seed]
    common = min(float(w.t1.iloc[-1]) for w in mine.whole) + 1
    for start, colour in STARTS.items():
        for rec in mine[mine.start == start].whole:
            rec = rec[rec.t1 <= common]
            t = 0.5 * (rec.t0 + rec.t1) / 1e6
            top.plot(t, rec.s, lw=0.6, color=colour)
            mid.plot(t, rec.R, lw=0.6, color=colour)
    _threshold(mid, n, "h")
    mid.set_ylim(0, 1.05 * max(float(w.R.max()) for w in mine.whole))
    top.set_ylabel(r"$\langle\sigma_x\rangle/\sigma_n$ (blocks of $10^3$)")
    mid.set_ylabel("coherence $R$ (blocks of $10^3$)")
    for ax in (top, mid):
        ax.set_xlabel(T_LABEL)
    kept = pd.concat(list(mine.blocks), ignore_index=True)
    top.set_title(f"N = {n}, $\\phi$ = {g.phi.iloc[0]:g}, seed {seed}: four starts\n"
                  f"(quiet {100 * quiet_share(kept, n):.1f}% of the blocks)")
    mid.set_title(f"N = {n}, $\\phi$ = {g.phi.iloc[0]:g}, seed {seed}:\ncoherence")


def _threshold(ax, n: int, how: str) -> None:
    line = ax.axhline if how == "h" else ax.axvline
    line(r_independent(n), color="k", lw=0.9, ls="--", label="threshold")


def _longest(ax, g: pd.DataFrame, n: int, seed: int) -> None:
    """The seed's longest run in means of a hundredth of it, and the quiet share of each mean's
    blocks (shaded, right axis)."""
    row = max((r for _, r in g[g.seed == seed].iterrows()), key=lambda r: len(r.whole))
    rec = row.whole
    k = max(1, len(rec) // 100)
    grp = np.arange(len(rec)) // k
    tt = rec.t1.groupby(grp).max() / 1e6
    twin = ax.twinx()
    twin.fill_between(tt, 0, (rec.R < r_independent(n)).groupby(grp).mean(), color=QUIET_FILL,
                      alpha=0.35, lw=0, step="pre")
    twin.set_ylim(0, 1)
    twin.set_ylabel("quiet share (shaded)")
    ax.set_zorder(twin.get_zorder() + 1)
    ax.patch.set_visible(False)
    ax.plot(tt, rec.s.groupby(grp).mean(), lw=0.8, color="k")
    ax.set_ylabel(r"$\langle\sigma_x\rangle/\sigma_n$ (means of " + _sci(k * 1000) + ")")
    ax.set_xlabel(T_LABEL)
    ax.set_title(f"N = {n}, $\\phi$ = {g.phi.iloc[0]:g}, seed {seed}: longest run\n"
                 f"({row.start} start, {_sci(float(rec.t1.iloc[-1]))})")


def _histogram(ax, g: pd.DataFrame, n: int) -> None:
    """R over every kept block of the layer, its quiet part shaded."""
    kept = pd.concat(list(g.blocks), ignore_index=True)
    r0 = r_independent(n)
    edges = np.linspace(0, 1.02 * max(float(kept.R.max()), r0), 61)
    ax.hist(kept.R, bins=edges, density=True, histtype="step", color="k", lw=0.8)
    w = np.full(len(kept), 1 / (len(kept) * np.diff(edges)[0]))
    q = kept.R < r0
    ax.hist(kept.R[q], bins=edges, weights=w[q.to_numpy()], color=QUIET_FILL, alpha=0.6)
    _threshold(ax, n, "v")
    ax.set_xlim(0, edges[-1])
    ax.set_xlabel("coherence $R$ of a block of $10^3$")
    ax.set_ylabel(R_DENSITY)
    seeds = sorted(g.seed.unique())
    ax.set_title(f"N = {n}, $\\phi$ = {g.phi.iloc[0]:g}: every block\n(seeds {seeds[0]}-"
                 f"{seeds[-1]}, all starts; quiet {100 * q.mean():.1f}%)")


def _key(fig) -> None:
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles = [Line2D([], [], color=c, lw=1, label=f"{s} start") for s, c in STARTS.items()]
    handles += [Line2D([], [], color="k", lw=0.9, ls="--",
                       label=r"threshold $\sqrt{\pi/4N}$ (independent phases)"),
                Patch(color=QUIET_FILL, alpha=0.5, label="quiet blocks ($R$ below it)")]
    fig.legend(handles=handles, loc="outside lower center", ncol=3, frameon=False)


def draw(runs: pd.DataFrame, cases=CASES):
    """The figure from benchmarks/report/stiff_states.py's ``load`` (a row per run)."""
    import matplotlib.pyplot as plt

    cases = [(n, phi) for n, phi in cases if ((runs.N == n) & (runs.phi == phi)).any()]
    with plt.rc_context({"font.size": MIN_FONT, "axes.titlesize": MIN_FONT + 0.5,
                         "legend.fontsize": MIN_FONT + 0.5}):
        fig, axes = plt.subplots(4, len(cases), figsize=(COLUMN_WIDTH, 9.6),
                                 squeeze=False, layout="constrained")
        for j, (n, phi) in enumerate(cases):
            g = runs[(runs.N == n) & (runs.phi == phi)]
            seed = shown_seed(g, n)
            _traces(axes[0, j], axes[1, j], g, n, seed)
            _longest(axes[2, j], g, n, seed)
            _histogram(axes[3, j], g, n)
        fig.suptitle("The stiff end over long runs: a block is quiet when its $R$ is below the "
                     "dashed line, coherent above.\nThe seed of each column: of those with the "
                     "layer's longest run, the one nearest half quiet", fontsize=MIN_FONT + 1)
        _key(fig)
        fig.get_layout_engine().set(h_pad=0.06, w_pad=0.04, hspace=0.04, wspace=0.06)
    return fig


def save(runs: pd.DataFrame, out=FIGURE) -> Path:
    """Draw the figure from ``runs`` (benchmarks/report/stiff_states.py's ``load``) and save
    it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = draw(runs)
    fig.savefig(out, dpi=200)
    plt.close(fig)
    return Path(out)
