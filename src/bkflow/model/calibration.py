"""The switching calibration: how far the mean of a window of a stiff layer wanders from the
layer's long-run mean, at the model's default parameters, for each calibrated size, phi and
window length (docs/model.md, "The stiff end's states").

It is the model's data, as the parameters' defaults are: measured on long runs
(benchmarks/measure/stiff_states.py), written to ``CALIBRATION_FILE`` (switching.json beside
this module) by ``python -m benchmarks.report.stiff_states``, read here once. The pure functions
of ``bkflow.observables.states`` ask ``switching()`` for it and read no file themselves.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from functools import lru_cache
from pathlib import Path

#: the installed calibration's file
CALIBRATION_FILE = Path(__file__).with_name("switching.json")
#: the calibration put in place of the installed one (``in_place``), in this thread or task
_PLACED: ContextVar[dict | None] = ContextVar("placed_calibration", default=None)


@lru_cache(maxsize=1)
def _installed() -> dict:
    try:
        return json.loads(CALIBRATION_FILE.read_text())
    except (OSError, ValueError):
        return {}


def switching() -> dict:
    """The calibration in force: {"sizes": {N: {"phi", "windows", "stress", "mu_bar", ...}}},
    the installed one (``CALIBRATION_FILE``; {} when absent or unreadable) unless
    ``in_place`` put another in its place."""
    placed = _PLACED.get()
    return _installed() if placed is None else placed


def reread() -> None:
    """Read ``CALIBRATION_FILE`` again at the next ``switching()`` (after it was rewritten)."""
    _installed.cache_clear()


@contextmanager
def in_place(table: dict) -> Iterator[None]:
    """Within: ``table`` is the calibration in force in this thread (a calibration being
    made, e.g. one that leaves a seed out, before any is written); other threads keep theirs."""
    token = _PLACED.set(table)
    try:
        yield
    finally:
        _PLACED.reset(token)
