"""The switching calibration: how far the mean of a window of a stiff layer wanders from the
layer's long-run mean, at the model's default parameters, for each calibrated size, phi and
window length (docs/model.md, "The stiff end's states").

It is the model's data, as the parameters' defaults are: measured on long runs
(benchmarks/measure/stiff_states.py), written to ``SWITCHING`` (switching.json beside this
module) by ``python -m benchmarks.report.stiff_states``, read here once. The pure functions
of ``bkflow.observables.states`` ask ``switching()`` for it and read no file themselves.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from contextlib import contextmanager
from functools import lru_cache
from pathlib import Path

#: the installed calibration
SWITCHING = Path(__file__).with_name("switching.json")
#: calibrations put in place of the installed one (``in_place``), the innermost last
_PLACED: list[dict] = []


@lru_cache(maxsize=1)
def _installed() -> dict:
    try:
        return json.loads(SWITCHING.read_text())
    except (OSError, ValueError):
        return {}


def switching() -> dict:
    """The calibration in force: {"sizes": {N: {"phi", "windows", "stress", "mu_bar", ...}}},
    the installed one (``SWITCHING``; {} when absent or unreadable) unless ``in_place`` put
    another in its place."""
    return _PLACED[-1] if _PLACED else _installed()


def reread() -> None:
    """Read ``SWITCHING`` again at the next ``switching()`` (after it was rewritten)."""
    _installed.cache_clear()


@contextmanager
def in_place(table: dict) -> Iterator[None]:
    """Within: ``table`` is the calibration in force (a calibration being made, e.g. one
    that leaves a seed out, before any is written)."""
    _PLACED.append(table)
    try:
        yield
    finally:
        _PLACED.pop()
