"""The catalogue of the figures ``bkflow plot`` draws: ``FIGURES`` names each figure, the
function that draws it and the summary key its runs must have recorded (a new figure is one
entry there); ``figure`` draws one of a sweep's data (``bkflow.figures.writer.plot`` writes
them all).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd

from bkflow.analysis import summary_keys as observables
from bkflow.figures.clusters import fig4a_clusters
from bkflow.figures.contacts import fig_contacts
from bkflow.figures.data import SweepData
from bkflow.figures.declared import fig_declared
from bkflow.figures.drops import fig_drops, fig_potency
from bkflow.figures.friction import fig1b_stress, fig2a_friction, fig2b_asymmetry
from bkflow.figures.order import fig3_order
from bkflow.figures.style import Figures, PlotError, style


@dataclass(frozen=True)
class FigureSpec:
    """One figure of ``bkflow plot``: its name (its files' stem), the function that draws it
    (``draw(data, plt)`` of a ``SweepData`` and a ``Figures``: a matplotlib Figure, or None
    where the data holds nothing to draw) and the runs.csv column of which at least one run
    must hold a number for it to be drawn (``needs``; None: every sweep has what it needs)."""

    name: str
    draw: Callable
    needs: str | None = None


#: every figure ``bkflow plot`` draws, by name, in the order it draws them: a new figure is one
#: FigureSpec in this list (a family, e.g. one figure per declared key, one generator of
#: FigureSpecs unpacked into it with ``*``)
FIGURES = {spec.name: spec for spec in (
    FigureSpec("fig1b_stress", fig1b_stress),
    FigureSpec("fig2a_friction", fig2a_friction),
    FigureSpec("fig2b_asymmetry", fig2b_asymmetry, needs="lx_over_ly"),
    FigureSpec("fig3_order", fig3_order, needs="psi_inf"),
    FigureSpec("fig4a_clusters", fig4a_clusters, needs="lx_over_ly"),
    FigureSpec("fig_drops", fig_drops),
    FigureSpec("fig_potency", fig_potency, needs="potency_exponent"),
    FigureSpec("fig_contacts", fig_contacts),
    # the observables that declare a figure: their key against phi
    *(FigureSpec(name, functools.partial(fig_declared, key=key), needs=key)
      for name, key in observables.figures().items()),
)}


def figure(data: SweepData, name: str):
    """The Figure ``name`` of ``FIGURES`` (or its short name: ``fig2a``, ``drops``) of a
    sweep's data, a ``matplotlib.figure.Figure`` made without pyplot; a PlotError saying why
    when the sweep did not record what it needs."""
    spec = FIGURES[_figure_name(name)]
    need = spec.needs
    if need and not np.isfinite(pd.to_numeric(data.runs.get(need), errors="coerce")).any():
        raise PlotError(f"no run recorded {need} (scene {', '.join(set(data.runs.scene))})")
    with style():
        fig = spec.draw(data, Figures())
    if fig is None:
        raise PlotError("no data")
    return fig


def _figure_name(name: str) -> str:
    """The full name in ``FIGURES`` of ``name``, or of the one figure whose first or last part
    it is (``fig2a``, ``drops``)."""
    if name in FIGURES:
        return name
    found = [f for f in FIGURES if f.split("_")[0] == name or f.split("_", 1)[-1] == name]
    if len(found) != 1:
        raise PlotError(f"no figure {name!r}; figures: {', '.join(FIGURES)} (or their first "
                        "or last part, e.g. fig2a, drops)")
    return found[0]
