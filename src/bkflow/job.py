"""One run of a sweep, done once: simulate it unless finished, analyse it unless current.

Both steps depend on their inputs alone, hold the run directory's lock, and skip what is
already there and intact, so that a sweep (locally or on a cluster) can call them again and
again: ``simulate`` runs LAMMPS only when the directory holds no intact finished run of
the spec; ``analyze`` only rewrites a summary that is missing or stale.
"""

from __future__ import annotations

from .analysis import analyze as analyze_run
from .engine import run
from .params import AnalysisSettings, RunSpec
from .rundir import RunDir


def simulated(out, spec: RunSpec | None = None) -> bool:
    """The directory holds an intact finished run (of ``spec``, when given)."""
    rd = RunDir(out)
    if rd.problem() is not None:
        return False
    if spec is None:
        return True
    requested = rd.meta().get("requested")
    return requested == spec.to_dict()


def analysed(out, spec: RunSpec, settings: AnalysisSettings) -> bool:
    """The run's summary is current for ``settings``."""
    rd = RunDir(out)
    return simulated(out, spec) and rd.analysis_problem(settings) is None


def simulate(spec: RunSpec, out, command: str | None = None, force: bool = False) -> bool:
    """Run ``spec`` into ``out`` unless it is there; True when LAMMPS ran. ``force``: above
    the cost limits too."""
    rd = RunDir(out)
    with rd.lock():
        if simulated(out, spec):
            return False
        run(spec, out, overwrite=True, progress=False, command=command, force=force)
        return True


def analyze(spec: RunSpec, out, settings: AnalysisSettings) -> dict:
    """The summary of the run in ``out`` under ``settings``: the one there if current, else
    made now from the run's files."""
    rd = RunDir(out)
    with rd.lock():
        if rd.analysis_problem(settings) is None:
            return rd.summary()
        return analyze_run(out, settings)


def run_one(spec: RunSpec, out, settings: AnalysisSettings = AnalysisSettings()) -> dict:
    """``simulate`` then ``analyze``: the summary of ``spec``'s run in ``out``."""
    simulate(spec, out)
    return analyze(spec, out, settings)
