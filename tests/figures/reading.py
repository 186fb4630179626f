"""Reading a drawn figure as a reader does, for the figures' tests: its axes and legends, the
points outside their axes or under a key, the marker styles no key shows, the axes that do not
give their units, the text too small to read."""

from __future__ import annotations

import re

import numpy as np

from bkflow.figures import style

#: labels of quantities without units (pure numbers); a probability density is not one: its
#: unit is the inverse of its quantity's (``DENSITY_UNITS``)
PURE = ("phi", "mu", "Psi", "/\\sigma_n", "l_x", "l_y", "R =", "1 -")
#: what an axis label must say when it names the quantity: its unit
UNITS = {"t (": r"($\sqrt{m/k_d}$)", r"$\sigma_x$ (": "($k_d/l$)", "stress drop": "($k_d/l$)",
         "potency": "($l$)"}
#: a density axis's unit, by its panel's x quantity: the inverse of its unit (R: a pure number)
DENSITY_UNITS = {"stress drop": r"($l/k_d$)", "potency": r"($l^{-1}$)",
                 "coherence $R$": "(per unit of $R$)"}


def draw_as_saved(fig):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    with style.style():
        FigureCanvasAgg(fig).draw()
    return fig


def every_axes(fig):
    return [a for ax in fig.axes for a in (ax, *ax.child_axes)]


def figure_legends(fig):
    from matplotlib.legend import Legend

    return list(fig.legends) + [c for ax in every_axes(fig) for c in ax.get_children()
                                if isinstance(c, Legend)]


def rgb(colour):
    from matplotlib.colors import to_rgb

    return tuple(round(v, 3) for v in to_rgb(colour))


def key_colours(fig) -> set:
    """The colours of every handle drawn in the figure's keys (lines, markers, patches)."""
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    out = set()
    for leg in figure_legends(fig):
        for a in leg.findobj(Line2D):
            out |= {rgb(a.get_color()), rgb(a.get_markerfacecolor())
                    if a.get_markerfacecolor() not in ("none", "None") else None}
        for a in leg.findobj(Patch):
            if a is not leg.legendPatch:
                out.add(rgb(a.get_facecolor()))
        for a in leg.findobj(LineCollection):
            out |= {rgb(c) for c in a.get_colors()}
    return out - {None}


def data_lines(ax):
    """The lines of ``ax`` that draw data: visible, with points."""
    return [ln for ln in ax.get_lines() if ln.get_visible() and len(ln.get_xydata())]


def outside_or_hidden(fig) -> list[str]:
    """Every drawn point (of lines with or without markers, error bars too) outside its axes,
    and every marker under a key or an inset."""
    from matplotlib.collections import LineCollection

    r = fig.canvas.get_renderer()
    keys = [k.get_window_extent(r) for k in figure_legends(fig)]
    bad = []
    for ax in every_axes(fig):
        if not ax.get_visible() or not ax.axison:
            continue
        box = ax.get_window_extent(r).expanded(1.01, 1.01)
        over = keys + [inset.get_window_extent(r) for inset in ax.child_axes]
        for ln in data_lines(ax):
            pts = ln.get_transform().transform(ln.get_xydata())
            pts = pts[np.isfinite(pts).all(axis=1)]
            marked = ln.get_marker() not in (None, "", "None", "none")
            for x, y in pts:
                if not box.contains(x, y):
                    bad.append(f"{ax.get_title() or ax.get_ylabel()}: {ln.get_label()} at "
                               f"({x:.0f}, {y:.0f}) outside its axes")
                elif marked and any(b.contains(x, y) for b in over):
                    bad.append(f"{ax.get_title() or ax.get_ylabel()}: {ln.get_label()} under a "
                               "key")
        for coll in ax.collections:
            if isinstance(coll, LineCollection) and coll.get_visible():  # error bars
                for seg in coll.get_segments():
                    for x, y in ax.transData.transform(seg):
                        if np.isfinite([x, y]).all() and not box.contains(x, y):
                            bad.append(f"{ax.get_ylabel()}: an error bar outside its axes")
    return bad


def marked_lines(lines) -> list:
    """The lines of ``lines`` that draw markers, an error bar's caps left out."""
    return [ln for ln in lines if str(ln.get_marker()) not in ("", "None", "none", " ", "_")]


def marker_styles(lines) -> set:
    """(marker, fill) of each line of ``lines`` that draws markers (not an error bar's caps)."""
    return {(str(ln.get_marker()), ln.get_fillstyle()) for ln in marked_lines(lines)}


def unkeyed_styles(fig) -> list:
    """The marker styles (shape, fill) drawn on a panel of ``fig`` (markers of 4 pt or more:
    not a scatter's dots) that no key of the figure shows, with their panel's title."""
    from matplotlib.lines import Line2D

    keyed = marker_styles(h for leg in figure_legends(fig) for h in leg.findobj(Line2D))
    bad = []
    for ax in every_axes(fig):
        drawn = marker_styles(ln for ln in data_lines(ax) if ln.get_transform() is ax.transData
                               and ln.get_markersize() >= 4)
        bad += [(ax.get_title(), style_) for style_ in drawn - keyed]
    return bad


def laws_and_title(fig) -> tuple[int, int, list[str]]:
    """A density figure's (fig_drops, fig_potency) laws: how many (a) draws, how many its title
    says are drawn (checked against the number of phi it names), and its key's words
    (checked: as many give an exponent as laws are drawn)."""
    ax = fig.axes[0]
    m = re.search(r"(\d+) of (\d+) phi", ax.get_title())
    assert m, ax.get_title()
    laws = [ln for ln in data_lines(ax) if str(ln.get_marker()) in ("None", "none", "")]
    keys = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    assert int(m.group(1)) == len(laws) == sum(r"$\alpha$" in k for k in keys), keys
    assert int(m.group(2)) == sum(k.startswith(r"$\phi$") for k in keys)
    return len(laws), int(m.group(2)), keys


def unit_problems(fig) -> list[str]:
    """Every axis of ``fig`` that draws data and does not say what it shows in its unit: no
    label, a label with neither a unit nor a pure number's name (``PURE``), a quantity
    without its unit (``UNITS``), or a probability density without the inverse of its
    quantity's unit (``DENSITY_UNITS``, the quantity named by its panel's x axis)."""
    bad = []
    for ax in every_axes(fig):
        if not ax.get_visible() or not ax.axison or not data_lines(ax):
            continue
        # a panel stacked on another with the same axis shares that axis' label
        xs = [a.get_xlabel() for a in ax.get_shared_x_axes().get_siblings(ax)]
        ys = [a.get_ylabel() for a in ax.get_shared_y_axes().get_siblings(ax)]
        x, y = max(xs, key=len), max(ys, key=len)
        for label in (x, y):
            if not label:
                bad.append("an axis without a label")
            elif "density" in label:
                bad += density_problems(label, x)
            elif not ("(" in label or any(w in label for w in PURE)):
                bad.append(f"{label!r}: no unit")
            else:
                bad += [f"{label!r} lacks its unit {unit}" for quantity, unit in UNITS.items()
                        if quantity in label and "/\\sigma_n" not in label and unit not in label]
    return bad


def density_problems(label: str, x: str) -> list[str]:
    """Why a probability density's axis ``label`` (of a panel whose x axis says ``x``) does
    not give its unit, the inverse of its quantity's (none: it does)."""
    units = [unit for quantity, unit in DENSITY_UNITS.items() if quantity in x]
    if not units:
        return [f"{label!r}: a density of {x!r}, whose unit no check knows"]
    return [] if units[0] in label else [f"{label!r}: a density without its unit {units[0]}"]


def small_text(fig, least: float = style.MIN_FONT) -> list:
    """The visible text of ``fig`` under ``least`` points (at its saved size): (text, size)."""
    from matplotlib.text import Text

    return [(t.get_text(), t.get_fontsize()) for t in fig.findobj(Text)
            if t.get_visible() and t.get_text().strip() and t.get_fontsize() < least - 1e-9]


def hidden_points(fig) -> list[str]:
    """The data points of a figure that a reader cannot see: outside their axes, or under a
    key (a legend of the axes or of the figure) or an inset."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.collections import PathCollection
    from matplotlib.legend import Legend

    FigureCanvasAgg(fig).draw()
    r = fig.canvas.get_renderer()
    keys = [k.get_window_extent(r) for k in fig.legends]
    keys += [c.get_window_extent(r) for ax in fig.axes for c in ax.get_children()
             if isinstance(c, Legend)]
    hidden = []
    for i, ax in enumerate(fig.axes):
        box = ax.get_window_extent(r).expanded(1.02, 1.02)
        over = keys + [inset.get_window_extent(r) for inset in ax.child_axes]
        sets = [(line.get_label(), line.get_transform().transform(line.get_xydata()))
                for line in ax.get_lines() if line.get_marker() not in (None, "", "None", "none")]
        sets += [(c.get_label(), c.get_offset_transform().transform(c.get_offsets()))
                 for c in ax.collections if isinstance(c, PathCollection)]
        for label, pts in sets:
            for x, y in pts[np.isfinite(pts).all(axis=1)]:
                if not box.contains(x, y) or any(b.contains(x, y) for b in over):
                    hidden.append(f"axes {i} ({ax.get_title() or ax.get_ylabel()}): {label} "
                                  f"at ({x:.0f}, {y:.0f})")
    return hidden


def text_outside(fig) -> list[str]:
    """What of ``fig`` (drawn as saved) reaches past the figure's edge, where an image saved
    at the figure's size (not trimmed to its content, as ``bkflow plot`` saves) cuts it: each
    axes (its titles, labels and tick labels as drawn) and each legend and text of the figure,
    by its title or label."""
    from matplotlib.legend import Legend

    r = fig.canvas.get_renderer()
    box = fig.bbox.padded(2 * fig.dpi / 72)   # within 2 pt: a glyph's margin, not a cut
    parts = [(ax.get_title() or ax.get_ylabel(), ax.get_tightbbox(r)) for ax in fig.axes
             if ax.get_visible()]
    parts += [("a legend", c.get_window_extent(r)) for c in fig.get_children()
              if isinstance(c, Legend)]
    parts += [(t.get_text(), t.get_window_extent(r)) for t in fig.texts if t.get_text()]
    return [name for name, b in parts
            if b is not None and not (box.contains(b.x0, b.y0) and box.contains(b.x1, b.y1))]
