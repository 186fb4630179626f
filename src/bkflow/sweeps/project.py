"""A sweep directory as a signac-flow project: one job per run, two operations.

Every run is a signac job whose state point is the full ``bkflow.model.params.RunSpec`` (the
job id is a hash of every parameter) and whose folder is the run directory
(``workspace/<id>/``). Operation ``simulate`` runs LAMMPS (post-condition: an intact
finished run); operation ``analyze`` (pre-condition: simulated) writes the summary under
the sweep's analysis settings, kept in the project document (post-condition: the summary is
current for them). So a re-run, locally with ``bkflow sweep`` or on a cluster with
``workflows/project.py`` (``ClusterProject``), skips finished work; a changed analysis
setting re-analyses every run and runs no LAMMPS.
"""

from __future__ import annotations

import contextlib
import os
import sys
from pathlib import Path

from flow import FlowProject

from bkflow.model.checks import SpecError
from bkflow.model.params import RunSpec
from bkflow.model.settings import AnalysisSettings
from bkflow.store import formats
from bkflow.sweeps import job as one
from bkflow.sweeps.grid import run_cost

#: the operations, in the order a run needs them
SIMULATE, ANALYZE = "simulate", "analyze"
#: project-document key of the sweep's analysis settings
SETTINGS_KEY = "analysis_settings"
#: engine throughput assumed for cluster wall-time requests (atom-steps/s, one core); the
#: measured figure is 3-4e7 (benchmarks/measure/throughput.py), halved for slower cluster cores
ASSUMED_THROUGHPUT = 1.5e7


class SweepProject(FlowProject):
    """The signac-flow project of a sweep directory."""


#: the job document's key of the length a sweep asks of the job's run now (RunSpec fields of
#: ``bkflow.lammps.continuation.LENGTH_FIELDS``), where it differs from the job's state point: a
#: sweep run again with a longer --t-end (or a smaller --target-error) asks it of the same job,
#: whose run then goes on in its directory (``bkflow.sweeps.lengths.open_jobs``)
LENGTH = "length"


def spec_of(job) -> RunSpec:
    """The RunSpec a job's run is asked for: its state point, with the length a later sweep
    asked of it (``LENGTH``)."""
    return RunSpec.from_dict({**job.cached_statepoint, **dict(job.document.get(LENGTH, {}))})


def settings_of(project) -> AnalysisSettings:
    """The sweep's analysis settings (project document; defaults when never set)."""
    return AnalysisSettings.from_dict(dict(project.document.get(SETTINGS_KEY, {})))


def set_settings(project, settings: AnalysisSettings) -> None:
    if settings_of(project) != settings:
        project.document[SETTINGS_KEY] = settings.to_dict()


def simulated(job) -> bool:
    """Post-condition of ``simulate``: the run's files are intact."""
    return one.simulated(job.path, spec_of(job))


def analysed(job) -> bool:
    """Post-condition of ``analyze``: the run is intact and its summary is current for
    the sweep's settings."""
    return one.analysed(job.path, spec_of(job), settings_of(job.project))


def finished(job) -> bool:
    """Simulated and analysed: nothing left to do for this run."""
    return analysed(job)


@SweepProject.label
def failed(job):
    """The last attempt at this run stopped with an error (kept in the job document)."""
    return "error" in job.document


def _walltime_hours(job) -> float:
    """A generous wall-time request for one run on a cluster core (SLURM directive)."""
    return round(max(0.05, (3 * run_cost(spec_of(job)) / ASSUMED_THROUGHPUT + 120) / 3600), 3)


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


def _record_failure(job, exc: Exception) -> None:
    from bkflow.lammps.engine import RunError, RunExistsError
    from bkflow.store.errors import RunBusyError
    from bkflow.store.files import NotRegularFileError, OutsideError

    spec = spec_of(job)
    if isinstance(exc, RunBusyError):  # not a failure: another process (a cluster job) has it
        job.document["busy"] = str(exc)
    elif isinstance(exc, (RunExistsError, OutsideError, NotRegularFileError)):
        # refused, not failed: the job's directory holds what bkflow does not replace or read,
        # and running again changes nothing until it is moved away
        job.document["error"] = str(exc)
        job.document["refused"] = True
    elif isinstance(exc, RunError):
        job.document["error"] = str(exc)
    else:  # one run's surprise must not take the sweep's other runs down
        job.document["error"] = (f"{type(exc).__name__}: {exc} ({spec.label}; see {job.path})")


def clear_failure(job) -> None:
    """Remove from the job's document what its last attempt recorded (``_record_failure``):
    a run that finishes, or is tried again, has none."""
    for key in ("error", "busy", "refused"):
        if key in job.document:
            del job.document[key]


def _shorter(job) -> list:
    """The run directories of the project's other jobs with the same parameters but the
    length (t_end): the runs a longer one may continue."""
    same = {k: v for k, v in job.cached_statepoint.items() if k != "t_end"}
    return [j.path for j in job.project.find_jobs(same) if j.id != job.id]


#: the job document's key saying its run may go above the cost limits (``--force``)
FORCE = "force"


@SweepProject.post(simulated)
@SweepProject.operation(directives={"np": 1, "walltime": _walltime_hours})
def simulate(job):
    """Run the job's RunSpec (``bkflow.sweeps.job.simulate``) and, while its files are hot,
    analyse it as ``analyze`` would, so that one pass finishes a run. A failure
    (blow-up, LAMMPS error) is recorded in the job document under ``error`` and does not stop
    the other runs; the post-condition stays false, so the next sweep tries it again."""
    _die_with_parent()
    try:
        spec = spec_of(job)
        one.seed(job.path, _shorter(job), spec)
        one.simulate(spec, job.path, command=f"bkflow sweep ({SIMULATE})",
                     force=bool(job.document.get(FORCE, False)))
        one.analyze(spec, job.path, settings_of(job.project))
    except Exception as exc:
        _record_failure(job, exc)
        return
    clear_failure(job)


@SweepProject.pre(simulated)
@SweepProject.post(analysed)
@SweepProject.operation(directives={"np": 1})
def analyze(job):
    """Analyse the job's run under the sweep's settings (``bkflow.sweeps.job.analyze``); an
    analysis that fails (damaged files) is recorded like a failed run."""
    _die_with_parent()
    try:
        one.analyze(spec_of(job), job.path, settings_of(job.project))
    except Exception as exc:
        _record_failure(job, exc)
        return
    clear_failure(job)


#: project-document key that marks a signac project as a bkflow sweep (its version)
SWEEP_MARK = "bkflow_sweep"
#: what bkflow itself writes at the top of a sweep directory
SWEEP_FILES = (".signac", "workspace", "signac_project_document.json", "runs.csv",
               "results.csv", "analysis.json", "figures")


def _project_document(path: Path) -> dict:
    import json

    try:
        doc = json.loads(formats.read_text(path / "signac_project_document.json"))
    except (OSError, ValueError):
        return {}
    return doc if isinstance(doc, dict) else {}


def _jobs_are_runs(path: Path) -> bool:
    """Whether the workspace's jobs are bkflow runs (a sweep directory written before bkflow
    marked its sweeps with ``SWEEP_MARK``)."""
    import json

    found = list((path / "workspace").glob("*/signac_statepoint.json"))[:3]
    for sp in found:
        try:
            if not {"phi", "Lx", "Ly", "seed"} <= set(json.loads(formats.read_text(sp))):
                return False
        except (OSError, ValueError, TypeError):
            return False
    return bool(found)


def sweep_dir_problem(path) -> str | None:
    """What makes ``path`` not bkflow's to write a sweep into (None: it does not exist, is
    empty, or is a bkflow sweep). A sweep writes runs.csv, results.csv, analysis.json and a
    workspace: into a directory of the user's own files, or into a run directory, it would
    overwrite or bury them."""
    from bkflow.store.layout import MARK, META, bookkeeping, listing

    path = Path(path)
    if path.exists() and not path.is_dir():
        return "is a file, not a directory"
    try:
        names = {p.name for p in path.iterdir()}
    except FileNotFoundError:
        return None
    names = {n for n in names if not bookkeeping(n)}
    if not names:
        return None
    if MARK in names or META in names:
        return "is a bkflow run directory, not a sweep's"
    if SWEEP_MARK in _project_document(path):  # marked before signac's files are made
        return None
    if ".signac" not in names:
        return f"holds files that are not a bkflow sweep ({listing(names)})"
    if _jobs_are_runs(path):  # a sweep written before bkflow marked its sweeps
        return None
    return "is a signac project that is not a bkflow sweep"


def check_sweep_dir(path) -> None:
    """Refuse, before anything is written, a sweep into a directory that is not bkflow's."""
    why = sweep_dir_problem(path)
    if why is not None:
        raise SpecError(f"--out {path} {why}: a sweep writes only into a new or empty "
                        "directory or a sweep's own; choose another --out")


class WorkspaceError(SpecError):
    """A sweep directory whose signac records were edited or cut by hand; the message says
    what and how to repair it (nothing was changed)."""


def workspace_problem(path) -> str | None:
    """What of a sweep directory's own records signac cannot read, and how to repair it; None
    when they are whole. Checked before signac opens them (it raises on the first, from deep
    inside): its config, its project document, and every job folder (a state point that
    reads, whose hash is the folder's name, and a readable job document)."""
    path = Path(path)
    why = _config_problem(path)
    if why is None:
        why = _document_problem(path)
    if why is None:
        why = _jobs_problem(path)
    return why


def _config_problem(path: Path) -> str | None:
    """What is wrong with the sweep's signac config (.signac/config), or None."""
    config = path / ".signac" / "config"
    restore = ("remove it and write a file in its place whose whole content is "
               "`schema_version = 2`")
    if config.is_symlink():
        return f"{config} is a symbolic link, not the sweep's own config: {restore}"
    if not config.exists() and (path / ".signac").is_dir() and (
            (path / "workspace").is_dir()
            or (path / "signac_project_document.json").exists()):
        return (f"{config} is missing from a sweep directory: write it: its whole content "
                "is `schema_version = 2`")
    try:
        from signac._config import _read_config_file

        if config.exists():
            _read_config_file(str(config))
    except Exception as exc:  # configobj's errors, an unreadable file
        return (f"{config} is not a signac config ({' '.join(str(exc).split())}); restore "
                "it: its whole content is "
                "`schema_version = 2`")
    return None


def _document_problem(path: Path) -> str | None:
    """What is wrong with the sweep's project document (not a JSON object), or None."""
    import json

    doc = path / "signac_project_document.json"
    if doc.exists():
        try:
            if not isinstance(json.loads(formats.read_text(doc)), dict):
                raise ValueError("not a JSON object")
        except (ValueError, OSError) as exc:
            return (f"{doc} is cut or damaged ({exc}); delete it: it holds the sweep's "
                    "analysis settings, which bkflow collect --analysis NAME=VALUE sets again")
    return None


def _jobs_problem(path: Path) -> str | None:
    """What is wrong with the first job folder of the sweep's workspace that signac cannot
    read (and how many more there are), with its repair; None when every one reads."""
    workspace = path / "workspace"
    if workspace.is_symlink():
        return (f"{workspace} is a symbolic link: bkflow writes a sweep's runs only inside its "
                "directory; replace it with the folder itself")
    bad = []
    for job in sorted(workspace.iterdir()) if workspace.is_dir() else []:
        why = _job_problem(job)
        if why is not None:
            bad.append((job, why))
    if bad:
        job, why = bad[0]
        more = f" (and {len(bad) - 1} more such folders)" if len(bad) > 1 else ""
        fix = ("" if "delete that file" in why else
               ": move it out of workspace/ (the sweep then redoes that run) or restore it")
        return f"{job} {why}{more}{fix}"
    return None


def _job_problem(job: Path) -> str | None:
    """Why signac cannot read the job folder ``job`` as a run of the sweep, or None."""
    import json

    from signac.job import calc_id

    sp = job / "signac_statepoint.json"
    try:
        if job.is_symlink():
            return "is a symbolic link (bkflow writes runs only inside the sweep)"
        if not job.is_dir():
            return "is not a folder"
        if not sp.exists():
            return "has no signac_statepoint.json"
        point = json.loads(formats.read_text(sp))
        if calc_id(point) != job.name:
            return "holds a state point whose hash is not its name (edited, or renamed)"
        try:   # a consistent state point must still be a run bkflow can make
            RunSpec.from_dict(point)
        except SpecError as exc:
            return f"holds a state point that is no run ({exc})"
        except (TypeError, ValueError, KeyError) as exc:
            return f"holds a state point that is no run ({type(exc).__name__}: {exc})"
        jd = job / "signac_job_document.json"
        if jd.exists():
            try:
                json.loads(formats.read_text(jd))
            except ValueError:
                return ("has a cut signac_job_document.json (delete that file: it holds only "
                        "the run's last error)")
        return None
    except (ValueError, OSError) as exc:
        return f"has an unreadable signac_statepoint.json ({exc})"


def check_workspace(path) -> None:
    why = workspace_problem(path)
    if why is not None:
        raise WorkspaceError(why)


def open_project(path, create: bool = True) -> SweepProject:
    """The sweep project at ``path`` (created when ``create`` and it does not exist; a
    directory that is not bkflow's is refused, ``check_sweep_dir``)."""
    import signac

    path = Path(path)
    if not (path / ".signac").is_dir():
        if not create:
            raise FileNotFoundError(f"{path} is not a bkflow sweep directory (no .signac/); "
                                    "run bkflow sweep --out DIR first")
        check_sweep_dir(path)
        path.mkdir(parents=True, exist_ok=True)
        doc = path / "signac_project_document.json"
        if SWEEP_MARK not in _project_document(path):
            # the mark first: a second sweep starting now sees a sweep of ours
            from bkflow import __version__
            from bkflow.store import formats

            formats.write_json_atomic(doc, {**_project_document(path), SWEEP_MARK: __version__})
        signac.init_project(str(path))
    elif create:
        check_sweep_dir(path)
    check_workspace(path)
    project = SweepProject.get_project(str(path), search=False)
    if create and SWEEP_MARK not in project.document:
        from bkflow import __version__

        project.document[SWEEP_MARK] = __version__
    return project


#: the cluster job-script template shipped with the package (flow's SLURM template extended)
TEMPLATE_DIR = Path(__file__).resolve().parent / "templates"


class ClusterProject(SweepProject):
    """SweepProject with bkflow's job-script template (``bkflow/sweeps/templates/script.sh``)."""

    def __init__(self, *args, **kwargs):
        from bkflow.sweeps.flowcompat import set_template_dir

        super().__init__(*args, **kwargs)
        # flow looks for templates in <sweep dir>/templates; ours ships with the package so
        # that every sweep directory uses it without a copy
        set_template_dir(self, TEMPLATE_DIR)

    def _main_submit(self, args):
        """``submit``, once its arguments are good (a bundle of fewer than one run is a bad
        value, exit 2), refused where the environment has no batch scheduler, before flow
        prints anything (its submission lines, then its own error)."""
        size = getattr(args, "bundle_size", None)
        if size is not None and size < 0:   # 0, --bundle alone: every run in one bundle
            raise ValueError(f"--bundle {size}: a bundle holds one run or more (--bundle "
                             "alone: all in one)")
        from flow.environment import get_environment
        from flow.errors import NoSchedulerError

        if getattr(get_environment(), "scheduler_type", None) is None:
            raise NoSchedulerError("no batch scheduler in this environment")
        return super()._main_submit(args)


def permit_above_limits(job, force: bool) -> None:
    """Record in the job's document whether its run may go above the cost limits (``--force``
    of the sweep that made or ran it), which ``simulate`` passes to the engine."""
    if force:
        job.document[FORCE] = True
    elif FORCE in job.document:
        del job.document[FORCE]
