"""One run of a sweep, done once: simulate it unless finished, analyse it unless current.

Both steps depend on their inputs alone, hold the run directory's lock, and skip what is
already there and intact, so that a sweep (locally or on a cluster) can call them again and
again: ``simulate`` runs LAMMPS only when the directory holds no intact finished run of
the spec; ``analyze`` only rewrites a summary that is missing or stale.
"""

from __future__ import annotations

from bkflow.analysis.summary import analyze as analyze_run
from bkflow.lammps.engine import run
from bkflow.model.params import RunSpec
from bkflow.model.settings import AnalysisSettings
from bkflow.store.rundir import RunDir


def simulated(out, spec: RunSpec | None = None) -> bool:
    """The directory holds an intact finished run (of ``spec``, when given)."""
    rd = RunDir(out)
    if rd.problem() is not None:
        return False
    if spec is None:
        return True
    from bkflow.lammps.continuation import answers

    # the same request, or a run that stopped by its rule before this request's longer cap
    return answers(rd, spec)


def analysed(out, spec: RunSpec, settings: AnalysisSettings) -> bool:
    """The run's summary is current for ``settings``."""
    rd = RunDir(out)
    return simulated(out, spec) and rd.analysis_problem(settings) is None


def simulate(spec: RunSpec, out, command: str | None = None, force: bool = False) -> bool:
    """Run ``spec`` into ``out`` unless it is there; True when LAMMPS ran. ``force``: above
    the cost limits too."""
    from bkflow.lammps.continuation import continuation

    rd = RunDir(out)
    with rd.lock():
        if simulated(out, spec):
            return False
        # a shorter run of the same parameters goes on from where it stopped; anything else
        # there (a stale or damaged run) is redone
        run(spec, out, overwrite=continuation(rd, spec) is None, progress=False,
            command=command, force=force)
        return True


def seed(out, donors, spec: RunSpec) -> str | None:
    """A directory without a run that one of ``donors`` (run directories of finished runs)
    continues: the longest of them that ``spec`` continues
    (``bkflow.lammps.continuation.continuation``) copied into ``out``, so that the run goes on
    from its restart file rather than simulating again what it has. Returns the donor copied,
    or None."""
    import shutil
    from pathlib import Path

    from bkflow.lammps.continuation import continuation
    from bkflow.store.errors import RunBusyError
    from bkflow.store.files import atomic_file
    from bkflow.store.layout import ANALYSIS_FILES, COMPANION, CONTINUING, LOCK, MARK, META

    rd = RunDir(out)
    with rd.lock():   # the job's own run, which another process may be writing
        if rd.meta() is not None:
            return None
        best, steps = None, -1
        for d in donors:
            try:
                # a donor another process is writing (or continuing) now is passed over;
                # checking one may undo a continuation of it that was cut short
                with RunDir(d).lock():
                    meta = continuation(RunDir(d), spec)
            except RunBusyError:
                continue
            if meta is not None and meta["derived"]["n_steps"] > steps:
                best, steps = Path(d), meta["derived"]["n_steps"]
        if best is None:
            return None

        def copy(src: Path, dst: Path) -> None:
            dst.mkdir(exist_ok=True)
            for p in sorted(src.iterdir(), key=lambda p: p.name == META):  # the record last
                if (p.name in ANALYSIS_FILES or p.name in (LOCK, MARK, CONTINUING)
                        or p.name.startswith("signac_") or p.name.endswith(".tmp")):
                    continue
                if p.name == COMPANION and p.is_dir() and not p.is_symlink():
                    RunDir(dst / p.name).path.mkdir(exist_ok=True)
                    RunDir(dst / p.name).mark()
                    copy(p, dst / p.name)
                elif p.is_file() and not p.is_symlink():
                    with open(p, "rb") as src_f, atomic_file(dst / p.name, binary=True) as o:
                        shutil.copyfileobj(src_f, o)

        # the job's own mark first: until the donor's record is copied (last) the directory
        # holds a run of this job's that did not finish, and a copy cut short is redone from
        # the start (the donor's mark names the donor's directory, and is not copied)
        rd.mark()
        try:
            with RunDir(best).lock():
                copy(best, rd.path)
        except RunBusyError:   # taken between the check and the copy: run from the start
            return None
        return str(best)


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
