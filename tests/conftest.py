"""Fixtures and markers of the test suite.

Tests that need the compiled plugin and LAMMPS are marked ``lammps`` (a module that runs LAMMPS
sets ``pytestmark = pytest.mark.lammps``); ``pytest -m "not lammps"`` runs the pure ones (analysis,
parameters, decks as text, tables) on a machine without the wheel.
"""

from __future__ import annotations

import pytest


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    """A fresh working directory (LAMMPS writes log files into the current one)."""
    monkeypatch.chdir(tmp_path)
    return tmp_path
