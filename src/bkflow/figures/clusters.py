"""The slip clusters of the paper's Fig. 4a: l_y against l_x of every cluster, each as a fraction
of the whole box's own extent on its side, for a few fixed phi (``CLUSTER_PHI``, also the phi of
fig_drops and fig_potency), with the regimes' bounds drawn in and each set's regime shares as the
analysis recorded them (the figures never classify).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from bkflow.figures.data import SweepData, nearest_log
from bkflow.figures.legends import protocol_label
from bkflow.figures.style import MIN_FONT, REGIME_COLOURS, phi_colour, size_label, value_label
from bkflow.model.lattice import box_fractions

#: the axes of a cluster scatter: each extent over a whole-box slip's on its side
#: (``box_fractions``), the f_x and f_y of the regimes' words (``style.REGIME_WORDS``)
FX_LABEL = r"$f_x = l_x\,/\,l_x^{\mathrm{whole\ box}}$ (along x)"
FY_LABEL = r"$f_y = l_y\,/\,l_y^{\mathrm{whole\ box}}$ (across x)"
#: what a cluster figure says of its axes: 1 is a whole-box slip, and a cluster can go past it
ABOVE_ONE = ("f: a cluster's extent (from the mean distance of its particles along that side) "
             "over a whole-box slip's; a whole-box slip sits at (1, 1). A cluster whose "
             "particles lie farther apart on average than the whole box's has f above 1: {}.")

#: the phi of the cluster scatter (fig4a), fig_drops and fig_potency: the swept values
#: nearest these targets, log-evenly spaced over the default range 0.1 .. 1000 (4/3 of a
#: decade apart, so that on the default grid of 3 per decade each is a grid point). Fixed, so
#: that the figures of two sweeps or two versions show the same layers (the phi where each
#: regime is most frequent would move with the data)
CLUSTER_PHI = (1e3, 46.4159, 2.15443, 0.1)


def cluster_phis(phis) -> list[float]:
    """The phi of the cluster scatter, fig_drops and fig_potency among the swept ``phis``: for
    each target of ``CLUSTER_PHI`` the nearest (on a log scale), each once, stiffest first.
    The same targets in every sweep, so that two sweeps' figures show the same layers where
    both swept them."""
    return sorted({nearest_log(phis, target) for target in CLUSTER_PHI}, reverse=True)


def cluster_size(data: SweepData) -> tuple[int, int]:
    """The size of the cluster figures: the paper's 20x5 where swept, else the smallest."""
    return (20, 5) if (20, 5) in data.sizes else data.sizes[0]


def fig4a_clusters(data: SweepData, plt):
    """l_y against l_x of every slip cluster, all seeds, each as a fraction of the whole box's
    own extent on its side, for the phi of ``CLUSTER_PHI`` (20x5 if swept): one panel per
    phi on shared axes, so that no phi's clusters hide another's (on one panel the thousands
    of a soft layer would cover the rest, and the stiff layers' clusters all sit on one spot
    of the C / W corner); each panel's title gives its count and the shares of its clusters in
    the regimes (``cluster_sets``)."""
    lx, ly = cluster_size(data)
    sets = cluster_sets(data, lx, ly, cluster_phis(data.runs_of(lx, ly).phi))
    if not sets:
        return None
    n = len(sets)
    ncols = 2 if n > 1 else 1
    nrows = -(-n // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(3.2 * ncols + 0.3, 3.2 * nrows + 0.9),
                             sharex=True, sharey=True, squeeze=False)
    top = _cluster_top(sets, (lx, ly))
    span = _span(data)
    for ax, one in zip(axes.flat, sets):
        _cluster_panel(ax, [one], (lx, ly), span, top)
        phi, c, shares = one
        ax.set_title(rf"$\phi$ = {value_label(phi)}: {len(c)} clusters" + "\n"
                     + _shares_words(shares, len(c)), fontsize=8)
    for ax in axes.flat[n:]:
        ax.set_axis_off()
    for k, ax in enumerate(axes.flat[:n]):
        if k + ncols >= n:    # no panel below: its x axis is labelled
            ax.set_xlabel(FX_LABEL)
            ax.xaxis.set_tick_params(labelbottom=True)
    for ax in axes[:, 0]:
        ax.set_ylabel(FY_LABEL)
    # the key (the colours of phi, as in fig_drops and fig_potency, and the bounds) in a spare
    # panel where there is one, else below the panels
    from matplotlib.lines import Line2D

    key = [Line2D([], [], ls="none", marker="o", ms=5, mew=0, color=phi_colour(phi),
                  label=rf"$\phi$ = {value_label(phi)}") for phi, *_ in sets] \
        + _cluster_guides(span)
    if n < axes.size:
        axes.flat[-1].legend(handles=key, loc="center", frameon=False, fontsize=MIN_FONT,
                             title=_above_one(sets, (lx, ly), 52), title_fontsize=MIN_FONT)
    else:
        fig.legend(handles=key, loc="outside lower center", ncol=3, frameon=False,
                   fontsize=MIN_FONT, title=_above_one(sets, (lx, ly), 95),
                   title_fontsize=MIN_FONT)
    fig.suptitle(f"Fig. 4a: slip clusters, {size_label(lx, ly)} ({protocol_label(data)})",
                 fontsize=9)
    return fig


def _above_one(sets, box, width: int) -> str:
    """``ABOVE_ONE`` with the largest f of the clusters of ``sets``, in lines of ``width``
    characters."""
    import textwrap

    most = max(float(max(f.max() for f in box_fractions(c.l_x, c.l_y, box)))
               for _, c, _ in sets)
    # (a whole-box slip's f is 1 up to rounding)
    return textwrap.fill(ABOVE_ONE.format(f"here up to {most:.3g}" if most > 1.0005 else
                                          "none here"), width)


def cluster_sets(data: SweepData, lx, ly, phis) -> list[tuple]:
    """[(phi, its clusters pooled over the seeds, {regime: share})] of the runs at (lx, ly)
    for each of ``phis`` whose runs recorded clusters."""
    sets = []
    for phi in phis:
        runs = data.runs_of(lx, ly, phi)
        frames = [(r, c) for (_, r), c in zip(
            runs.iterrows(), (data.run_dir(r).read_clusters() for _, r in runs.iterrows()))
            if c is not None and len(c)]
        if frames:
            kept = pd.DataFrame([r for r, _ in frames])
            sets.append((phi, pd.concat([c for _, c in frames]),
                         _regime_shares(kept, [c for _, c in frames])))
    return sets


def _shares_words(shares: dict, total: int) -> str:
    """"C 98% (490), LC 2% (10)": the regimes' shares of a set of ``total`` clusters, those
    of 0.5% or more, each with its count of clusters (a share of a few clusters reads as
    what it is)."""
    return ", ".join(f"{reg} {share:.0%} ({round(share * total)})"
                     for reg, share in shares.items() if share >= 0.005)


def _span(data: SweepData) -> float:
    """The fraction of a side from which the sweep's analysis counts it spanned."""
    from bkflow.model.params import SPAN_FRACTION

    return float(getattr(getattr(data, "settings", None), "span_fraction", SPAN_FRACTION))


def _cluster_top(sets, box) -> float:
    """The upper limit of both axes of a cluster scatter: every cluster inside (a soft
    layer's clusters reach past 1 across the box), at least 1.15 (the C / W corner's name)."""
    return max(1.15, 1.03 * max(float(max(f.max() for f in box_fractions(
        c.l_x, c.l_y, box))) for _, c, _ in sets))


def _cluster_guides(span: float) -> list:
    """The key of the regime bounds drawn on a cluster scatter."""
    from matplotlib.lines import Line2D

    return [Line2D([], [], color="grey", lw=0.6, ls=":",
                   label=f"{span:g} of a side: spanning (the regimes' bounds)"),
            Line2D([], [], color="grey", lw=0.6, ls="--", label="the DP / DT bound")]


def _cluster_panel(ax, sets, box, span: float, top: float) -> dict:
    """Draw ``sets`` (``cluster_sets``) on ``ax`` as small filled circles in their phi's
    colour (``phi_colour``), translucent (the more clusters, the fainter), the densest set
    lowest, with the regime bounds and the regions' names in grey; returns {phi: a key handle
    (opaque and larger, labelled with the count and the regime shares)}."""
    keys = {}
    # the largest set first and lowest: a sparse set is drawn over a dense one, not hidden
    for z, (phi, c, shares) in enumerate(sorted(sets, key=lambda s: -len(s[1]))):
        fx, fy = box_fractions(c.l_x, c.l_y, box)
        colour = phi_colour(phi)
        alpha = float(np.clip(20.0 / math.sqrt(len(c)), 0.15, 0.8))
        ax.plot(fx, fy, "o", color=colour, ms=2.0, mew=0, alpha=alpha, zorder=2 + z,
                label="_nolegend_")
        words = _shares_words(shares, len(c))
        # an empty line added to the axes, so that a caller's ax.legend() finds it too
        keys[phi], = ax.plot([], [], "o", color=colour, ms=5, mew=0,
                             label=rf"$\phi$ = {value_label(phi)}: {len(c)} clusters"
                             + (f" ({words})" if words else ""))
    ax.plot([0, top], [0, top], color="grey", lw=0.6, ls="--")
    ax.axvline(span, color="grey", lw=0.6, ls=":")
    ax.axhline(span, color="grey", lw=0.6, ls=":")
    # the regions' names in grey (the colours belong to the phi), under the points: a name
    # never hides a cluster
    for txt, x, y in (("C / W", 1.07, 1.07), ("LC", 1.07, 0.5), ("DP", 0.6, 0.2),
                      ("DT", 0.2, 0.6)):
        ax.text(x, y, txt, fontsize=8, ha="center", va="center", color="dimgrey",
                weight="bold", zorder=1)
    ax.set_xlim(-0.03, top)  # a cluster one particle across sits at 0: drawn whole
    ax.set_ylim(-0.03, top)
    return keys


def _regime_shares(runs: pd.DataFrame, frames) -> dict:
    """{regime: share of the clusters} of ``frames`` (the clusters of each run of ``runs``):
    the runs' own shares as the analysis classified them (runs.csv
    ``regime_fractions[R]``, bkflow.observables.clusters.regime), weighted by each run's clusters. A
    figure reads the regimes from the tables; it never classifies."""
    weights = np.array([len(c) for c in frames], dtype=float)
    shares = {}
    for reg in REGIME_COLOURS:
        col = f"regime_fractions[{reg}]"
        if col in runs:
            f = pd.to_numeric(runs[col], errors="coerce").to_numpy(dtype=float)
            ok = np.isfinite(f)
            if ok.any() and weights[ok].sum() > 0:
                shares[reg] = float(np.sum(f[ok] * weights[ok]) / weights[ok].sum())
    return shares


def cluster_scatter(data: SweepData, plt, lx, ly, phis, title, ax=None):
    """l_y/l_y^box against l_x/l_x^box of every cluster of the runs at (lx, ly) and each phi,
    all on one panel (``ax``, or a new figure's), with the regime bounds of
    ``bkflow.observables.clusters.regime`` drawn in and the regions named in grey; None when no
    clusters. Each phi is a set of small filled circles in its colour (``phi_colour``: a sequential
    map, so that no set reads as one of the paper's regime colours, and filled, as open markers
    mean a drifting run in bkflow's other figures), translucent and the densest lowest; the
    key gives each set's count and regime shares, which a reader cannot count where sets lie
    on one another (fig4a draws one panel per phi instead)."""
    fig = None
    if ax is None:
        fig, ax = plt.subplots(figsize=(4.2, 4.9))
    sets = cluster_sets(data, lx, ly, phis)
    if not sets:
        if fig is not None:
            plt.close(fig)
        return None
    span = _span(data)
    keys = _cluster_panel(ax, sets, (lx, ly), span, _cluster_top(sets, (lx, ly)))
    # each extent against the whole box's own on its side: a whole-box slip sits at (1, 1)
    # on odd and even sides alike (bkflow.model.lattice.box_fractions)
    ax.set_xlabel(FX_LABEL)
    ax.set_ylabel(FY_LABEL)
    ax.set_title(title, fontsize=9)
    ax.legend(handles=[keys[phi] for phi, *_ in sets] + _cluster_guides(span), frameon=False,
              fontsize=MIN_FONT, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=1,
              title=r"colour: $\phi$ (regime shares of its clusters)",
              title_fontsize=MIN_FONT)
    return fig if fig is not None else ax.figure
