"""The figures of the observables that declare one (``bkflow.analysis.summary_keys``, an
Observable's ``figure``): its key against phi, one series per size, each point the seeds'
mean with its error and its marker by state, as the paper's figures draw theirs."""

from __future__ import annotations

from bkflow.analysis.summary_keys import keys
from bkflow.figures.data import SweepData
from bkflow.figures.legends import draw_series, state_legend
from bkflow.figures.style import size_label

#: the axis label of a declared unit
UNIT_LABELS = {"sigma_n": r"$/\sigma_n$", "stress": "(stress units)", "time": "(time units)",
               "l": "(lattice units)"}


def fig_declared(data: SweepData, plt, key: str):
    """``key`` of results.csv against phi, one series per size (None where no point holds
    it)."""
    declared = keys()[key]
    fig, ax = plt.subplots(figsize=(4.6, 3.3))
    drawn = False
    for k, (lx, ly) in enumerate(data.sizes):
        g = data.results_of(lx, ly)
        if key in g and g[key].notna().any():
            draw_series(ax, g, key, k, size_label(lx, ly))
            drawn = True
    if not drawn:
        return None
    ax.set_xscale("log")
    ax.set_xlabel(r"$\phi = k_b/\Delta k_d$")
    ax.set_ylabel(f"{key} {UNIT_LABELS.get(declared.unit, '')}".strip())
    ax.set_title(declared.meaning, fontsize=9)
    state_legend(fig, data, ax=ax)
    return fig
