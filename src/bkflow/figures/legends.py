"""How the figures mark what they show and say it in their legends, alike in every figure
("legend", never "key": a key is a summary's): a curve against phi (one per size, told apart
by colour and line) whose markers say each point's state (``state_marker``: shape and fill),
the legend of those markers and of the regime letters, laid out below a figure's panels, and
the words naming the runs' protocol, the title of every legend.
"""

from __future__ import annotations

import pandas as pd

from bkflow.figures.data import SweepData, point_errors, point_states
from bkflow.figures.style import (
    COLUMN_WIDTH,
    MIN_FONT,
    REGIME_COLOURS,
    REGIME_NOTE,
    REGIME_WORDS,
    SIZE_LINES,
    STATE_FILL,
    STATE_WORDS,
    state_marker,
    value_label,
)


def draw_series(ax, g: pd.DataFrame, field: str, k: int, label: str):
    """The curve of the ``k``-th size against phi, in its colour and line (``SIZE_LINES``),
    with error bars, each point's marker drawn by its state (``state_marker``) over the
    curve and its bar."""
    line = ax.errorbar(g.phi, g[field], yerr=point_errors(g, field), marker="none", capsize=2,
                       lw=0.9, ls=SIZE_LINES[k % len(SIZE_LINES)], label=label, zorder=2)
    colour = line[0].get_color()
    states = point_states(g)
    for name in STATE_FILL:
        keep = states == name
        if keep.any():
            ax.plot(g.phi[keep], g[field][keep], ls="none", zorder=3,
                    **state_marker(name, colour))
    return line


def state_handles(present=tuple(STATE_FILL), colour="dimgrey") -> tuple[list, list[str]]:
    """The key of the marker convention (``state_marker``) for the states ``present``:
    the markers in ``colour`` and their words, in the convention's order."""
    from matplotlib.lines import Line2D

    shown = [name for name in STATE_FILL if name in present]
    return ([Line2D([], [], ls="none", **state_marker(name, colour)) for name in shown],
            [STATE_WORDS[name] for name in shown])


def regime_legend(regimes) -> tuple[list, list[str]]:
    """The key of the regime letters (``REGIME_COLOURS``, ``REGIME_WORDS``) for the regimes
    given: each letter as its marker, in its colour; where DP or DT is among them, what their
    f_x and f_y are (``REGIME_NOTE``) after them."""
    from matplotlib.lines import Line2D

    order = [r for r in REGIME_COLOURS if r in set(regimes)]
    handles = [Line2D([], [], ls="none", marker=rf"$\mathrm{{{r}}}$",
                      ms=7 if len(r) == 1 else 10, color=REGIME_COLOURS[r], mew=0)
               for r in order]
    words = [REGIME_WORDS[r] for r in order]
    if {"DP", "DT"} & set(order):
        handles.append(Line2D([], [], ls="none"))
        words.append(REGIME_NOTE)
    return handles, words


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
        return who + ", t_end = " + ", ".join(value_label(e) for e in ends)
    return "mixed protocols"


def state_legend(fig, data: SweepData, ax=None, extra=((), ()), states=None,
              ncol: int | None = None) -> None:
    """The figure's key, below its panels where it covers no point: the curves of ``ax`` (its
    labelled handles, e.g. one per size), on rows of their own the marker convention
    (``state_marker``) for the ``states`` shown (default: those of the sweep's points), and
    ``extra`` (handles, labels), e.g. fig2a's regime letters, on rows of their own below;
    in ``ncol`` columns (default: as many as the figure's width holds, ``legend_columns``)."""
    handles, labels = ax.get_legend_handles_labels() if ax is not None else ([], [])
    shown = set(point_states(data.results)) if states is None else set(states)
    groups = [(handles, labels), state_handles(shown), (list(extra[0]), list(extra[1]))]
    groups = [(list(h), list(w)) for h, w in groups if len(h)]
    if not groups:
        return
    # as many columns as the figure's width holds, within a column's width as saved
    ncol = ncol or legend_columns(groups, fig.get_figwidth())
    handles, labels = _in_rows(groups, ncol)
    fig.legend(handles, labels, loc="outside lower center", ncol=ncol, frameon=False,
               fontsize=MIN_FONT, handletextpad=0.3, columnspacing=1.2,
               title=protocol_label(data), title_fontsize=MIN_FONT)


def legend_columns(groups, width: float) -> int:
    """The columns of a key of ``groups`` ((handles, labels) each, laid out by ``_in_rows``)
    below a figure ``width`` inches wide: as many as its longest group has, up to 6 and one per
    1.6 in of the width, fewer while the key at ``MIN_FONT`` (``legend_width``) would make the
    figure as saved wider than ``COLUMN_WIDTH`` (less the 0.1 in that saving pads each side
    with), at least one."""
    cap = min(max(len(h) for h, _ in groups), 6, max(2, int(width // 1.6)))
    return next((n for n in range(cap, 1, -1) if legend_width(groups, n) <= COLUMN_WIDTH - 0.2),
                1)


def legend_width(groups, ncol: int, fontsize: float = MIN_FONT) -> float:
    """The width in inches of a key of ``groups`` in ``ncol`` columns (``_in_rows``), its text
    ``fontsize`` points: each column its widest label with a handle (2 em) and the gap to it
    (0.3 em), 1.2 em between columns and 0.4 em at each side (``state_legend``'s legend)."""
    from matplotlib.font_manager import FontProperties
    from matplotlib.textpath import TextToPath

    measure, font = TextToPath(), FontProperties(size=fontsize)

    def text_width(label: str) -> float:
        return max(measure.get_text_width_height_descent(line, font, ismath=line.count("$") > 1)[0]
                   for line in label.split("\n")) / 72

    labels = _in_rows(groups, ncol)[1]
    rows, em = len(labels) // ncol, fontsize / 72
    widest = [max(map(text_width, labels[c * rows:(c + 1) * rows])) for c in range(ncol)]
    return sum(widest) + ncol * 2.3 * em + (ncol - 1) * 1.2 * em + 0.8 * em


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
