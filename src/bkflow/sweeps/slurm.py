"""A sweep on a cluster: ``python -m bkflow.slurm status|run|submit|exec ...``, run inside a
sweep directory (``bkflow sweep ... --out DIR --init`` creates one without running it).

This is signac-flow's command line for ``bkflow.sweeps.project.ClusterProject``, whose
operations ``simulate`` and ``analyze`` are the ones ``bkflow sweep`` runs locally, and whose
job-script template ships with the package (``bkflow/sweeps/templates/script.sh``): it works from a
wheel as from a checkout. The job scripts it submits call ``python -m bkflow.slurm`` again
(the python that submitted, whose environment holds bkflow):

    bkflow sweep --phi 1e-1:1e3 --sizes 100,400,900 --seeds 3 --out grid --init
    cd grid
    python -m bkflow.slurm status
    python -m bkflow.slurm submit --bundle 16 --parallel --pretend   # show the scripts
    python -m bkflow.slurm submit --bundle 16 --parallel             # sbatch
    python -m bkflow.slurm run -p 2                                # or here, 2 at a time
    bkflow collect .
"""

from __future__ import annotations

import contextlib
import logging
import os
import shlex
import sys
from pathlib import Path


def project(path=None):
    """The cluster project of the sweep directory ``path`` (default: the current one), whose
    submitted commands are ``<this python> -m bkflow.slurm ...``."""
    from bkflow.sweeps.project import ClusterProject

    return ClusterProject.get_project(
        os.getcwd() if path is None else str(path),
        # quoted: flow writes it into the job scripts' shell lines as it is, where a space in
        # the path would split it and a "$(...)" in it would run
        entrypoint={"executable": shlex.quote(sys.executable), "path": "-m bkflow.slurm"})


def main(argv=None) -> None:
    if argv is not None:
        sys.argv[1:] = list(argv)
    from bkflow.lammps.limits import mpi_refusal

    why = mpi_refusal()
    if why:  # K copies of one command in one MPI world: they would wait forever
        print(f"bkflow.slurm: error: {why}", file=sys.stderr)
        sys.exit(2)
    _check_environment()
    p = _sweep_project()
    from bkflow.model.checks import SpecError
    from bkflow.sweeps.project import check_workspace

    try:
        check_workspace(p.path)  # a hand-edited workspace: named with its repair
    except SpecError as exc:
        print(f"bkflow.slurm: error: {exc}", file=sys.stderr)
        sys.exit(2)
    # flow logs a scheduler's failure before raising it: the one line below says it instead
    logging.getLogger("flow").setLevel(logging.CRITICAL)
    unknown = unknown_operations(p, sys.argv[1:])
    if unknown:  # flow would select nothing, run nothing, and exit 0
        print(f"bkflow.slurm: error: no operation {', '.join(unknown)}: the operations are "
              f"{', '.join(sorted(p.operations))}", file=sys.stderr)
        sys.exit(2)
    acting = sys.argv[1:2] in (["run"], ["exec"]) and "--pretend" not in sys.argv
    before = _errors(p) if acting else {}
    _run(p)
    if acting:
        _exit_if_failed(p, before)


def _errors(p) -> dict:
    """{job id: the failure its document keeps} of the project ``p``'s jobs."""
    from bkflow.sweeps.project import failed

    return {j.id: j.document["error"] for j in p if failed(j)}


def _exit_if_failed(p, before: dict) -> None:
    """After ``run``/``exec``: exit 1 with the first failure when a run failed in this pass
    (a failure recorded or changed since ``before``: each is kept in its job document, and
    flow itself goes on and exits 0), so that a job script, and a user, see it."""
    new = {k: v for k, v in _errors(p).items() if before.get(k) != v}
    if new:
        print(f"bkflow.slurm: error: {len(new)} run(s) failed; the first: "
              f"{next(iter(new.values()))}", file=sys.stderr)
        sys.exit(1)


def unknown_operations(p, argv: list[str]) -> list[str]:
    """The names given to ``-o``/``--operation`` in ``argv`` that match neither an operation
    nor a group of the project ``p`` (flow reads each as a regular expression, matched whole:
    ``-o 'sim.*'``)."""
    import re

    known = set(p.operations) | set(getattr(p, "_groups", {}))

    def matches(name: str) -> bool:
        try:
            return any(re.fullmatch(name, k) for k in known)
        except re.error:
            return False

    names, taking = [], False
    for arg in argv:
        if arg in ("-o", "--operation"):
            taking = True
        elif arg.startswith("--operation="):
            names.append(arg.split("=", 1)[1])
            taking = False
        elif arg.startswith("-"):
            taking = False
        elif taking:
            names.append(arg)
    return [n for n in names if not matches(n)]


def _check_environment() -> None:
    """Exit 2 naming the environments signac-flow knows when SIGNAC_FLOW_ENVIRONMENT names
    none of them."""
    env = os.environ.get("SIGNAC_FLOW_ENVIRONMENT")
    if env:
        from flow.environment import get_environment

        try:
            get_environment()
        except ValueError:
            from flow.environment import ComputeEnvironment

            known = sorted(c.__name__ for c in _subclasses(ComputeEnvironment))
            print(f"bkflow.slurm: error: SIGNAC_FLOW_ENVIRONMENT={env} is no environment "
                  f"signac-flow knows (it knows {', '.join(known)}): unset it, or name one of "
                  "those", file=sys.stderr)
            sys.exit(2)


def _sweep_project():
    """The cluster project of the current directory; where there is none, exit: 2 naming
    the damaged records of a sweep or saying it is no sweep directory, 0 after the help."""
    try:
        return project()
    except LookupError:
        if Path(".signac").is_dir():   # a sweep directory whose signac records are damaged
            from bkflow.sweeps.project import workspace_problem

            why = workspace_problem(Path.cwd())
            if why is not None:
                print(f"bkflow.slurm: error: {why}", file=sys.stderr)
                sys.exit(2)
        if {"-h", "--help"} & set(sys.argv[1:]):
            with contextlib.suppress(BrokenPipeError):
                print(__doc__)
            sys.exit(0)
        print(f"bkflow.slurm: error: {os.getcwd()} is not a sweep directory (no signac "
              "project here): run it inside the --out directory of bkflow sweep ... --init",
              file=sys.stderr)
        sys.exit(2)  # bad input, as bkflow's own commands


def _run(p) -> None:
    """flow's command line of the project ``p``; its failures as one line and an exit code:
    130 after Ctrl-C, 2 for a bad job id or option, 1 for anything else."""
    try:
        p.main()
    except KeyboardInterrupt:
        sys.exit(130)
    except (LookupError, ValueError, TypeError) as exc:  # no such job, a bad option value
        first = " ".join((str(exc).strip().splitlines() or [type(exc).__name__])[0].split())
        print(f"bkflow.slurm: error: {first}: check the job ids and options "
              "(python -m bkflow.slurm COMMAND --help)", file=sys.stderr)
        sys.exit(2)  # bad input, as bkflow's own commands
    except Exception as exc:  # flow asks the scheduler (squeue) for the status of every job
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        hint = (_scheduler_hint(sys.argv[1:]) if _from_scheduler(exc) else
                f" ({type(exc).__name__}; bkflow.slurm did not expect it: please report it)")
        print(f"bkflow.slurm: error: {first}{hint}", file=sys.stderr)
        sys.exit(1)


def _scheduler_hint(argv: list[str]) -> str:
    """What to do when the scheduler failed or there is none: a command that works without
    one. ``submit`` (``--pretend`` too: flow asks the queue first) needs a working scheduler;
    without one the jobs run here, with ``run``."""
    standard = os.environ.get("SIGNAC_FLOW_ENVIRONMENT") == "StandardEnvironment"
    here = ("SIGNAC_FLOW_ENVIRONMENT=StandardEnvironment "
            f"{shlex.quote(sys.executable)} -m bkflow.slurm")
    if argv and argv[0] == "submit":
        return (" (submit needs a working batch scheduler (sbatch, squeue), and this machine "
                f"has {'none' if standard else 'no working one'}: run the jobs here instead, "
                f"{here} run -p 2)")
    if standard:  # cannot happen for run/status/exec, which flow runs without a scheduler
        return " (no batch scheduler in this environment: use run, not submit)"
    rest = " ".join(shlex.quote(a) for a in argv)
    return f" (if this machine has no working scheduler, run without one: {here} {rest})"


#: the commands of the schedulers signac-flow drives
SCHEDULER_COMMANDS = ("squeue", "sbatch", "scancel", "sinfo", "qstat", "qsub", "bjobs", "bsub")


def _from_scheduler(exc: BaseException) -> bool:
    """Whether ``exc`` (or what caused it) is a scheduler's failure: one of its commands
    failed or is missing, or flow says submitting failed."""
    import subprocess

    seen = set()
    while exc is not None and id(exc) not in seen:
        seen.add(id(exc))
        if isinstance(exc, subprocess.CalledProcessError):
            cmd = exc.cmd[0] if isinstance(exc.cmd, (list, tuple)) else str(exc.cmd).split()[0]
            if os.path.basename(str(cmd)) in SCHEDULER_COMMANDS:
                return True
        if isinstance(exc, FileNotFoundError) and os.path.basename(
                str(exc.filename or "")) in SCHEDULER_COMMANDS:
            return True
        if type(exc).__name__ in ("SubmitError", "NoSchedulerError"):
            return True
        exc = exc.__cause__ or exc.__context__
    return False


def _subclasses(cls) -> list:
    out = []
    for sub in cls.__subclasses__():
        out += [sub, *_subclasses(sub)]
    return out


if __name__ == "__main__":
    main()
