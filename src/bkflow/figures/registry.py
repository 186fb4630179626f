"""The documented path (docs/api.md) of the figures' catalogue and ``bkflow plot``'s writer,
kept for code written against it: the names live in ``bkflow.figures.catalogue`` and
``bkflow.figures.writer``; import them from there."""

from bkflow.figures.catalogue import FIGURES, FigureSpec, figure  # noqa: F401
from bkflow.figures.writer import FORMATS, plot, save_figure  # noqa: F401
