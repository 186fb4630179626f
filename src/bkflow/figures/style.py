"""What every figure of bkflow shares in how it looks: the style (``STYLE``, applied only while
bkflow builds and saves a figure), figures made without pyplot (``Figures``), the lines of the
sizes, the colours of the regimes and the phi, the markers of the points' states, the ticks of a
short log axis, the smallest text, and the words of a parameter value in a key.
"""

from __future__ import annotations

import functools
import math

#: the lines of the sizes of a figure, in order, each with its colour (matplotlib's cycle):
#: solid, dashed, dotted, dash-dotted, ...; a curve's markers say its points' states
#: (``state_marker``), so that the sizes are told apart by colour and line, never by marker
SIZE_LINES = ("-", (0, (5, 2)), (0, (1.2, 1.4)), (0, (6, 1.6, 1.2, 1.6)), (0, (10, 2.5)),
              (0, (2.5, 2.5)))

#: the regimes' colours of the letters in fig2a (the paper's code: black, red, green, blue;
#: W, which the paper has not, grey), always with their key
REGIME_COLOURS = {"C": "black", "W": "tab:grey", "LC": "tab:red", "DP": "tab:green",
                  "DT": "tab:blue"}

#: the regimes in words, for the keys (bkflow.observables.clusters.regime)
REGIME_WORDS = {"C": "crystalline, the whole box slips",
                "W": "the whole box slips, not crystalline",
                "LC": "laminar crystalline: whole rows",
                "DP": "disordered: x not spanned, f_x >= f_y",
                "DT": "disordered: x not spanned, f_x < f_y"}
#: what f_x, f_y of ``REGIME_WORDS`` are (docs/model.md "Slip clusters"), keyed beside DP or DT
REGIME_NOTE = "f_x, f_y: a cluster's extents over a whole-box slip's"

#: the range of phi over which ``phi_colour`` runs: one colour per phi in every figure
PHI_RANGE = (0.1, 1000.0)

#: the smallest text of any figure, in points at its saved size
MIN_FONT = 7.0
#: the widest any figure is as saved (inches, trimmed): a 6.5-7 in column prints it at its own
#: size or larger, so that its text is never under ``MIN_FONT`` in print
COLUMN_WIDTH = 7.0

#: bkflow's figure style, applied (matplotlib.rc_context) only while bkflow builds and saves
#: a figure: the user's rcParams are never changed
STYLE = {"font.size": 9, "axes.labelsize": 9, "legend.fontsize": 7.5, "xtick.labelsize": 8,
         "ytick.labelsize": 8, "lines.markersize": 4, "figure.dpi": 100, "savefig.dpi": 200,
         "savefig.bbox": "tight"}

#: how a point's state (results.csv ``state``, docs/model.md "Steady state") is drawn: by its
#: marker's shape (``STATE_MARKER``) and fill (``STATE_FILL``), told apart by the shape alone
#: at print size: a filled circle (every seed's run steady), an open circle (some drifting), a
#: square filled below (switching between states: the error bar covers the switching) or a
#: diamond filled on the left (some metastable: a flat stress that still remembers its start;
#: split vertically, so that the curve through the marker does not hide the split). One
#: convention for every figure that marks states (bkflow plot's and the reproduction's,
#: workflows/paper), drawn by ``state_marker`` and keyed by ``legends.state_handles``
STATE_FILL = {"steady": "full", "switching": "bottom", "drifting": "none", "metastable": "left"}
STATE_MARKER = {"steady": "o", "switching": "s", "drifting": "o", "metastable": "D"}
#: the words of each state in a figure's key (every figure that marks states: bkflow plot's
#: and the reproduction's, workflows/paper)
STATE_WORDS = {"steady": "steady (every seed)",
               "switching": "switching between states (some seed)",
               "drifting": "drifting (some seed)",
               "metastable": "metastable: remembers its start (some seed)"}
#: a state marker's size (points, a circle's; squares and diamonds a little smaller, so that
#: the shapes look alike in size) and edge width (points) on a curve against phi
STATE_SIZE, STATE_EDGE = 6.5, 1.0
_SHAPE_SCALE = {"o": 1.0, "s": 0.85, "D": 0.78}


def state_marker(state: str, colour, size: float = STATE_SIZE) -> dict:
    """The keywords of ``Axes.plot`` (or of a ``Line2D``) that draw a point of ``state`` (a
    ``STATE_FILL`` name; any other as drifting) in ``colour``: its shape, fill, size and edge;
    the edge width scales with ``size``."""
    state = state if state in STATE_FILL else "drifting"
    fill, shape = STATE_FILL[state], STATE_MARKER[state]
    return {"marker": shape, "ms": size * _SHAPE_SCALE.get(shape, 1.0),
            "mew": STATE_EDGE * min(1.0, size / STATE_SIZE), "color": colour, "mec": colour,
            "fillstyle": fill, "mfc": colour if fill != "none" else "white", "mfcalt": "white"}


def phi_colour(phi: float):
    """The colour of a phi where a figure draws a few phi as sets (fig4a, fig_drops,
    fig_potency): plasma over log10 phi in ``PHI_RANGE``, the stiff end dark, cut at 0.85
    (the yellow end is not seen on white; viridis would make 0.1 and 2.15 two greens that
    a translucent scatter cannot tell apart). A sequential map, the same for a phi in every
    figure, whose hues cannot be read as the paper's regime code (black C, red LC, green DP,
    blue DT: its Fig. 4a draws regimes, not phi)."""
    from matplotlib import colormaps

    lo, hi = (math.log10(v) for v in PHI_RANGE)
    frac = min(1.0, max(0.0, (math.log10(phi) - lo) / (hi - lo)))
    return colormaps["plasma"](0.85 * (1.0 - frac))


def plain_log_ticks(axis, lo: float, hi: float) -> None:
    """Ticks a reader can read on a log ``axis`` (``ax.xaxis``) spanning ``lo`` to ``hi``,
    never overlapping labels such as ``1.2 x 10^-2`` side by side: over a decade or less a few
    evenly spaced round values, over two decades or less 1, 2 and 5 times the powers of ten,
    both labelled as plain numbers (0.0125, 20), minor ticks unlabelled; over more, matplotlib's
    powers of ten, as they are."""
    from matplotlib.ticker import FuncFormatter, LogLocator, MaxNLocator, NullFormatter

    lo, hi = sorted((float(lo), float(hi)))
    span = math.log10(hi / lo) if lo > 0 and hi > lo else 0.0
    if span > 2.0:
        return
    axis.set_major_locator(MaxNLocator(nbins=4, steps=[1, 2, 2.5, 5, 10]) if span <= 1.0
                           else LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:.6g}"))
    axis.set_minor_formatter(NullFormatter())


class PlotError(ValueError):
    """The directory holds nothing to plot."""


class Figures:
    """What the figure functions need of pyplot, without pyplot's state: every figure is a
    ``matplotlib.figure.Figure`` of its own, never registered with pyplot, so that making one
    neither switches the backend nor touches (or closes) a user's open figures. A notebook
    shows the Figure it is given; files are written with ``Figure.savefig``."""

    def subplots(self, nrows=1, ncols=1, figsize=None, layout="constrained", **kw):
        fig = self.figure(figsize=figsize, layout=layout)
        return fig, fig.subplots(nrows, ncols, **kw)

    def figure(self, figsize=None, layout="constrained", **kw):
        """A Figure with a layout engine (constrained by default), so that it keeps its
        labels inside however it is saved: a plain ``savefig()`` cuts nothing off."""
        return _figure_class()(figsize=figsize, layout=layout, **kw)

    def close(self, fig=None):
        """Nothing to close: no figure is registered with pyplot."""


@functools.cache
def _figure_class():
    from matplotlib.figure import Figure

    class BkFigure(Figure):
        """A Figure that a notebook shows as a PNG even where pyplot (and with it the inline
        backend's display hook) was never imported."""

        def _repr_png_(self):
            import io as _io

            buf = _io.BytesIO()
            with style():
                self.savefig(buf, format="png", dpi=100, bbox_inches="tight")
            return buf.getvalue()

    return BkFigure


def style():
    """The context in which bkflow builds (and saves) its figures: ``STYLE``."""
    import matplotlib

    return matplotlib.rc_context(STYLE)


def new_figures() -> Figures:
    """What a figure function takes as its ``plt``: figures made without pyplot."""
    return Figures()


def value_label(v: float) -> str:
    """A parameter value for a key: three significant digits, never an exponent
    (2.15443 -> 2.15, 1000 -> 1000)."""
    text = f"{v:.3g}"
    return f"{v:.0f}" if "e+" in text else text


def size_label(lx, ly) -> str:
    """A size for a key: "N = 100 (20x5)"."""
    return f"N = {int(lx) * int(ly)} ({int(lx)}x{int(ly)})"
