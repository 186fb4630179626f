"""The guards around every ``bkflow`` command: its exit codes (``EXIT_CODES``), the checks of
the process before a command starts (its limits, the MPI launcher, the environment, the
current directory, the names it was given) and the one line and exit code of every way a
command can fail, a bug of bkflow's own included.

Every expected failure is one line on stderr and an exit code of ``EXIT_CODES``; nothing
half-written is left looking complete.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from bkflow import __version__

EXIT_RUN_FAILED = 1
EXIT_BAD_INPUT = 2
EXIT_BUSY = 3
EXIT_FILE_SYSTEM = 4
EXIT_RESOURCES = 5
EXIT_INTERNAL = 70
EXIT_INTERRUPTED = 130
EXIT_BROKEN_PIPE = 141
#: what every exit code of bkflow means (README, "Exit codes")
EXIT_CODES = {
    0: "done",
    EXIT_RUN_FAILED: "a run failed (blew up, tore apart, LAMMPS error); nothing of it looks "
                     "finished",
    EXIT_BAD_INPUT: "bad input or a refused request (a bad argument, parameters whose derived "
                    "quantities overflow or underflow, a directory that is not bkflow's, a "
                    "finished run without --overwrite, a damaged run: a file cut, changed or "
                    "another run's, its restart file included, or a record holding a value "
                    "the model cannot give; a request above the cost limits without --force); "
                    "an analysis that finds a stress ratio above what the contacts hold stops "
                    "here too",
    EXIT_BUSY: "another bkflow process is writing the same run or sweep",
    EXIT_FILE_SYSTEM: "the file system refused (permissions, full disk, a file where a "
                      "directory should be, a name too long, the directory removed while "
                      "bkflow wrote into it)",
    EXIT_RESOURCES: "out of memory, open files or file size (the machine's, or a limit set "
                    "on the process: ulimit -v, -n, -f)",
    EXIT_INTERNAL: "a bug in bkflow: one line, the traceback saved to a file it names",
    EXIT_INTERRUPTED: "interrupted (Ctrl-C, SIGTERM, SIGHUP); the same command resumes",
    EXIT_BROKEN_PIPE: "the output's reader went away (e.g. | head)",
}


def say(line: str) -> None:
    """One line on stderr."""
    print(line, file=sys.stderr)


def progress_newline() -> str:
    """A newline to end a progress line on a terminal; nothing elsewhere (one line)."""
    try:
        return "\n" if sys.stderr.isatty() else ""
    except (AttributeError, ValueError):
        return ""


# ------------------------------------------------------------------------- the process
def interrupt_signals() -> tuple:
    """The signals the command takes as Ctrl-C: SIGTERM and SIGHUP (a closed terminal), but
    a signal this process was started with ignored stays ignored (nohup: SIGHUP)."""
    import signal

    return tuple(s for s in (signal.SIGTERM, signal.SIGHUP)
                 if signal.getsignal(s) != signal.SIG_IGN)


#: the process limits below which MPI, LAMMPS or the libraries under bkflow end the process
#: from C (UCX or MPICH aborts, exit 134 or 143; the BLAS under SciPy exits 1 when it cannot
#: allocate its buffers under ~320 MB): resource, ulimit option, minimum, unit (bytes), what
PROCESS_LIMITS = (
    ("RLIMIT_AS", "-v", 512, 2**20, "out of memory: this process may use at most {have} MB "
     "(ulimit -v, or the job's limit); bkflow needs at least {need} MB to load its libraries"),
    ("RLIMIT_NOFILE", "-n", 64, 1, "error: this process may open at most {have} files "
     "(ulimit -n); MPI and LAMMPS need at least {need}"),
    ("RLIMIT_FSIZE", "-f", 64, 2**20, "error: this process may write files of at most {have} "
     "MB (ulimit -f); MPI's shared memory needs {need} MB, and a run's series more"),
)


def process_limit_short() -> str | None:
    """The first process limit (``PROCESS_LIMITS``) below what bkflow needs, said."""
    import resource

    for name, _, need, unit, said in PROCESS_LIMITS:
        soft, _ = resource.getrlimit(getattr(resource, name))
        if soft != resource.RLIM_INFINITY and soft / unit < need:
            return said.format(have=f"{soft / unit:.3g}", need=need)
    return None


def guarded(command) -> int:
    """``command()``'s exit code, run once the process' limits are checked, with stdout and
    stderr writable, and every failure that is no command's own (an interrupt before it
    started, a reader gone, memory out, a bug) turned into one line and its exit code."""
    short = process_limit_short()
    if short is not None:
        say(f"bkflow: {short}: raise the limit")
        return EXIT_RESOURCES
    for name in ("stdout", "stderr"):  # closed by the caller (2>&-): write into the void
        if getattr(sys, name) is None:
            setattr(sys, name, open(os.devnull, "w"))  # noqa: SIM115 (for the process' life)
    try:
        return command()
    except KeyboardInterrupt:  # before a command started (while Python imports)
        say(f"{progress_newline()}bkflow: interrupted before anything was written")
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        # the reader of our output went away (| head): say nothing more
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
    except ImportError as exc:  # a library that cannot be mapped into memory is out of it
        if "failed to map segment" not in str(exc) and "Cannot allocate" not in str(exc):
            return internal_error()
        return out_of_memory()
    except MemoryError:
        return out_of_memory()
    except Exception:  # a bug: one line, and the traceback where it can be reported from
        return internal_error()


def out_of_memory() -> int:
    say("bkflow: out of memory: this machine (or its limit, ulimit -v or the job's) "
        "cannot hold what the command needs; nothing finished was changed: free "
        "memory, raise the limit, or ask for a smaller run")
    return EXIT_RESOURCES


def internal_error() -> int:
    """A bug: one line, the traceback of the exception being handled saved to a file."""
    import tempfile
    import traceback

    text = traceback.format_exc()
    try:
        fd, path = tempfile.mkstemp(prefix="bkflow-error-", suffix=".txt")
        with os.fdopen(fd, "w", errors="backslashreplace") as f:
            f.write(f"bkflow {__version__}: {' '.join(sys.argv)}\n{text}")
        where = f"the traceback is in {path}"
    except OSError:
        where = "the traceback could not be saved"
    last = text.strip().splitlines()[-1]
    say(f"bkflow: internal error ({last}); {where}: please report it with the command "
        "that caused it; nothing finished was changed")
    return EXIT_INTERNAL


# ------------------------------------------------------------------------- before a command
def mpi_refused() -> int | None:
    """EXIT_BAD_INPUT, said, when an MPI launcher started bkflow as several processes."""
    from bkflow.lammps.limits import mpi_refusal

    why = mpi_refusal()
    if why:  # before anything, --help and --version included: one line a copy
        say(f"bkflow: error: {why}")
        return EXIT_BAD_INPUT
    return None


def paths_refused(paths) -> int | None:
    """An exit code, said, when a path the command writes or reads cannot be used: a name
    that is not UTF-8, or a relative one under a current directory that no longer exists
    (with every path absolute, the command runs from ``/``)."""
    for p in paths:
        try:
            str(p).encode("utf-8")
        except UnicodeEncodeError:
            say(f"bkflow: error: {os.fsencode(str(p))!r} is not a UTF-8 name: bkflow's "
                "tables and records (JSON, CSV) need one; choose another")
            return EXIT_BAD_INPUT
    try:
        os.getcwd()
    except FileNotFoundError:
        if not paths or not all(os.path.isabs(str(p)) for p in paths):
            say("bkflow: error: the current directory no longer exists (deleted while this "
                "shell stood in it): cd to an existing directory, or give absolute paths")
            return EXIT_FILE_SYSTEM
        os.chdir("/")  # every path is absolute: the lost directory is not needed
    return None


def _thread_count(text: str) -> bool:
    return text.strip().isdigit() and int(text) > 0


def _check_threads(env) -> None:
    """The thread counts of numexpr and OpenMP, whose libraries read them."""
    from bkflow.model.checks import SpecError

    for var in ("NUMEXPR_MAX_THREADS", "NUMEXPR_NUM_THREADS"):
        v = env.get(var, "")
        if v and not _thread_count(v):
            raise SpecError(f"environment variable {var}={v!r} is not a number of threads "
                            "(numexpr, under pandas, reads it): unset it or give an integer")
    omp = env.get("OMP_NUM_THREADS", "")
    if omp:
        if not all(_thread_count(n) for n in omp.split(",")):
            raise SpecError(f"environment variable OMP_NUM_THREADS={omp!r} is not an OpenMP "
                            "thread count (e.g. 4, or 4,2 for nested levels): unset it or fix it")
        if "," in omp and not env.get("NUMEXPR_NUM_THREADS"):
            env["NUMEXPR_NUM_THREADS"] = omp.split(",")[0].strip()  # numexpr reads one level


def check_environment(env=os.environ) -> None:
    """The environment variables the libraries under bkflow read, checked before any of them
    is imported, so that a bad one is named rather than reported as a damaged file (numexpr,
    under pandas, fails to read a bad OMP_NUM_THREADS). Adjusts what the command line does
    not need: figures are written to files (matplotlib's Agg backend, whatever MPLBACKEND
    says), and a local run or sweep submits nothing (flow's SIGNAC_FLOW_ENVIRONMENT is for
    python -m bkflow.slurm)."""
    from bkflow.model.checks import SpecError

    _check_threads(env)
    env["MPLBACKEND"] = "Agg"
    env.pop("SIGNAC_FLOW_ENVIRONMENT", None)
    bad = [k for k in env if k.startswith("TQDM_")]
    if bad:
        try:
            from tqdm import tqdm

            tqdm(total=1, disable=True).close()
        except Exception as exc:
            raise SpecError(f"environment variable {', '.join(sorted(bad))}: tqdm (the progress "
                            f"bars) cannot read it ({exc}): unset it or fix it") from None


def environment_refused() -> int | None:
    """EXIT_BAD_INPUT, said, when ``check_environment`` refuses the environment."""
    from bkflow.model.checks import SpecError

    try:
        check_environment()
    except SpecError as exc:
        say(f"bkflow: error: {exc}")
        return EXIT_BAD_INPUT
    return None


# ------------------------------------------------------------------------- a command's failure
def _fs_message(exc: OSError) -> str:
    where = f"{exc.filename}: " if exc.filename else ""
    return f"{where}{exc.strerror or exc}"


def _one_line(exc) -> str:
    return " ".join(str(exc).splitlines())


def _unreadable(exc, a) -> int:
    """A run that cannot be analysed: named by its directory unless the message names it."""
    target = a.dir if a.cmd == "analyze" else a.out if a.cmd == "run" else None
    text = _one_line(exc)
    named = target is not None and any(
        text.startswith(str(p)) for p in (target, Path(target).absolute(),
                                          Path(target).resolve()))
    where = f"cannot analyse {target}: " if target is not None and not named else ""
    say(f"bkflow: error: {where}{text}")
    return EXIT_BAD_INPUT


def _missing(exc: FileNotFoundError, a) -> int:
    """A file not found: the output directory removed under a run or sweep, or a bad path."""
    out = getattr(a, "out", None) if a.cmd in ("run", "sweep") else None
    missing = Path(str(exc.filename or "")).absolute()
    if out is not None and not Path(out).exists() and \
            Path(out).absolute() in (missing, *missing.parents):   # removed under it
        say(f"bkflow: file system: {out} was removed while bkflow wrote into it; the "
            "same command starts it again")
        return EXIT_FILE_SYSTEM
    say(f"bkflow: error: {_fs_message(exc)}")
    return EXIT_BAD_INPUT


def _interrupted(exc, a) -> int:
    what = ("finished runs are kept, an interrupted one is redone" if a.cmd in ("run",
            "sweep") else "what was written is whole, the rest unchanged")
    say(f"{progress_newline()}bkflow: interrupted; {what}: run the same command again to "
        "resume")
    return EXIT_INTERRUPTED


def _said(prefix: str, code: int, one_line: bool = False):
    def failure(exc, a) -> int:
        say(f"{prefix}{_one_line(exc) if one_line else exc}")
        return code
    return failure


def _file_system(exc: OSError, a) -> int:
    # permissions, a full disk, a name too long, a file for a directory
    say(f"bkflow: file system: {_fs_message(exc)}; nothing finished was changed")
    return EXIT_FILE_SYSTEM


def _reraise(exc, a) -> int:
    raise exc


def failure_handlers() -> list:
    """(exception classes, handler) of a command's failures, in the order they are told
    apart (a subclass before its base); a handler says the failure's line and returns its
    exit code."""
    from bkflow.lammps.engine import RunDiskError, RunError, RunExistsError
    from bkflow.lammps.plugin import PluginError
    from bkflow.model.checks import SpecError
    from bkflow.store.errors import AnalysisError, DamagedRunError, RunBusyError
    from bkflow.store.files import NotRegularFileError, OutsideError

    return [
        (NotRegularFileError, _said("bkflow: error: ", EXIT_BAD_INPUT)),
        ((AnalysisError, DamagedRunError), _unreadable),
        ((SpecError, RunExistsError, PluginError, OutsideError),
         _said("bkflow: error: ", EXIT_BAD_INPUT, one_line=True)),
        (RunBusyError, _said("bkflow: busy: ", EXIT_BUSY)),
        (RunDiskError, _said("bkflow: file system: ", EXIT_FILE_SYSTEM)),
        (RunError, _said("bkflow: run failed: ", EXIT_RUN_FAILED)),
        (FileNotFoundError, _missing),
        (BrokenPipeError, _reraise),
        (OSError, _file_system),
        (KeyboardInterrupt, _interrupted),
    ]


def failed(exc: BaseException, a, handlers: list) -> int:
    """The exit code of command ``a.cmd`` that raised ``exc``, its line said by the first of
    ``handlers`` (``failure_handlers``) that takes it; an exception none takes (a bug, memory
    out, the output's reader gone) is raised again, for ``guarded``."""
    for types, handler in handlers:
        if isinstance(exc, types):
            return handler(exc, a)
    raise exc
