"""What every figure of bkflow shares in how it looks: the style (``STYLE``, applied only while
bkflow builds and saves a figure), figures made without pyplot (``Figures``), the markers and
colours (of the sizes, the regimes, the phi and the points' states), the smallest text, and the
words of a parameter value in a key.
"""

from __future__ import annotations

import functools
import math

#: the markers of the sizes (or of the phi) of a figure, in order
MARKERS = ("o", "s", "D", "^", "v", "P")

#: the regimes' colours of the letters in fig2a (the paper's code: black, red, green, blue;
#: W, which the paper has not, grey), always with their key
REGIME_COLOURS = {"C": "black", "W": "tab:grey", "LC": "tab:red", "DP": "tab:green",
                  "DT": "tab:blue"}

#: the regimes in words, for the keys (bkflow.observables.clusters.regime)
REGIME_WORDS = {"C": "crystalline, the whole box slips",
                "W": "the whole box slips, not crystalline",
                "LC": "laminar crystalline: whole rows",
                "DP": "disordered, longer along x",
                "DT": "disordered, longer across x"}

#: the range of phi over which ``phi_colour`` runs: one colour per phi in every figure
PHI_RANGE = (0.1, 1000.0)

#: the smallest text of any figure, in points at its saved size
MIN_FONT = 7.0

#: bkflow's figure style, applied (matplotlib.rc_context) only while bkflow builds and saves
#: a figure: the user's rcParams are never changed
STYLE = {"font.size": 9, "axes.labelsize": 9, "legend.fontsize": 7.5, "xtick.labelsize": 8,
         "ytick.labelsize": 8, "lines.markersize": 4, "figure.dpi": 100, "savefig.dpi": 200,
         "savefig.bbox": "tight"}

#: how a point's state (results.csv ``state``, docs/model.md "Steady state") is drawn: its
#: marker filled (every seed's run steady), open (some drifting), half-filled, left half (some
#: metastable: a flat stress that still remembers its start; split vertically, so that the
#: curve through the marker does not hide the split), or bottom half (switching between
#: states: the error bar covers the switching)
STATE_FILL = {"steady": "full", "switching": "bottom", "drifting": "none", "metastable": "left"}
#: the words of each state in a figure's key (every figure that marks states: bkflow plot's
#: and the reproduction's, workflows/paper)
STATE_WORDS = {"steady": "steady (every seed)",
               "switching": "switching between states (some seed)",
               "drifting": "drifting (some seed)",
               "metastable": "metastable: remembers its start (some seed)"}


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


def _style() -> Figures:
    """What a figure function takes as its ``plt``: figures made without pyplot."""
    return Figures()


def _num(v: float) -> str:
    """A parameter value for a key: three significant digits, never an exponent
    (2.15443 -> 2.15, 1000 -> 1000)."""
    text = f"{v:.3g}"
    return f"{v:.0f}" if "e+" in text else text


def _size_label(lx, ly) -> str:
    """A size for a key: "N = 100 (20x5)"."""
    return f"N = {int(lx) * int(ly)} ({int(lx)}x{int(ly)})"
