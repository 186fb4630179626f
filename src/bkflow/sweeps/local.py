"""Local sweeps: every run of a grid not yet finished, several at a time, then the tables.

``sweep`` opens (or creates) the sweep directory's signac-flow project
(``bkflow.sweeps.project``), creates one job per RunSpec, and runs the pending operations with a
process pool, most expensive run first, with one progress line; ``collect`` re-analyses
what is stale and writes runs.csv and results.csv (``bkflow.store.tables``).
"""

from __future__ import annotations

import contextlib
import datetime
import os
import sys
import threading
import time
from dataclasses import dataclass, field

import pandas as pd

from bkflow.analysis.results import write_tables
from bkflow.lammps.engine import RunError
from bkflow.lammps.progress import in_notebook, terminal_size
from bkflow.model.checks import SpecError
from bkflow.model.params import RunSpec
from bkflow.model.settings import AnalysisSettings
from bkflow.store.rundir import RunDir
from bkflow.store.tables import retire_figures
from bkflow.sweeps import flowcompat
from bkflow.sweeps.grid import run_cost
from bkflow.sweeps.lengths import open_jobs
from bkflow.sweeps.project import (
    ANALYZE,
    SIMULATE,
    analysed,
    check_sweep_dir,
    clear_failure,
    finished,
    open_project,
    permit_above_limits,
    set_settings,
    settings_of,
    simulated,
    spec_of,
)


@dataclass
class SweepReport:
    total: int
    finished_before: int
    finished: list = field(default_factory=list)     # jobs finished by this sweep
    failed: dict = field(default_factory=dict)       # job id -> message
    refused: list = field(default_factory=list)      # of the failed, those refused (exit 2)
    unfinished: list = field(default_factory=list)   # neither (interrupted)
    reanalysed: list = field(default_factory=list)   # of those, the ones only analysed again
    busy: list = field(default_factory=list)         # of the unfinished, those another process had
    retired_figures: list = field(default_factory=list)  # figures of the tables before
    wall_time_s: float = 0.0
    results: pd.DataFrame | None = None              # results.csv as written


class _SweepBar:
    """One progress line for the sweep (runs done / total, ETA) on a terminal; on anything
    else one line per run as it finishes. Polls the jobs' post-conditions."""

    def __init__(self, jobs, done_before: int, total: int, enabled: bool | None,
                 axes: tuple = ()):
        self.pending = list(jobs)
        self.axes = axes  # the parameters besides phi, size and seed that the sweep varies
        self.done = done_before
        self.total = total
        self.stream = sys.stderr
        self.tty = (self.stream.isatty() or in_notebook()) if enabled is None else enabled
        self.quiet = enabled is False
        self.stop = threading.Event()
        self.bar = None
        if self.tty and not self.quiet:
            from tqdm.auto import tqdm

            self.bar = tqdm(total=total, initial=done_before, unit="run", desc="sweep",
                            file=self.stream, smoothing=0.1,
                            **terminal_size(100))
        self.thread = threading.Thread(target=self._poll, daemon=True)

    def _check(self):
        still = []
        for job in self.pending:
            if finished(job) or "error" in job.document or "busy" in job.document:
                self.done += 1
                if self.bar is not None:
                    self.bar.update(1)
                elif not self.quiet:
                    state = ("done" if finished(job) else "failed" if "error" in job.document
                             else "busy: another process is writing it")
                    spec = spec_of(job)
                    extra = "".join(f", {k}={getattr(spec, k)}" for k in self.axes)
                    print(f"[{self.done}/{self.total}] {spec.label}{extra}: {state}",
                          file=self.stream, flush=True)
            else:
                still.append(job)
        self.pending = still

    def _poll(self):
        while not self.stop.wait(0.5):
            with contextlib.suppress(Exception):  # a file caught mid-write: next poll
                self._check()

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.stop.set()
        self.thread.join()
        with contextlib.suppress(Exception):
            self._check()
        if self.bar is not None:
            self.bar.close()


class WorkerDied(RunError):
    """A worker process of a local sweep died (killed, out of memory) in the middle of a run;
    the sweep stopped its other runs (they resume with the same command)."""


#: the jobs each worker has started: (job id, pid), put by the worker, read by the sweep
_STARTED = None
#: the worker's own project, opened once per worker process
_WORKER_PROJECT = {}


def _work(path: str, job_id: str, names: list) -> None:
    """A worker's task: the job's pending operations, by flow, in this process (flow runs the
    same operations on a cluster)."""
    _STARTED.put((job_id, os.getpid()))
    project = _WORKER_PROJECT.get(path)
    if project is None:
        project = _WORKER_PROJECT[path] = open_project(path, create=False)
    from bkflow.lammps import plugin

    with plugin.interrupts(()):  # no signal is Ctrl-C here
        _flow_run(project, [project.open_job(id=job_id)], names)


def _flow_run(project, jobs, names) -> None:
    """flow's run of ``jobs``' pending operations ``names`` in this process, its bars quiet.
    The file system's refusal (a directory removed, a full disk) reaches the sweep as itself,
    not wrapped as flow's UserOperationError: the command says what refused and exits as for
    any file system error, in one process as in many."""
    from flow.errors import UserOperationError

    with flowcompat.quiet_flow_bars():
        try:
            project.run(jobs=jobs, names=names)
        except UserOperationError as exc:
            if isinstance(exc.__cause__, OSError):
                raise exc.__cause__ from None
            raise


def _worker_signals() -> None:
    """A worker dies of SIGTERM and SIGHUP as any process does (the sweep sees it die and
    stops; its own handlers, inherited by fork, would turn them into an interrupt of one run
    only); Ctrl-C, sent to the whole process group, still interrupts it. A signal the sweep
    ignores (started under nohup) the worker ignores too."""
    import signal

    for sig in (signal.SIGTERM, signal.SIGHUP):
        if signal.getsignal(sig) != signal.SIG_IGN:
            signal.signal(sig, signal.SIG_DFL)


def warm(simulate: bool = True) -> None:
    """Import what a run and its analysis use (LAMMPS's module and MPI when it will
    ``simulate``, pandas, scipy, powerlaw), once, before the worker processes are forked:
    every worker then starts with them in memory and pays only its runs (a cold process
    spends about a second and a half importing them, more than a short run takes). Best
    effort: what cannot be imported here is met, and reported, where a run needs it."""
    import importlib

    from bkflow.analysis import summary  # noqa: F401
    from bkflow.observables.stress import import_powerlaw

    try:
        import_powerlaw()
    except ImportError:
        pass
    names = ["pandas", "scipy.stats", "scipy.sparse.csgraph", "pyarrow.parquet"]
    if simulate:
        from bkflow.lammps.plugin import PluginError, load_mpi

        try:
            load_mpi()
        except PluginError:
            pass
        names.insert(0, "lammps")
    for name in names:
        try:
            importlib.import_module(name)
        except ImportError:
            pass


def _run_pending(project, jobs, names, np_: int, cost: dict | None = None) -> None:
    """The pending operations of ``jobs``, most expensive run first: in this process when
    ``np_`` is 1, else in ``np_`` worker processes (``_run_in_workers``)."""
    jobs = sorted(jobs, key=lambda j: -cost.get(j.id, 0.0)) if cost else list(jobs)
    if np_ <= 1:
        _flow_run(project, jobs, names)
        return
    _run_in_workers(project, jobs, names, np_)


def _run_in_workers(project, jobs, names, np_: int) -> None:
    """The pending operations of ``jobs``, in this order, in ``np_`` worker processes, each
    running many runs. A worker that dies (SIGKILL, the out-of-memory killer) stops the sweep
    within a second: the others are terminated and ``WorkerDied`` names the runs that were
    under way. (flow's own pool, multiprocessing.Pool, would wait for the dead worker's result
    for ever.)"""
    import multiprocessing
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool

    global _STARTED
    warm(simulate=SIMULATE in names)
    ctx = multiprocessing.get_context("fork")  # workers inherit the imports and the queue
    _STARTED = ctx.SimpleQueue()
    started, done = {}, set()
    pool = ProcessPoolExecutor(max_workers=np_, mp_context=ctx, initializer=_worker_signals)
    try:
        pending = {pool.submit(_work, str(project.path), j.id, list(names)): j for j in jobs}
        while pending:
            finished_now, _ = wait(pending, timeout=0.5, return_when=FIRST_COMPLETED)
            _note_started(started)
            for fut in finished_now:
                job = pending.pop(fut)
                done.add(job.id)
                fut.result()  # BrokenProcessPool, or what the task raised (an interrupt)
    except BrokenProcessPool:
        _note_started(started)
        raise _worker_died(jobs, started, done) from None
    except BaseException:  # Ctrl-C, SIGTERM or SIGHUP to the sweep: its runs stop now too
        for proc in list(getattr(pool, "_processes", {}).values()):
            with contextlib.suppress(OSError):
                proc.terminate()
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _note_started(started: dict) -> None:
    """Move the (job id, pid) the workers have put since into ``started``."""
    while not _STARTED.empty():
        job_id, pid = _STARTED.get()
        started[job_id] = pid


def _worker_died(jobs, started: dict, done: set) -> WorkerDied:
    """The error of a worker's death, naming the runs of ``jobs`` that were under way (started,
    not done, neither finished nor failed)."""
    under_way = [j for j in jobs if j.id in started and j.id not in done
                 and not finished(j) and "error" not in j.document]
    labels = ", ".join(spec_of(j).label for j in under_way) or "none started"
    return WorkerDied(f"a worker process of the sweep died (killed, or out of memory) "
                      f"while running: {labels}; the sweep stopped its other runs; the same "
                      "command resumes them")


def sweep(specs, out, jobs: int | None = None, progress: bool | None = None,
          settings: AnalysisSettings | None = None, force: bool = False) -> SweepReport:
    """Run every spec not yet finished in sweep directory ``out``, ``jobs`` runs at a time
    (default: all cores), through signac-flow; then write runs.csv and results.csv.

    ``settings``: the analysis settings of the sweep (default: those it has, or the
    defaults); a finished run analysed under others is analysed again, not run again.
    Runs are started most expensive first, so that the cores stay busy to the end.
    ``force``: the runs may go above the cost limits (bkflow.lammps.limits).
    """
    specs = list(specs)
    jobs = jobs or available_cores()
    if jobs < 1:
        raise SpecError(f"--jobs must be >= 1, got {jobs}")
    check_sweep_dir(out)  # before the lock file is made in it
    with RunDir(out).lock():  # one sweep at a time writes a sweep directory
        return _sweep(specs, out, jobs, progress, settings, force)


def _sweep(specs, out, jobs, progress, settings, force=False) -> SweepReport:
    project = open_project(out)
    if settings is not None:
        set_settings(project, settings)
    selected = open_jobs(project, specs)
    for job in selected:  # a previous failure is retried
        clear_failure(job)
        permit_above_limits(job, force)
    todo = [j for j in selected if not finished(j)]
    stale = {j.id for j in todo if simulated(j)}
    report = SweepReport(total=len(selected), finished_before=len(selected) - len(todo))
    t0 = time.perf_counter()
    cost = {j.id: run_cost(spec_of(j)) for j in todo}
    if todo:
        with _SweepBar(todo, report.finished_before, report.total, progress, _varied(specs)):
            _run_pending(project, todo, [SIMULATE, ANALYZE], min(jobs, len(todo)), cost)
    report.wall_time_s = time.perf_counter() - t0
    _tally(report, todo, stale)
    done = collect(project, jobs=jobs)
    report.results, report.retired_figures = done.results, done.retired_figures
    return report


def _varied(specs) -> tuple:
    """The parameters besides phi, size and seed whose values differ among ``specs`` (the
    progress lines name them)."""
    return tuple(f for f in RunSpec.__dataclass_fields__
                 if f not in ("phi", "Lx", "Ly", "seed")
                 and len({repr(getattr(s, f)) for s in specs}) > 1)


def _tally(report: SweepReport, todo, stale: set) -> None:
    """Sort the jobs the sweep ran (``todo``) into ``report``: finished (and of those, the
    ``stale`` ones only analysed again), failed (refused), or unfinished (busy)."""
    for job in todo:
        if finished(job):
            report.finished.append(job.id)
            if job.id in stale:
                report.reanalysed.append(job.id)
        elif "error" in job.document:
            report.failed[job.id] = job.document["error"]
            if job.document.get("refused"):
                report.refused.append(job.id)
        else:  # interrupted, or busy in another process (e.g. a cluster job)
            report.unfinished.append(job.id)
            if "busy" in job.document:
                report.busy.append(job.id)


@dataclass
class Collection:
    """What ``collect`` did: the jobs it re-analysed and the tables it wrote."""

    jobs: int
    finished: int
    failed: list
    reanalysed: list
    runs: pd.DataFrame
    results: pd.DataFrame
    retired_figures: list = field(default_factory=list)  # drawn from the tables before
    damaged: list = field(default_factory=list)  # (job id, why): runs once finished, now not


def collect(project, settings: AnalysisSettings | None = None,
            jobs: int = 1) -> Collection:
    """Re-analyse every simulated run whose summary is stale for the sweep's settings (or
    ``settings``, which then become the sweep's), then write runs.csv, results.csv and
    analysis.json into the project directory."""
    with RunDir(project.path).lock():
        return _collect(project, settings, jobs)


def _collect(project, settings, jobs) -> Collection:
    if settings is not None:
        set_settings(project, settings)
    settings = settings_of(project)
    all_jobs = list(project)
    stale = [j for j in all_jobs if simulated(j) and not analysed(j)]
    if stale:
        _run_pending(project, stale, [ANALYZE], jobs)
    done = [j for j in all_jobs if finished(j)]
    runs, results = write_tables(
        project.path, [(j.id, spec_of(j).to_dict(), RunDir(j.path).summary()) for j in done],
        settings.to_dict())
    failed = [j for j in all_jobs if not finished(j) and "error" in j.document]
    damaged = _damaged(all_jobs)
    retired = retire_figures(project.path)
    return Collection(len(all_jobs), len(done), failed,
                      [j.id for j in stale if finished(j)], runs, results, retired, damaged)


def _damaged(jobs) -> list:
    """(job id, why) of every run of ``jobs`` that finished once and is no longer intact."""
    damaged = []
    for j in jobs:
        rd = RunDir(j.path)
        if not finished(j) and rd.is_complete():   # it finished once: say what broke it
            why = rd.problem()
            if why is not None:
                damaged.append((j.id, why))
    return damaged


def available_cores() -> int:
    with contextlib.suppress(AttributeError):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def fmt_duration(seconds: float) -> str:
    return str(datetime.timedelta(seconds=int(round(seconds))))


__all__ = ["sweep", "collect", "SweepReport", "Collection", "available_cores"]
