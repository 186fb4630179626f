"""Parameter sweeps on signac + signac-flow: one job per run, finished runs never redone.

A sweep directory is a signac project. Every run is a signac job whose state point is the
full :class:`~bkflow.params.RunSpec` (so the job id is a hash of every parameter) and whose
folder holds the run's files (``workspace/<id>/``). The one operation, :func:`simulate`,
calls the pure :func:`run_one`; its post-condition :func:`finished` checks that the run's
files are intact (sizes recorded by the engine) and that its summary is there. So a
re-run, locally with ``bkflow sweep`` or on a cluster with ``workflows/project.py``, skips
finished runs and redoes interrupted, half-written or corrupted ones.

>>> phi_values("1e-1:1e3")[:4]
[0.1, 0.215443, 0.464159, 1.0]
>>> len(phi_values("1e-1:1e3"))
13
>>> phi_values("1,10,100")
[1.0, 10.0, 100.0]
"""

from __future__ import annotations

import contextlib
import datetime
import errno
import math
import os
import shutil
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from .params import PAPER_SIZES, RunSpec, SpecError, parse_size

#: default sampling of a --phi range
POINTS_PER_DECADE = 3
#: default number of seeds (1 .. K) per (phi, size)
SEEDS = 3
#: default Lx / Ly of --sizes (the paper's lattices have Ly = Lx / 4)
ASPECT = 4
RUNS_FILE = "runs.csv"
RESULTS_FILE = "results.csv"
LOCK_FILE = ".bkflow.lock"
#: the sweep's single operation (a signac-flow operation name)
OPERATION = "simulate"
#: summary fields averaged over seeds in results.csv (mean and standard error)
RESULT_FIELDS = ("mu_bar", "mean_stress_ratio", "psi_inf", "lx_over_ly", "lx_mean_over_Lx",
                 "ly_mean_over_Ly", "drop_exponent", "n_slips", "t_run")
#: engine throughput assumed for cluster wall-time requests (atom-steps/s, one core); the
#: measured figure is 3-4e7 (benchmarks/RESULTS.md), halved for slower cluster cores
ASSUMED_THROUGHPUT = 1.5e7


class RunBusyError(RuntimeError):
    """Another process is running this job now (its lock is held)."""


# --------------------------------------------------------------------------- parameters
def _sig(x: float) -> float:
    # six significant digits: the same phi reached from two ranges is the same job
    return float(f"{x:.6g}")


def phi_values(text: str, points_per_decade: int = POINTS_PER_DECADE) -> list[float]:
    """``"A:B"`` -> log-spaced phi from A to B, ``points_per_decade`` per decade, both ends
    included when B/A is a whole number of steps; ``"a,b,c"`` -> that list. Values are
    rounded to 6 significant digits. Raises :class:`SpecError` naming what is wrong."""
    text = str(text).strip()
    if not isinstance(points_per_decade, int) or points_per_decade < 1:
        raise SpecError(f"--points-per-decade must be a whole number >= 1, "
                        f"got {points_per_decade!r}")

    def number(s):
        try:
            v = float(s)
        except ValueError:
            raise SpecError(f"--phi {text}: {s!r} is not a number") from None
        if not (math.isfinite(v) and v > 0):
            raise SpecError(f"--phi {text}: phi must be > 0 (phi = k_b / dk_d), got {s}")
        return v

    if ":" in text:
        parts = text.split(":")
        if len(parts) != 2:
            raise SpecError(f"--phi {text}: a range is A:B (e.g. 1e-1:1e3)")
        a, b = number(parts[0]), number(parts[1])
        if not b > a:
            raise SpecError(f"--phi {text}: the range must increase (A < B), e.g. "
                            f"--phi {parts[1]}:{parts[0]}")
        decades = math.log10(b / a)
        n = int(math.floor(decades * points_per_decade + 1e-9))
        vals = [a * 10 ** (k / points_per_decade) for k in range(n + 1)]
        if b / vals[-1] > 1 + 1e-9:
            vals.append(b)  # the end of the range is always swept
        return sorted({_sig(v) for v in vals})
    vals = [number(s) for s in text.split(",") if s.strip()]
    if not vals:
        raise SpecError("--phi: give a range A:B or a list a,b,c")
    return sorted({_sig(v) for v in vals})


def parse_aspect(text) -> float | None:
    """``--aspect``: Lx / Ly that every size must have (a number), or ``any`` (None)."""
    if text is None:
        return ASPECT
    if str(text).strip().lower() == "any":
        return None
    try:
        v = float(text)
    except ValueError:
        raise SpecError(f"--aspect {text!r}: give Lx/Ly as a number (e.g. 1) or 'any'") \
            from None
    if not (math.isfinite(v) and v > 0):
        raise SpecError(f"--aspect must be > 0, got {text}")
    return v


def parse_sizes(text: str, aspect: float | None = ASPECT) -> list[tuple[int, int]]:
    """``"20x5,40x10"`` -> [(20, 5), (40, 10)]; ``100,400`` picks the paper's lattices.
    Every size must have Lx = aspect * Ly unless ``aspect`` is None."""
    sizes = []
    for item in str(text).split(","):
        item = item.strip()
        if not item:
            continue
        if item.isdigit():
            n = int(item)
            if n not in PAPER_SIZES:
                raise SpecError(f"--sizes {item}: a bare number names one of the paper's "
                                f"lattices N = {', '.join(map(str, PAPER_SIZES))}; else LXxLY")
            lx, ly = PAPER_SIZES[n]
        else:
            lx, ly = parse_size(item)
        if aspect is not None and not math.isclose(lx, aspect * ly):
            raise SpecError(f"--sizes {item}: Lx/Ly = {lx / ly:g}, not {aspect:g} (the "
                            f"paper's lattices have Ly = Lx/4); pass --aspect {lx / ly:g} or "
                            f"--aspect any to sweep other shapes")
        sizes.append((lx, ly))
    if not sizes:
        raise SpecError("--sizes: give at least one LXxLY")
    return list(dict.fromkeys(sizes))


def sweep_specs(phis, sizes, seeds, **common) -> list[RunSpec]:
    """Every (phi, size, seed) as a validated RunSpec (a SpecError before anything runs).

    ``seeds``: a count K (seeds 1..K) or an explicit list."""
    if isinstance(seeds, int):
        if seeds < 1:
            raise SpecError(f"--seeds must be >= 1, got {seeds}")
        seeds = range(1, seeds + 1)
    return [RunSpec(phi=phi, Lx=lx, Ly=ly, seed=s, **common)
            for (lx, ly) in sizes for phi in phis for s in seeds]


def run_cost(spec: RunSpec) -> float:
    """Atom-steps of a run: what its wall time scales with."""
    return float(spec.N) * spec.n_steps


# --------------------------------------------------------------------------- one run
@contextlib.contextmanager
def _job_lock(out: Path):
    """Hold an exclusive lock on the run directory (released when the process dies)."""
    import fcntl

    out.mkdir(parents=True, exist_ok=True)
    fd = os.open(out / LOCK_FILE, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            if exc.errno in (errno.EAGAIN, errno.EACCES):
                raise RunBusyError(f"{out}: another process is running this job now; wait "
                                   "for it or stop it") from None
            raise
        yield
    finally:
        os.close(fd)


def summary_problem(out, spec: RunSpec | None = None) -> str | None:
    """Why the analysis of run directory ``out`` is missing or stale (None when intact)."""
    from . import io
    from .engine import CLUSTERS_FILE, PSI_FILE, SUMMARY_FILE

    out = Path(out)
    try:
        s = io.read_json(out / SUMMARY_FILE)
    except FileNotFoundError:
        return "no summary.json"
    except (OSError, ValueError) as exc:
        return f"summary.json unreadable ({exc})"
    if not isinstance(s, dict) or "mu_bar" not in s:
        return "summary.json holds no mu_bar"
    if spec is not None:
        expected = spec.to_dict()
        if spec.target_error is not None:  # an adaptive run ends when its target is met
            if not (isinstance(s.get("t_end"), (int, float)) and s["t_end"] <= spec.t_end):
                return "summary.json belongs to other parameters"
            del expected["t_end"]
        if any(s.get(k) != v for k, v in expected.items()):
            return "summary.json belongs to other parameters"
        needed = [PSI_FILE] * spec.writes_snapshots + [CLUSTERS_FILE] * spec.writes_slips
        for name in needed:
            if not (out / name).is_file():
                return f"{name} is missing"
    return None


def run_one(spec: RunSpec, out) -> dict:
    """Run ``spec`` into directory ``out`` unless it already holds it, analyse it, and
    return the summary (summary.json, as written).

    The result depends on ``spec`` alone: an intact finished run is returned as it is, a
    finished simulation without its analysis is only analysed, anything else (nothing yet,
    interrupted, truncated files) is run from scratch. A lock on the directory keeps two
    processes from writing one run; the second gets a :class:`RunBusyError`.
    """
    from . import io
    from .analysis import analyze
    from .engine import SUMMARY_FILE, run, run_problem

    out = Path(out)
    with _job_lock(out):
        if run_problem(out) is None:
            if summary_problem(out, spec) is None:
                return io.read_json(out / SUMMARY_FILE)
            return analyze(out)
        run(spec, out, overwrite=True, progress=False, command=f"bkflow sweep ({OPERATION})")
        return analyze(out)


# --------------------------------------------------------------------------- the project
from flow import FlowProject  # noqa: E402  (kept below the pure helpers it does not need)


class SweepProject(FlowProject):
    """The signac-flow project of a sweep directory: one job per run, one operation."""


def finished(job) -> bool:
    """Post-condition of :func:`simulate`: the run's files are intact and analysed."""
    from .engine import run_problem

    return (run_problem(job.path) is None
            and summary_problem(job.path, RunSpec.from_dict(job.cached_statepoint)) is None)


@SweepProject.label
def failed(job):
    """The last attempt at this run stopped with an error (kept in the job document)."""
    return "error" in job.document


def _walltime_hours(job) -> float:
    """A generous wall-time request for one run on a cluster core (SLURM directive)."""
    spec = RunSpec.from_dict(job.cached_statepoint)
    return round(max(0.05, (3 * run_cost(spec) / ASSUMED_THROUGHPUT + 120) / 3600), 3)


def _die_with_parent() -> None:
    """In a worker process of a local sweep, die when the sweep itself is killed: a worker
    left behind would keep writing a run the resumed sweep redoes (Linux only)."""
    import multiprocessing

    if multiprocessing.parent_process() is None or not sys.platform.startswith("linux"):
        return
    import ctypes
    import signal

    with contextlib.suppress(OSError, AttributeError):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
        if os.getppid() == 1:  # the parent died before prctl took effect
            os._exit(1)


@SweepProject.post(finished)
@SweepProject.operation(directives={"np": 1, "walltime": _walltime_hours})
def simulate(job):
    """One run of the model for the job's state point (a RunSpec), via :func:`run_one`.

    A run that fails (blow-up, lost atoms, LAMMPS error, or an analysis that cannot cope)
    records the message in the job document under ``error`` and does not stop the other
    runs; the post-condition stays false, so the next sweep tries it again.
    """
    from .engine import RunError

    _die_with_parent()
    spec = RunSpec.from_dict(job.cached_statepoint)
    try:
        run_one(spec, job.path)
    except (RunError, RunBusyError) as exc:
        job.document["error"] = str(exc)
        return
    except Exception as exc:  # one run's surprise must not take the sweep's other runs down
        job.document["error"] = (f"{type(exc).__name__}: {exc} (phi={spec.phi:g}, "
                                 f"{spec.Lx}x{spec.Ly}, seed {spec.seed}; see {job.path})")
        return
    if "error" in job.document:
        del job.document["error"]


def open_project(path, create: bool = True) -> SweepProject:
    """The sweep project at ``path`` (created when ``create`` and it does not exist)."""
    import signac

    path = Path(path)
    if not (path / ".signac").is_dir():
        if not create:
            raise FileNotFoundError(f"{path} is not a bkflow sweep directory (no .signac/); "
                                    "run bkflow sweep --out DIR first")
        path.mkdir(parents=True, exist_ok=True)
        signac.init_project(str(path))
    return SweepProject.get_project(str(path), search=False)


# --------------------------------------------------------------------------- local sweep
@dataclass
class SweepReport:
    total: int
    finished_before: int
    finished: list = field(default_factory=list)     # jobs finished by this sweep
    failed: dict = field(default_factory=dict)       # job id -> message
    unfinished: list = field(default_factory=list)   # neither (interrupted)
    wall_time_s: float = 0.0
    results: pd.DataFrame | None = None              # results.csv as written


class _SweepBar:
    """One progress line for the sweep (runs done / total, ETA) on a terminal; on anything
    else one line per run as it finishes. Polls the jobs' post-conditions."""

    def __init__(self, jobs, done_before: int, total: int, enabled: bool | None):
        self.pending = list(jobs)
        self.done = done_before
        self.total = total
        self.stream = sys.stderr
        self.tty = self.stream.isatty() if enabled is None else enabled
        self.quiet = enabled is False
        self.stop = threading.Event()
        self.bar = None
        if self.tty and not self.quiet:
            from tqdm import tqdm

            self.bar = tqdm(total=total, initial=done_before, unit="run", desc="sweep",
                            file=self.stream, smoothing=0.1,
                            ncols=min(100, shutil.get_terminal_size().columns))
        self.thread = threading.Thread(target=self._poll, daemon=True)

    def _check(self):
        still = []
        for job in self.pending:
            if finished(job) or "error" in job.document:
                self.done += 1
                if self.bar is not None:
                    self.bar.update(1)
                elif not self.quiet:
                    sp = job.cached_statepoint
                    state = "failed" if "error" in job.document else "done"
                    print(f"[{self.done}/{self.total}] phi={sp['phi']:g} {sp['Lx']}x{sp['Ly']} "
                          f"seed {sp['seed']}: {state}", file=self.stream, flush=True)
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


def sweep(specs, out, jobs: int | None = None, progress: bool | None = None) -> SweepReport:
    """Run every spec not yet finished in sweep directory ``out``, ``jobs`` runs at a time
    (default: all cores), through signac-flow; then write runs.csv and results.csv.

    Runs are started most expensive first, so that the cores stay busy to the end.
    """
    specs = list(specs)
    jobs = jobs or available_cores()
    if jobs < 1:
        raise SpecError(f"--jobs must be >= 1, got {jobs}")
    project = open_project(out)
    selected = [project.open_job(s.to_dict()).init() for s in specs]
    for job in selected:  # a previous failure is retried
        if "error" in job.document:
            del job.document["error"]
    todo = [j for j in selected if not finished(j)]
    report = SweepReport(total=len(selected), finished_before=len(selected) - len(todo))
    t0 = time.perf_counter()
    cost = {j.id: run_cost(RunSpec.from_dict(j.cached_statepoint)) for j in todo}
    if todo:
        with _SweepBar(todo, report.finished_before, report.total, progress), _no_flow_bars():
            project.run(jobs=todo, names=[OPERATION], np=jobs if jobs > 1 else None,
                        order=lambda op: _op_cost(op, cost))
    report.wall_time_s = time.perf_counter() - t0
    for job in todo:
        if finished(job):
            report.finished.append(job.id)
        elif "error" in job.document:
            report.failed[job.id] = job.document["error"]
        else:
            report.unfinished.append(job.id)
    report.results = collect(project)[1]
    return report


@contextlib.contextmanager
def _no_flow_bars():
    """Silence flow's own "Serialize tasks" bar while ours counts the runs (flow prints it
    unconditionally when running in parallel)."""
    import flow.project as fp

    original = getattr(fp, "tqdm", None)
    if original is not None:
        fp.tqdm = lambda iterable, *args, **kwargs: iterable
    try:
        yield
    finally:
        if original is not None:
            fp.tqdm = original


def _op_cost(op, cost: dict) -> float:
    # flow sorts by this key: the most expensive run first
    jobs = getattr(op, "_jobs", ())
    return -cost.get(jobs[0].id, 0.0) if jobs else 0.0


def available_cores() -> int:
    with contextlib.suppress(AttributeError):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


# --------------------------------------------------------------------------- tables
#: state-point keys that are not physics: averaged over, or bookkeeping
_NOT_GROUPED = ("seed",)


def runs_table(project) -> pd.DataFrame:
    """One row per finished run: every parameter and every scalar of its summary."""
    from . import io
    from .engine import SUMMARY_FILE

    rows = []
    for job in project:
        if not finished(job):
            continue
        s = io.read_json(Path(job.path) / SUMMARY_FILE)
        row = {"job": job.id}
        for k, v in s.items():
            if isinstance(v, dict):
                for kk, vv in v.items():
                    row[f"{k}[{kk}]"] = vv
            elif not isinstance(v, list):
                row[k] = v
        # parameters as requested (an adaptive run's t_end is its cap), the length it ran
        row["t_run"] = s.get("t_end")
        row.update(job.cached_statepoint)
        rows.append(row)
    df = pd.DataFrame(rows)
    if len(df):
        df = df.sort_values(["Lx", "Ly", "phi", "seed"], kind="stable").reset_index(drop=True)
    return df


def results_table(runs: pd.DataFrame) -> pd.DataFrame:
    """Per (phi, size, and every other parameter but the seed): the mean over seeds and its
    standard error (sample standard deviation / sqrt(n); NaN for one seed) of
    :data:`RESULT_FIELDS`, the seeds' count, the mean within-run error of mu_bar, and the
    regime most seeds report."""
    if runs.empty:
        return pd.DataFrame()
    params = [f for f in RunSpec.__dataclass_fields__ if f not in _NOT_GROUPED]
    rows = []
    for key, g in runs.groupby(params, sort=True, dropna=False):
        row = dict(zip(params, key))
        row["N"] = int(row["Lx"] * row["Ly"])
        row["n_seeds"] = len(g)
        for f in RESULT_FIELDS:
            if f not in g:  # a field the runs did not record
                row[f] = row[f"{f}_sem"] = math.nan
                continue
            v = pd.to_numeric(g[f], errors="coerce").to_numpy(dtype=float)
            v = v[np.isfinite(v)]
            row[f] = v.mean() if len(v) else math.nan
            row[f"{f}_sem"] = v.std(ddof=1) / math.sqrt(len(v)) if len(v) > 1 else math.nan
        err = pd.to_numeric(g["mu_bar_err"], errors="coerce").to_numpy(dtype=float)
        row["mu_bar_err_within_run"] = float(np.nanmean(err)) if np.isfinite(err).any() \
            else math.nan
        regimes = g["regime"].dropna()
        row["regime"] = regimes.mode().iloc[0] if len(regimes) else None
        rows.append(row)
    first = ["phi", "Lx", "Ly", "N", "n_seeds"]
    df = pd.DataFrame(rows)
    return df[first + [c for c in df.columns if c not in first]].sort_values(
        ["Lx", "Ly", "phi"], kind="stable").reset_index(drop=True)


def collect(project) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Write ``runs.csv`` and ``results.csv`` into the project directory (atomically)."""
    runs = runs_table(project)
    results = results_table(runs)
    root = Path(project.path)
    for name, df in ((RUNS_FILE, runs), (RESULTS_FILE, results)):
        tmp = root / (name + ".tmp")
        df.to_csv(tmp, index=False, float_format="%.10g")
        os.replace(tmp, root / name)
    return runs, results


def fmt_duration(seconds: float) -> str:
    return str(datetime.timedelta(seconds=int(round(seconds))))


__all__ = ["phi_values", "parse_sizes", "parse_aspect", "sweep_specs", "run_one", "finished",
           "simulate", "SweepProject", "open_project", "sweep", "collect", "runs_table",
           "results_table", "RunBusyError", "SweepReport"]
