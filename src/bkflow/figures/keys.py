"""How the figures mark and key what they show, alike in every figure: a curve against phi whose
markers say each point's state (``STATE_FILL``), the key of those markers and of the regime
letters, laid out below a figure's panels, and the words naming the runs' protocol, the title of
every key.
"""

from __future__ import annotations

import pandas as pd

from bkflow.figures.data import SweepData, _errors, _point_states
from bkflow.figures.style import (
    MIN_FONT,
    REGIME_COLOURS,
    REGIME_WORDS,
    STATE_FILL,
    STATE_WORDS,
    _num,
)


def _series(ax, g: pd.DataFrame, field: str, marker: str, label: str):
    """One curve against phi with error bars, each point's marker drawn by its state
    (``STATE_FILL``)."""
    line = ax.errorbar(g.phi, g[field], yerr=_errors(g, field), marker="none", capsize=2,
                       lw=0.8, label=label)
    colour = line[0].get_color()
    states = _point_states(g)
    for name, fill in STATE_FILL.items():
        k = states == name
        if k.any():
            ax.plot(g.phi[k], g[field][k], marker, color=colour, ls="none", ms=5,
                    fillstyle=fill, mfc=colour if fill != "none" else "white",
                    mfcalt="white")
    return line


def state_handles(present=tuple(STATE_FILL)) -> tuple[list, list[str]]:
    """The key of the marker convention (``STATE_FILL``) for the states ``present``:
    grey markers and their words, in the convention's order."""
    from matplotlib.lines import Line2D

    shown = [(name, fill) for name, fill in STATE_FILL.items() if name in present]
    return ([Line2D([], [], marker="o", ls="none", color="grey", fillstyle=fill,
                    mfc="grey" if fill != "none" else "white", mfcalt="white")
             for _, fill in shown], [STATE_WORDS[name] for name, _ in shown])


def regime_key(regimes) -> tuple[list, list[str]]:
    """The key of the regime letters (``REGIME_COLOURS``, ``REGIME_WORDS``) for the regimes
    given: each letter as its marker, in its colour."""
    from matplotlib.lines import Line2D

    order = [r for r in REGIME_COLOURS if r in set(regimes)]
    handles = [Line2D([], [], ls="none", marker=rf"$\mathrm{{{r}}}$",
                      ms=7 if len(r) == 1 else 10, color=REGIME_COLOURS[r], mew=0)
               for r in order]
    return handles, [REGIME_WORDS[r] for r in order]


def protocol_label(data: SweepData) -> str:
    """What the figure's runs are, in words, from what the sweep recorded of them (runs.csv
    ``start``, ``companion``, ``until_steady``, ``t_end``): "steady protocol" only for the
    steady protocol's own start and companion (params.STEADY_START beside
    STEADY_COMPANION, until steady); any other start run until steady says so
    ("synchronized start until steady, partial companion"); a fixed length names its start
    and lengths ("paper's protocol, t_end = 1000": the synchronized start); else the
    mixture."""
    from bkflow.model.params import STEADY_COMPANION, STEADY_START

    r = data.runs

    def recorded(column) -> pd.Series:
        """Each run's value of ``column`` as text, "" where none was recorded."""
        if column not in r:
            return pd.Series("", index=r.index)
        v = r[column].astype(str).where(r[column].notna(), "")
        return v.where(~v.str.lower().isin(("none", "nan")), "")

    steady = recorded("until_steady").str.lower().isin(("true", "1", "1.0"))
    start, companion = recorded("start"), recorded("companion")
    starts, companions = set(start) - {""}, set(companion) - {""}
    start_words = "/".join(sorted(starts)) + " start" if starts else "runs"
    companion_words = ", " + "/".join(sorted(companions)) + " companion" if companions else ""
    if steady.all():
        if (start == STEADY_START).all() and (companion == STEADY_COMPANION).all():
            return "steady protocol"
        return start_words + " until steady" + companion_words
    if not steady.any() and "t_end" in r:
        ends = sorted(set(pd.to_numeric(r["t_end"], errors="coerce").dropna()))
        who = "paper's protocol" if starts == {"synchronized"} and not companions else \
            "fixed length, " + start_words + companion_words
        return who + ", t_end = " + ", ".join(_num(e) for e in ends)
    return "mixed protocols"


def state_key(fig, data: SweepData, ax=None, extra=((), ())) -> None:
    """The figure's key, below its panels where it covers no point: the curves of ``ax`` (its
    labelled handles, e.g. one per size) and the marker convention (``STATE_FILL``) for
    the states present in the figure's points (grey markers); ``extra`` (handles, labels),
    e.g. fig2a's regime letters, on rows of their own below."""
    handles, labels = ax.get_legend_handles_labels() if ax is not None else ([], [])
    more, words = state_handles(set(_point_states(data.results)))
    groups = [(handles + more, labels + words), (list(extra[0]), list(extra[1]))]
    groups = [g for g in groups if g[0]]
    if not groups:
        return
    # as many columns as the figure's width holds (a key wider than the figure squeezes it)
    ncol = min(max(len(h) for h, _ in groups), 6, max(2, int(fig.get_figwidth() // 1.6)))
    handles, labels = _in_rows(groups, ncol)
    fig.legend(handles, labels, loc="outside lower center", ncol=ncol, frameon=False,
               fontsize=MIN_FONT, handletextpad=0.3, columnspacing=1.2,
               title=protocol_label(data), title_fontsize=MIN_FONT)


def _in_rows(groups, ncol: int) -> tuple[list, list[str]]:
    """(handles, labels) of several groups in the order that a legend of ``ncol`` columns
    (which fills column by column) shows as rows, each group starting a row of its own
    (blank entries fill a group's last row)."""
    from matplotlib.lines import Line2D

    rows = []
    for handles, labels in groups:
        entries = list(zip(handles, labels))
        entries += [(Line2D([], [], ls="none"), "")] * (-len(entries) % ncol)
        rows += [entries[i:i + ncol] for i in range(0, len(entries), ncol)]
    ordered = [row[c] for c in range(ncol) for row in rows]
    return [h for h, _ in ordered], [label for _, label in ordered]
