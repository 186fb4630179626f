"""The errors of a run directory: one that cannot be analysed, one another process is
writing, one whose files are damaged. ``bkflow.store.rundir`` hands them on; the command line
turns each into its exit code."""

from __future__ import annotations


class AnalysisError(ValueError):
    """A run directory that cannot be analysed (nothing finished there, or damaged files)."""


class RunBusyError(RuntimeError):
    """Another process is writing this run directory now (its lock is held)."""


class DamagedRunError(ValueError):
    """A run directory whose files are not what its completion record says, or unreadable."""
