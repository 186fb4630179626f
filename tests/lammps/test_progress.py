"""bkflow.lammps.progress: the size the run's and the sweep's progress lines are drawn at."""

from __future__ import annotations

import os
import pty

from bkflow.lammps.progress import terminal_size


def test_the_terminal_size_is_the_terminals_capped_where_asked(monkeypatch):
    monkeypatch.setenv("COLUMNS", "150")
    monkeypatch.setenv("LINES", "40")
    assert terminal_size() == {"ncols": 150, "nrows": 40}
    assert terminal_size(100) == {"ncols": 100, "nrows": 40}


def test_a_terminal_without_a_size_gets_80_by_24(monkeypatch):
    """A fresh pseudo-terminal reports 0x0: tqdm would draw nothing in 0 rows."""
    monkeypatch.delenv("COLUMNS", raising=False)
    monkeypatch.delenv("LINES", raising=False)
    leader, follower = pty.openpty()
    try:
        assert os.get_terminal_size(follower) == (0, 0)
        monkeypatch.setattr("sys.__stdout__", os.fdopen(follower, "w", closefd=False))
        assert terminal_size() == {"ncols": 80, "nrows": 24}
    finally:
        os.close(leader)
        os.close(follower)
