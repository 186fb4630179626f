"""The length a sweep asks of its runs (--t-end, --target-error:
``bkflow.lammps.continuation.LENGTH_FIELDS``): a sweep asked again with another length asks
it of the jobs it has, not of new ones (``open_jobs``), so that its runs go on in place and
its tables keep one row per run; a shorter request is refused (``ShorterRequestError``).
"""

from __future__ import annotations

from pathlib import Path

from bkflow.lammps.continuation import LENGTH_FIELDS, answers, continuation, other_request
from bkflow.model.checks import SpecError
from bkflow.model.params import RunSpec
from bkflow.model.settings import AnalysisSettings
from bkflow.store.rundir import RunDir
from bkflow.sweeps.project import (
    LENGTH,
    check_sweep_dir,
    finished,
    open_project,
    permit_above_limits,
    set_settings,
)


def _set_length(job, spec: RunSpec) -> None:
    sp = job.cached_statepoint
    length = {f: getattr(spec, f) for f in LENGTH_FIELDS if sp.get(f) != getattr(spec, f)}
    if length:
        job.document[LENGTH] = length
    elif LENGTH in job.document:
        del job.document[LENGTH]


class ShorterRequestError(SpecError):
    """A sweep asked for a shorter length than its runs were asked for before."""


def _takes(job, spec: RunSpec) -> bool:
    """Whether the run of ``job`` (a layer's, asked for another length before) goes on to
    ``spec``, or already is its run: nothing it has is simulated again (continued in place,
    ``bkflow.lammps.continuation.continuation``, or answered, ``answers``); a job whose run
    never finished, is damaged or was made under an earlier stop rule takes any length (its
    run is redone anyway). A run another process is writing is taken: the sweep runs the
    others and says that one is busy (its simulate finds it so), as for any busy run."""
    from bkflow.lammps.continuation import finished
    from bkflow.store.errors import RunBusyError

    rd = RunDir(job.path)
    try:
        with rd.lock():
            if not rd.is_complete() or rd.problem() is not None or finished(rd) is None:
                return True   # never finished, damaged, or of an earlier bkflow: redone
            return answers(rd, spec) or continuation(rd, spec) is not None
    except RunBusyError:
        return True


def _steps(job) -> int:
    """The steps the job's finished run ran (0 where none)."""
    meta = RunDir(job.path).meta() or {}
    return int((meta.get("derived") or {}).get("n_steps") or 0)


def check_lengths(path, specs) -> None:
    """Refuse (``ShorterRequestError``), before anything is printed or written, a sweep into
    an existing sweep directory whose runs went further than ``specs`` ask (``open_jobs``)."""
    if (Path(path) / ".signac").is_dir():
        open_jobs(open_project(path, create=False), specs, dry=True)


def open_jobs(project, specs, dry: bool = False) -> list:
    """One job per RunSpec of ``specs``, created where new. A sweep asked again with another
    length (--t-end, --target-error; ``bkflow.lammps.continuation.LENGTH_FIELDS``), when the
    sweep does not vary that length, asks it of the job of the same layer it already has (its
    ``LENGTH``), not of a new job: a run that stopped at its cap goes on from its restart file,
    one that stopped by its rule is left as it is (it answers the longer request), and the
    sweep's tables and figures keep one row per run. A shorter length than a finished run went
    to is refused (``ShorterRequestError``): it would redo the run; so is a grid that varies
    the length over runs asked for another length before. Every job is checked before any is
    created or changed; ``dry``: only that check."""
    specs = list(specs)
    if not dry:
        open_jobs(project, specs, dry=True)
    axes = {f for f in LENGTH_FIELDS if len({getattr(s, f) for s in specs}) > 1}
    jobs = []
    for spec in specs:
        job = project.open_job(spec.to_dict())
        if axes and job in project and LENGTH in job.document:
            raise ShorterRequestError(
                f"the sweep's run of {spec.label} in {job.path} was asked for another length "
                f"by a later sweep ({dict(job.document[LENGTH])}), and this grid varies "
                f"{', '.join(sorted(axes))} over it, which would redo it: sweep into another "
                "--out")
        same = [] if axes else _same_layer(project, job, spec)
        if same:
            job = _taken(same, spec)
            if not dry:
                _set_length(job, spec)
        elif not dry:
            job.init()
        jobs.append(job)
    return jobs


def _same_layer(project, job, spec: RunSpec) -> list:
    """The jobs of ``project`` of ``spec``'s layer (``spec``'s own job where it exists)."""
    if job in project:
        return [job]
    layer = {k: v for k, v in spec.to_dict().items() if k not in LENGTH_FIELDS}
    return list(project.find_jobs(layer))


def _taken(same: list, spec: RunSpec):
    """The job of ``same`` whose run takes ``spec`` (``_takes``), the one that ran furthest
    where several do; ShorterRequestError where none does."""
    same = sorted(same, key=_steps, reverse=True)
    taken = [j for j in same if _takes(j, spec)]
    if not taken:
        why = other_request(RunDir(same[0].path), spec)
        target = "none" if spec.target_error is None else f"{spec.target_error:g}"
        raise ShorterRequestError(
            f"the sweep's run of {spec.label} in {same[0].path} cannot be asked for t_end "
            f"{spec.t_end:g}, target error {target}" + (f": {why}" if why else "")
            + "; a sweep's runs only go on: ask for at least the length they were asked for "
            "before (runs.csv's t_end), or sweep into another --out")
    return taken[0]


def init_jobs(specs, root, settings: AnalysisSettings | None = None,
              force: bool = False) -> int:
    """Create the jobs of ``specs`` in the sweep directory ``root`` without running them (for
    a cluster: ``python -m bkflow.slurm run|submit``); the number already finished. ``force``:
    their runs may go above the cost limits."""
    check_sweep_dir(root)  # before the lock file is made
    with RunDir(root).lock():
        project = open_project(root)
        if settings is not None:
            set_settings(project, settings)
        jobs = open_jobs(project, specs)
        for job in jobs:
            permit_above_limits(job, force)
        return sum(finished(job) for job in jobs)
