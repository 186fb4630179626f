"""The memory of the start, run by run (``fig_contacts``): the shear stress and the contacts'
phase coherence R(t) over the whole run of a soft, an intermediate and a stiff phi, a row per
run (its stress beside its R, on the run's time axis), smoothed alike in every panel, the
analysed window shaded by the run's state: steady (green), switching between the layer's
steady states (green, hatched: a coherent or quiet window is one of them, its stress
trend-free) or neither (orange: drifting, metastable, or states named while the stress still
drifts), each row's title giving the state and the trend test as the run's summary does.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from bkflow.figures.data import SweepData, nearest_log, point_states
from bkflow.figures.legends import protocol_label
from bkflow.figures.style import COLUMN_WIDTH, MIN_FONT, size_label, value_label

#: fig_contacts' width and the height of a run's row (inches)
CONTACTS_WIDTH, CONTACTS_ROW = COLUMN_WIDTH - 0.2, 2.15


def _smooth(t, x, width: float):
    """x averaged over consecutive windows of ``width`` time units: (centres, means)."""
    t, x = np.asarray(t, float), np.asarray(x, float)
    if len(t) < 2 or width <= 0:
        return t, x
    k = ((t - t[0]) // width).astype(int)
    n = np.bincount(k)
    keep = n > 0
    if keep.sum() > 1 and t[-1] - (t[0] + k[-1] * width) < 0.5 * width:
        keep[k[-1]] = False  # a last window under half the width: an edge artefact
    return (np.bincount(k, t)[keep] / n[keep], np.bincount(k, x)[keep] / n[keep])


def _contact_phis(phis) -> list[float]:
    """A soft, an intermediate and a stiff phi of those swept: the softest, the stiffest,
    and the one nearest their geometric mean (0.1, 10, 1000 on the default grid; all three
    of a sweep of three phi, such as 10, 100, 1000, where fixed targets would leave its middle
    one out), each once."""
    phis = sorted(set(float(p) for p in phis))
    middle = nearest_log(phis, math.sqrt(phis[0] * phis[-1]))
    return list(dict.fromkeys([phis[0], middle, phis[-1]]))


def _window(shortest: float, block: float) -> float:
    """The smoothing window of fig_contacts, in time units: the largest 1, 2 or 5 times a
    power of ten at most a twentieth of the shortest run shown, or, where that is shorter than
    one block of the records, the smallest such number at least one block: one window for
    every panel, so that their curves are smoothed alike."""
    decade = math.floor(math.log10(max(shortest / 20.0, 1e-12)))
    steps = [m * 10.0 ** e for e in range(decade - 1, decade + 12) for m in (1.0, 2.0, 5.0)]
    below = [w for w in steps if w <= shortest / 20.0 * (1 + 1e-9)]
    if below and below[-1] >= block * (1 - 1e-9):
        return below[-1]
    return min(w for w in steps if w >= block * (1 - 1e-9))



def fig_contacts(data: SweepData, plt):
    """The memory of the start, run by run: sigma_x(t)/sigma_n and the contacts' phase
    coherence R(t) (docs/model.md "Contact phase") over the whole run, for a soft, an
    intermediate and a stiff phi of the smallest size (``_contact_phis``; seed 1, or the
    first). The dark curves are means over one window of time (``_window``, the same in every
    panel and said in the key: a window of a fixed share of each run would make runs of
    different lengths look alike when they are not smoothed alike); the light curve is R's
    block means as recorded. The analysed window (from the end of the transient) is shaded by
    the run's state (``SHADES``, ``_shade``: steady; switching between the layer's steady
    states, quiet and coherent, each a steady state of its own; or neither, drifting or
    metastable, or a switching run whose stress still drifts), its state and trend test in
    the row's title (``_trend_words``), keyed below. A row per run, its stress beside its R
    on one time axis (``_contact_rows``), so that the figure fits a 7 in column."""
    lx, ly = data.sizes[0]
    chosen = _contact_phis(data.runs_of(lx, ly).phi)
    fig, axes = _contact_rows(plt, len(chosen))
    panels = _contact_records(data, axes, (lx, ly), chosen)
    if not panels:
        return None
    block = max(b for *_, b in panels)   # the records' block, in time units
    width = _window(min(t[-1] - t[0] for _, _, _, t, _, _, _ in panels), block)
    shown = {_contact_panel(axes[j, 0], axes[j, 1], (lx, ly), panel, width)
             for j, *panel in panels}
    for stress, coherence in axes:  # every panel: the stresses' ranges differ
        stress.set_ylabel(r"$\sigma_x/\sigma_n$")
        coherence.set_ylabel(r"$R = |\langle e^{2\pi i u}\rangle|$")
    _contact_key(fig, data, width, block, shown)
    fig.suptitle("The start's memory: the stress and the contacts' phase coherence",
                 fontsize=9)
    return fig


def _contact_rows(plt, n: int):
    """fig_contacts' figure and its panels, ``axes[j]`` = (stress, R) of the ``j``-th run: a
    row per run (a subfigure, its title the run's), the stress beside R on one time axis
    (shared: the same run), ``CONTACTS_WIDTH`` wide."""
    fig = plt.figure(figsize=(CONTACTS_WIDTH, CONTACTS_ROW * n + 0.9))
    rows = fig.subfigures(n, 1, squeeze=False)[:, 0]
    return fig, np.array([row.subplots(1, 2, sharex=True) for row in rows])


def _contact_records(data: SweepData, axes, size, chosen) -> list[tuple]:
    """[(row, phi, runs.csv row, t, sigma_x, phase series, block in time units)] of the
    first seed of each phi ``chosen`` at ``size`` whose run recorded its phase series; the
    stress panel of a run that did not says so."""
    panels = []
    for j, phi in enumerate(chosen):
        row = data.runs_of(*size, phi).iloc[0]
        rd = data.run_dir(row)
        spec = rd.spec()
        red = rd.read_reduced(spec)
        phase = rd.phase_series(spec, red)
        if phase is None:
            axes[j, 0].text(0.5, 0.5, "no phase series\n(run made before bkflow recorded it)",
                            transform=axes[j, 0].transAxes, ha="center", va="center",
                            fontsize=MIN_FONT)
            continue
        t, sigma, _ = red.series()    # block means
        panels.append((j, phi, row, t, sigma, phase, red.block * spec.dt))
    return panels


#: the shading of fig_contacts' analysed window by the run's state (``_shade``): its colour,
#: hatch and words in the key. A switching run's window (quiet, coherent or both) whose stress
#: is trend-free is in the layer's steady states, one or both of them: shaded as steady,
#: hatched, keyed apart; one whose stress still drifts is not steady
SHADES = {"steady": ("tab:green", None, "analysed window (after the transient): steady"),
          "switching": ("tab:green", "//", "analysed window: switching between the layer's "
                        "steady states\n(quiet, coherent), trend-free"),
          "other": ("tab:orange", None, "analysed window: not steady (drifting, metastable,\n"
                    "or states named while the stress still drifts)")}


def _shading(colour, hatch, alpha: float) -> dict:
    """The colours of a shaded window: filled light (``alpha``), its hatch (if any) darker."""
    from matplotlib.colors import to_rgba

    return {"facecolor": to_rgba(colour, alpha), "hatch": hatch,
            "edgecolor": to_rgba(colour, 0.45) if hatch else "none"}


def _shade(state, stationary=None) -> str:
    """The ``SHADES`` name of a run's state (runs.csv ``state``) and trend test
    (``stationary``: the summary's "the stress is trend-free over the window", the test its
    verdict reads, with an error that covers the switching; None where not recorded). The
    verdict names the states a window visited ahead of its trend (docs/model.md "Steady
    state"): such a window whose stress the same test finds still drifting is shaded as not
    steady, never as one of the layer's steady states."""
    name = str(point_states(pd.DataFrame({"state": [state]}))[0])
    if name == "switching" and _flag(stationary) is False:
        return "other"
    return name if name in SHADES else "other"


def _flag(value) -> bool | None:
    """A runs.csv boolean (True, False, "True", "False"), None where missing."""
    if isinstance(value, str):
        return {"true": True, "false": False}.get(value.strip().lower())
    return None if value is None or pd.isna(value) else bool(value)


def _trend_words(row) -> str:
    """The trend test of a run as its summary gives it (runs.csv ``drift``, ``drift_err``,
    ``stationary``: of the pair's mean stress where the run has a companion, as its verdict
    reads it), for its panel's title: "drift -0.86% ± 4.68%: trend-free" ("pair's drift ..."),
    or "...: the stress still drifts"; "" where the run recorded none."""
    drift, err = (pd.to_numeric(row.get(k), errors="coerce") for k in ("drift", "drift_err"))
    flag = _flag(row.get("stationary"))
    if flag is None or not (np.isfinite(drift) and np.isfinite(err)):
        return ""
    pair = isinstance(row.get("companion_start"), str) and row.get("companion_start")
    return (("pair's drift" if pair else "drift")
            + rf" {100 * drift:+.2f}% $\pm$ {100 * err:.2f}%: "
            + ("trend-free" if flag else "the stress still drifts"))


def _contact_panel(stress, coherence, size, panel, width: float) -> str:
    """One run's row of fig_contacts (``panel``: phi, runs.csv row, t, sigma_x, phase
    series, block): sigma_x/sigma_n (``stress``) beside R (``coherence``), each smoothed over
    ``width`` time units, the analysed window shaded by its state (``SHADES``), the run and
    its trend test the row's title; the shade's name."""
    from matplotlib.ticker import MaxNLocator

    phi, row, t, sigma, phase, _ = panel
    ts, ss = _smooth(t, sigma / (row.sigma_n * getattr(row, "area", 1.0)), width)
    stress.plot(ts, ss, color="black", lw=0.8)
    coherence.plot(phase["t"], phase["R"], color="plum", lw=0.3, alpha=0.6)
    tr, rr = _smooth(phase["t"], phase["R"], width)
    coherence.plot(tr, rr, color="indigo", lw=1.2)
    t0 = float(row.t_transient) if "t_transient" in row and pd.notna(row.t_transient) \
        else t[0]
    shade = _shade(row.get("state"), row.get("stationary"))
    colour, hatch, _ = SHADES[shade]
    for ax in (stress, coherence):
        ax.axvspan(t0, t[-1], lw=0, **_shading(colour, hatch, 0.12))
    trend = _trend_words(row)
    stress.get_figure(root=False).suptitle(
        rf"$\phi$ = {value_label(phi)}, {size_label(*size)}, seed {int(row.seed)}: "
        f"{row.get('state', 'n/a')}" + (f"\n{trend}" if trend else ""), fontsize=MIN_FONT + 0.5)
    coherence.set_ylim(0, 1.02)
    for ax in (stress, coherence):
        ax.set_xlabel(r"t ($\sqrt{m/k_d}$)")
        ax.xaxis.set_major_locator(MaxNLocator(nbins=4, steps=[1, 2, 2.5, 5, 10]))
    return shade


def _contact_key(fig, data: SweepData, width: float, block: float, shown) -> None:
    """fig_contacts' key, below its panels: the curves, with the smoothing window and the
    records' block, and beside them the shading of the analysed window of the states
    ``shown`` (names of ``SHADES``)."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles = [Line2D([], [], color="black", lw=0.8), Line2D([], [], color="indigo", lw=1.2),
               Line2D([], [], color="plum", lw=0.8)]
    labels = [rf"$\sigma_x/\sigma_n$, mean over {width:g} time units",
              f"R, mean over {width:g} time units",
              f"R, block means ({block:.3g} time units)"]
    for name, (colour, hatch, words) in SHADES.items():
        if name in shown:
            handles.append(Patch(lw=0, **_shading(colour, hatch, 0.25)))
            labels.append(words)
    # two columns, the curves in the first and the shadings in the second (blanks fill it)
    handles += [Line2D([], [], ls="none")] * (6 - len(handles))
    labels += [""] * (6 - len(labels))
    fig.legend(handles, labels, loc="outside lower center", ncol=2, frameon=False,
               fontsize=MIN_FONT, handlelength=1.8, columnspacing=1.2,
               title=protocol_label(data), title_fontsize=MIN_FONT)
