"""The run directory: every file a run and its analysis write, and the checks on them.

This module is the only one that knows a run directory's layout. The engine writes the deck,
the data file and LAMMPS's outputs here and commits the run by writing ``meta.json`` last
(atomically, with the size of every file, so a cut file is detected); the analysis reads the
run's tables and writes its own; sweeps and figures ask the checks below. Nothing else names
a file of a run.

| file | what |
|---|---|
| ``in.bk``, ``data.bk`` | the LAMMPS deck and data file (``lmp -in in.bk`` runs it again) |
| ``params.json`` | the RunSpec of a deck written by ``bkflow deck`` |
| ``extrema.npy`` | sigma_x's turning points at the extrema threshold (observables.reduced) |
| ``blocks.npy`` | sums of sigma_x and of the contacts' phases over blocks (observables.reduced) |
| ``stress.npy`` | step, sigma_x: the raw shear stress (scenes series, full; + the ledger) |
| ``phase.npy`` | step, R, Z_re, Z_im, R2, u_mean, u_std: the raw load phases (series, full) |
| ``stress.csv``, ``phase.csv`` | the same as text, in runs of bkflow before 0.5 |
| ``psi.npy`` | Psi(t) every snapshot_nevery steps, computed in the run (order, figures, full) |
| ``snapshots.lammpstrj`` | positions every snapshot_nevery steps (scene full) |
| ``slips.npy``, ``clusters.npy`` | each slip's catalogue row and clusters, from the run (figures) |
| ``slips.lammpstrj`` | positions at every slip's maximum and minimum (+ first breaks) |
| ``fronts.bin`` | every particle's slip rate through the first slips (scenes fronts, full) |
| ``log.lammps`` | LAMMPS's log |
| ``restart.STEP.bk`` | LAMMPS's restart file of the last step: a longer run continues from it |
| ``meta.json`` | the completion record: parameters, versions, counters, sizes |
| ``summary.json`` | the analysis: every observable, the settings it was made under |
| ``events.parquet`` | the event catalogue, one row per slip (bkflow.observables.catalogue), typed |
| ``psi.csv`` | ``t,psi``: Psi(t) of a run made before bkflow computed it in the run |
| ``clusters.csv`` | one row per slip cluster (scenes clusters, events, full) |
| ``companion/`` | the companion run (RunSpec.companion), a run directory itself |
| ``.bkflow-run`` | the mark that bkflow made the directory (written first) |
| ``.bkflow.lock`` | the lock a process holds while it writes the run |

The scenes events and full add to extrema.npy and blocks.npy (and full to stress.csv) the
contact breaks and the energy ledger (``LEDGER_COLUMNS``) and to slips.lammpstrj each
contact's first break in the slip (column ``brk``); events.parquet then holds the catalogue's
size, shape, nucleation, front and energy
columns, clusters.csv the paper's energy argument per cluster.
"""

from __future__ import annotations

import contextlib
import dataclasses
import errno
import os
from pathlib import Path

import numpy as np

from bkflow.model.params import ANALYSIS_REVISION, AnalysisSettings, RunSpec

# the columns of the ledger (stress.csv's after t, sigma_x in the scenes that keep it, fix
# bk/stress ``energy``; the records' fields): named once, in bkflow.observables.reduced
from bkflow.observables.reduced import LEDGER_COLUMNS  # noqa: F401
from bkflow.store import formats

DECK = "in.bk"
DATA = "data.bk"
PARAMS = "params.json"
#: the raw series (scenes series, full), binary: step and sigma_x (+ the ledger), step and the
#: phase statistics
SERIES_STRESS = "stress.npy"
SERIES_PHASE = "phase.npy"
#: the raw series as CSV: what bkflow wrote before 0.5 (read)
STRESS = "stress.csv"
PHASE = "phase.csv"
SNAPSHOTS = "snapshots.lammpstrj"
SLIPS = "slips.lammpstrj"
FRONTS = "fronts.bin"
#: the records of fix bk/reduce (bkflow.observables.reduced): sigma_x's turning points, the block
#: sums
EXTREMA = "extrema.npy"
BLOCKS = "blocks.npy"
#: Psi(t) computed in the run (fix bk/psi): step, psi
PSI_RECORD = "psi.npy"
#: each slip's row of the event catalogue and its clusters, computed in the run (fix bk/slips
#: ``catalogue``, scene figures)
SLIP_ROWS = "slips.npy"
CLUSTER_ROWS = "clusters.npy"
LOG = "log.lammps"
META = "meta.json"
#: LAMMPS's restart file of the run's last step (named by that step; meta.json's "restart"
#: names it): a longer run of the same parameters continues from it (bkflow.lammps.engine), never
#: simulating again what the run has
RESTART = "restart.{}.bk"
#: written while a finished run is being continued (the sizes of its files before): an
#: interrupted continuation is undone to the finished run (``undo_continuation``)
CONTINUING = ".bkflow-continuing"
SUMMARY = "summary.json"
#: the event catalogue as CSV: what bkflow wrote before 0.5 beside the Parquet (read, removed
#: when the run is analysed again)
EVENTS = "events.csv"
#: the event catalogue (typed, columnar): one row per slip
EVENTS_PARQUET = "events.parquet"
PSI = "psi.csv"
CLUSTERS = "clusters.csv"
LOCK = ".bkflow.lock"
#: written when bkflow begins a run in a directory (its version and the time): the run's files
#: written after it are bkflow's to replace; one older than it, or a mark bkflow did not write,
#: is not (RunDir.foreign; docs/running.md "What bkflow replaces")
MARK = ".bkflow-run"
#: files signac keeps in a sweep's job directory
SIGNAC_FILES = ("signac_statepoint.json", "signac_job_document.json")

def bookkeeping(name: str) -> bool:
    """A name bkflow leaves in any directory it writes: its lock, an atomic writer's
    temporary."""
    return name == LOCK or (name.startswith(".") and name.endswith(".tmp"))


def listing(names) -> str:
    """A few of ``names`` for a message: "a, b, c and 4 more"."""
    shown = sorted(names)
    return ", ".join(shown[:3]) + (f" and {len(shown) - 3} more" if len(shown) > 3 else "")


#: the files of a finished run that may change without damaging it: LAMMPS's log, which
#: `lmp -in in.bk` in the finished directory rewrites (the rest it writes again bit for bit)
MAY_CHANGE = (LOG,)
#: a file of a run's names as much older than the run's mark as this is still the run's
#: (file systems that keep times in whole or two seconds)
MARK_SLACK_S = 2.0
#: what a run writes (the engine); a partial run's are removed before it is redone
RUN_FILES = (DECK, DATA, EXTREMA, BLOCKS, PSI_RECORD, SLIP_ROWS, CLUSTER_ROWS, SERIES_STRESS,
             SERIES_PHASE, STRESS, PHASE, SNAPSHOTS, SLIPS, FRONTS, LOG, META)
#: what the analysis writes
ANALYSIS_FILES = (SUMMARY, EVENTS, EVENTS_PARQUET, PSI, CLUSTERS)
#: what ``bkflow movie`` draws from a run's fronts (one pair per slip asked for)
MOVIE_PATTERN, FRONT_MAPS_PATTERN = "movie_slip{}.gif", "fronts_slip{}.png"
#: a sweep directory keeps its runs in signac's workspace/<job id>/
WORKSPACE = "workspace"
#: the subdirectory of a run that holds its companion run (RunSpec.companion), itself a run
#: directory
COMPANION = "companion"

#: columns of the contacts' phase series (fix bk/phase)
PHASE_COLUMNS = ("t", "R", "Z_re", "Z_im", "R2", "u_mean", "u_std")
#: columns of the analysis's tables
EVENT_COLUMNS = ("t_max", "t_min", "sigma_fail", "drop", "late")
PSI_COLUMNS = ("t", "psi")
CLUSTER_COLUMNS = ("event", "t", "n_c", "l_x", "l_y")


#: run directories whose lock this process holds
_HELD: set[str] = set()


class AnalysisError(ValueError):
    """A run directory that cannot be analysed (nothing finished there, or damaged files)."""


class RunBusyError(RuntimeError):
    """Another process is writing this run directory now (its lock is held)."""


class DamagedRunError(ValueError):
    """A run directory whose files are not what its completion record says, or unreadable."""


#: the file systems without flock (Lustre mounted without -o flock, some NFS) have been
#: warned about once
_WARNED_NO_FLOCK: set[str] = set()


class RunDir:
    """One run directory: its files, its completion record and its checks.

    >>> d = RunDir("runs/phi10")
    >>> d.path.name, d.file(STRESS).name
    ('phi10', 'stress.csv')
    """

    def __init__(self, path):
        self.path = Path(path)

    def __repr__(self) -> str:
        return f"RunDir({str(self.path)!r})"

    def file(self, name: str) -> Path:
        return self.path / name

    # ------------------------------------------------------------------ the completion record
    def _record(self, name: str) -> dict | None:
        try:
            record = formats.read_json(self.file(name))
        except (OSError, ValueError):
            return None
        return record if isinstance(record, dict) else None

    def meta(self) -> dict | None:
        """meta.json, or None when there is none or it is unreadable."""
        return self._record(META)

    def check_record_readable(self) -> None:
        """Raise the OSError of a meta.json that is there but cannot be read (permissions, a
        directory, a symlink loop): bkflow cannot tell whether the run is finished, so it
        neither redoes nor analyses it (exit 4), where a missing one means an interrupted run."""
        for d in (self, self.companion()):
            meta = d.file(META)
            if os.path.lexists(meta):
                with open(formats.regular(meta), "rb"):
                    pass

    def is_complete(self) -> bool:
        """meta.json says the run finished (sizes not checked: see ``problem``)."""
        meta = self.meta()
        return meta is not None and meta.get("status") == "complete"

    def problem(self) -> str | None:
        """Why this directory does not hold an intact finished run, or None when it does.

        Finished means meta.json says complete and every file it lists still has the size it
        had when the run ended; a truncated, emptied or missing output file is named.
        """
        try:
            meta = formats.read_json(self.file(META))
        except FileNotFoundError:
            return "not run (no meta.json)"
        except (OSError, ValueError) as exc:
            return f"meta.json unreadable ({exc})"
        if not isinstance(meta, dict) or meta.get("status") != "complete":
            return "meta.json does not say complete"
        for name, size in meta.get("file_bytes", {}).items():
            if self.file(name).is_symlink():   # not the run's file (and not to be written)
                return f"{name} is a symbolic link"
            if name in MAY_CHANGE:
                continue
            try:
                actual = self.file(name).stat().st_size
            except OSError:
                return f"{name} is missing"
            if actual != size:
                return f"{name} has {actual} bytes, the run wrote {size}"
        if meta.get("companion"):
            comp = self.companion()
            if comp.path.is_symlink():
                return f"its companion ({COMPANION}/) is a symbolic link, not this run's"
            try:
                comp_meta = formats.read_json(comp.file(META))
            except (OSError, ValueError):
                comp_meta = None
            if isinstance(comp_meta, dict):   # whose run it is, before whether it is whole
                why = self._foreign_companion(meta, comp_meta)
                if why is not None:
                    return why
            why = comp.problem()
            if why is not None:
                return f"its companion run ({COMPANION}/) is damaged: {why}"
        return None

    def restart_files(self) -> list[Path]:
        """Every restart file in the directory (the run's, and any left by a continuation
        that did not finish)."""
        return sorted(self.path.glob(RESTART.format("*")))

    #: the records a continuation rewrites in place (their header and the record under way),
    #: kept as they were until it commits: cutting them back to their size is not enough
    REWRITTEN = (EXTREMA, BLOCKS, PSI_RECORD, SLIP_ROWS, CLUSTER_ROWS, SERIES_STRESS,
                 SERIES_PHASE)

    def _before(self, name: str) -> Path:
        return self.file(f".{name}.before-continuing.tmp")

    def begin_continuation(self) -> None:
        """Note that the finished run here is being continued (its record stays as it is):
        the records it rewrites in place are kept aside, and the note names the finished
        run's restart file (what tells an interrupted continuation from one that committed)."""
        for name in self.REWRITTEN:
            if self.file(name).is_file():
                data = formats.read_bytes(self.file(name))
                with formats.atomic_file(self._before(name), binary=True) as f:
                    f.write(data)
        formats.write_text_atomic(self.file(CONTINUING), str((self.meta() or {}).get("restart")))

    def end_continuation(self, keep: str | None) -> None:
        """After the new record is committed: remove the continuation's note and every
        restart file but ``keep``."""
        for p in self.restart_files():
            if p.name != keep:
                p.unlink(missing_ok=True)
        for name in self.REWRITTEN:
            self._before(name).unlink(missing_ok=True)
        self.file(CONTINUING).unlink(missing_ok=True)

    def undo_continuation(self) -> bool:
        """A continuation interrupted before it committed: cut every recorded file back to
        the size the record gives it (what the continuation appended goes), remove the restart
        files it left, and the note; the finished run is as it was. Returns whether there was
        one to undo."""
        if not self.file(CONTINUING).exists():
            return False
        meta = self.meta() or {}
        try:
            noted = formats.read_text(self.file(CONTINUING)).strip()
        except (OSError, ValueError):
            noted = ""
        if noted and noted != str(meta.get("restart")):
            # the continuation committed (the record names its own restart file) and was
            # stopped before it cleaned up: finish that, the committed run stays
            self.end_continuation(meta.get("restart"))
            return True
        sizes = meta.get("file_bytes", {})
        for name in self.REWRITTEN:
            if self._before(name).is_file():
                os.replace(self._before(name), self.file(name))
        for name, size in sizes.items():
            p = self.file(name)
            if name not in MAY_CHANGE and p.is_file() and p.stat().st_size > size:
                os.truncate(p, size)
        keep = meta.get("restart")
        for p in self.restart_files():
            if p.name != keep:
                p.unlink(missing_ok=True)
        self.file(CONTINUING).unlink(missing_ok=True)
        return True

    @staticmethod
    def _foreign_companion(meta: dict, comp: dict) -> str | None:
        """Why the finished companion run is not this run's (the same model and seed from the
        companion's start, as long), or None."""
        try:
            want = RunSpec.from_dict(meta["params"]).companion_spec
        except Exception:   # the run's own record is what is damaged: said where it is read
            return None
        try:
            got = RunSpec.from_dict(comp["params"])
        except Exception:   # a record without parameters: not a companion of bkflow's
            return f"its companion ({COMPANION}/) has no readable parameters"
        if want is None or got != want:
            return (f"its companion ({COMPANION}/) is not this run's (another model, seed, start "
                    "or length): it was replaced")
        return None

    def companion(self) -> RunDir:
        """The run directory of this run's companion (RunSpec.companion)."""
        return RunDir(self.path / COMPANION)

    def commit(self, meta: dict) -> dict:
        """Write meta.json last: the files' sizes and ``"status": "complete"`` with it."""
        files = sorted(p.name for p in self.path.iterdir()
                       if p.name in RUN_FILES or p.name == meta.get("restart"))
        meta = {**meta, "status": "complete", "files": sorted(set(files) | {META})}
        # sizes let a later check tell a finished run from one whose files were cut or lost
        meta["file_bytes"] = {f: self.file(f).stat().st_size for f in files if f != META}
        meta["bytes_written"] = sum(meta["file_bytes"].values())
        formats.write_json_atomic(self.file(META), meta)
        return meta

    def clear(self) -> None:
        """Remove what a run, its analysis and its movies wrote (before a run is redone:
        nothing drawn from the old run stays behind looking current)."""
        for name in RUN_FILES + ANALYSIS_FILES + (CONTINUING,):
            self.file(name).unlink(missing_ok=True)
        for p in self.restart_files():
            p.unlink(missing_ok=True)
        comp = self.companion()
        if comp.path.is_dir() and comp.foreign() is None:
            import shutil

            shutil.rmtree(comp.path)
        for pattern in (MOVIE_PATTERN, FRONT_MAPS_PATTERN):
            for p in self.path.glob(pattern.format("*")):
                p.unlink(missing_ok=True)

    def movie_file(self, slip: int) -> Path:
        return self.file(MOVIE_PATTERN.format(slip))

    def front_maps_file(self, slip: int) -> Path:
        return self.file(FRONT_MAPS_PATTERN.format(slip))

    def mark(self) -> None:
        """Claim the directory for a run bkflow begins now (docs/running.md, "What bkflow
        replaces"): the mark records bkflow's version and the time; the run's files written
        after it are the ones a later run may replace (a partial run of ours is redone)."""
        import time

        from bkflow import __version__
        from bkflow.store.formats import inside

        # replaced atomically: a link planted under the mark's name is replaced, never
        # followed (and no component of the path is a link: ``inside``)
        formats.write_json_atomic(inside(self.path, MARK, "the run's mark"),
                             {"bkflow": __version__, "began": time.time(),
                              "directory": self._identity()})

    def _identity(self) -> list[int]:
        """The directory's identity on its file system (device, inode): a mark copied into
        another directory, or a directory copied whole, carries another's."""
        st = os.stat(self.path)
        return [st.st_dev, st.st_ino]

    def _replaceable(self, names) -> list[str]:
        """The names among ``names`` that a run (or its clear()) writes or removes."""
        import fnmatch

        patterns = (RESTART.format("*"), MOVIE_PATTERN.format("*"),
                    FRONT_MAPS_PATTERN.format("*"))
        return sorted(n for n in names if n in RUN_FILES + ANALYSIS_FILES + (CONTINUING,)
                      or any(fnmatch.fnmatch(n, p) for p in patterns))

    def _mark_problem(self, names) -> str | None:
        """Why the mark does not make the run's files here bkflow's to replace: it is not a
        record bkflow wrote, or a file of the run's names is older than it (it was there
        before bkflow began a run here); None when it does."""
        import json

        mark = self.file(MARK)
        try:
            rec = json.loads(formats.read_text(mark)) if not mark.is_symlink() else None
        except (OSError, ValueError):
            rec = None
        if not (isinstance(rec, dict) and "bkflow" in rec):
            return (f"holds a {MARK} mark that bkflow did not write (an empty or edited file), "
                    f"beside {listing(self._replaceable(names)) or 'no run files'}")
        if rec.get("directory") != self._identity():
            return (f"holds a {MARK} mark that bkflow wrote in another directory (copied here, "
                    f"or this directory is a copy), beside "
                    f"{listing(self._replaceable(names)) or 'no run files'}")
        try:
            began = min(float(rec["began"]), mark.lstat().st_mtime)
        except (KeyError, TypeError, ValueError):
            began = mark.lstat().st_mtime
        older = [n for n in self._replaceable(names)
                 if self.file(n).lstat().st_mtime < began - MARK_SLACK_S]
        if older:
            return (f"holds {listing(older)}, older than its {MARK} mark: not files of the run "
                    "bkflow began here, so not replaced")
        return None

    def foreign(self) -> str | None:
        """What makes this directory not bkflow's to write a run into (None: it is empty,
        or bkflow's own run, finished or not)."""
        if self.path.is_file():
            return "is a file, not a directory"
        try:
            names = {p.name for p in self.path.iterdir()}
        except FileNotFoundError:
            return None
        if META in names:
            return None
        if MARK in names:
            return self._mark_problem(names)
        names = {n for n in names if n not in SIGNAC_FILES and not bookkeeping(n)}
        if not names:
            return None
        for made in (EXTREMA, STRESS):
            if {PARAMS, made} <= names:
                return f"holds a run made with lmp -in {DECK} ({PARAMS}, {made})"
        if PARAMS in names or DECK in names:
            deck = ", ".join(sorted(names & {DECK, DATA, PARAMS}))
            return f"holds a deck written by bkflow deck ({deck})"
        return f"holds files that are not a bkflow run ({listing(names)})"

    def busy(self) -> bool:
        """Whether another process holds the directory's lock now (a run, an analysis, a
        collect), without taking it or creating a lock file."""
        import fcntl

        try:
            fd = os.open(self.file(LOCK), os.O_RDONLY | os.O_NOFOLLOW)
        except OSError:
            return False
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except OSError as exc:
            return exc.errno in (errno.EAGAIN, errno.EACCES)
        finally:
            os.close(fd)
        return False

    @contextlib.contextmanager
    def lock(self):
        """Hold an exclusive lock on the directory (released when the process dies); a
        second writer gets ``RunBusyError`` at once. Re-entrant within a process (the
        sweep's job holds it around the engine's run and the analysis)."""
        import fcntl

        self.path.mkdir(parents=True, exist_ok=True)
        key = str(self.path.resolve())
        if key in _HELD:
            yield self
            return
        try:  # never through a link: it could create or touch a file anywhere
            fd = os.open(self.file(LOCK), os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o644)
        except OSError as exc:
            if exc.errno != errno.ELOOP:
                raise
            from bkflow.store.formats import OutsideError

            raise OutsideError(f"{self.file(LOCK)} is a symbolic link: bkflow locks, deletes "
                               "and writes only inside the directory it was given; remove it"
                               ) from None
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as exc:
                if exc.errno in (errno.EAGAIN, errno.EACCES):
                    raise RunBusyError(f"another bkflow process is writing {self.path} now; "
                                       "wait for it or stop it") from None
                if exc.errno not in (errno.ENOSYS, errno.EOPNOTSUPP, errno.ENOLCK):
                    raise
                # a file system without locks (Lustre without -o flock): run unlocked
                fs = str(self.path.parent)
                if fs not in _WARNED_NO_FLOCK:
                    _WARNED_NO_FLOCK.add(fs)
                    import sys

                    print(f"bkflow: warning: {fs} does not support file locks ({exc.strerror});"
                          " running without them: do not start two writers on one run",
                          file=sys.stderr)
            _HELD.add(key)
            try:
                yield self
            finally:
                _HELD.discard(key)
        finally:
            os.close(fd)

    # ------------------------------------------------------------------ the run's parameters
    def spec(self) -> RunSpec:
        """The RunSpec of the finished run (meta.json), or of a deck run standalone
        (params.json, written by ``bkflow deck``)."""
        meta = self.meta()
        if meta is not None and meta.get("status") == "complete":
            where, params = META, meta.get("params")
        else:
            try:
                where, params = PARAMS, formats.read_json(self.file(PARAMS))
            except ValueError as exc:
                raise DamagedRunError(f"{self.file(PARAMS)} is not JSON ({exc})") from None
        if not isinstance(params, dict):
            raise DamagedRunError(f"{self.file(where)} holds no run parameters (expected an "
                                  f"object of RunSpec fields)")
        try:
            return RunSpec.from_dict(params)
        except (TypeError, ValueError) as exc:
            raise DamagedRunError(f"{self.file(where)}: {exc}") from None

    def finished_standalone(self) -> str | None:
        """For a deck run with ``lmp -in in.bk``: why it is not finished (None when its stress
        series reaches the deck's t_end)."""
        records = EXTREMA if self.file(EXTREMA).exists() else STRESS
        if not (self.file(PARAMS).exists() and self.file(records).exists()):
            return (f"{self.path} holds no finished run (no meta.json with status complete, "
                    f"nor a deck's {PARAMS} with its {EXTREMA}); run it first with bkflow run")
        spec = self.spec()
        red = self.read_reduced(spec)
        last = spec.stress_nevery * (spec.n_steps // spec.stress_nevery) * spec.dt
        if red.n_samples == 0 or red.t_end < last - 0.5 * spec.dt:
            return (f"{self.path}'s records end at t = {red.t_end:g}, before the run's end "
                    f"({last:g}): the run did not finish")
        return None

    # ------------------------------------------------------------------ the run's outputs
    def recorded_threshold(self, spec: RunSpec) -> float:
        """The zigzag threshold the run's extrema were recorded at: its deck's fix bk/reduce
        line says it (a run made before a change of RunSpec.extrema_threshold_stress, e.g. the
        size-scaled threshold, recorded at its own), else the spec's."""
        import re

        try:
            deck = formats.read_text(self.file(DECK), errors="replace")
        except OSError:
            return spec.extrema_threshold_stress
        m = re.search(r"bk/reduce\s+\S+\s+\S+\s+threshold\s+(\S+)", deck)
        try:
            return float(m.group(1)) if m else spec.extrema_threshold_stress
        except ValueError:
            return spec.extrema_threshold_stress

    def read_reduced(self, spec: RunSpec):
        """The run's records of its stress and phases (``bkflow.observables.reduced.Reduced``): fix
        bk/reduce's, or the same reduction of the raw series of a run that has no records
        (one made before bkflow reduced in the run)."""
        from bkflow.observables import reduced

        args = (spec.stress_nevery, spec.block_nevery, spec.dt, self.recorded_threshold(spec))
        if self.file(BLOCKS).exists() or not self.file(STRESS).exists():
            try:
                # a companion keeps its blocks only (no extrema.npy; a finished run's
                # missing file is found by problem() before)
                red = reduced.load(formats.regular(self.file(EXTREMA))
                                   if self.file(EXTREMA).exists() else None,
                                   formats.regular(self.file(BLOCKS)), *args)
                if self.file(SERIES_STRESS).exists():   # scenes series, full: every slip
                    red = dataclasses.replace(red, raw=lambda: self.read_stress(spec)[1],
                                              raw_ledger=lambda: self.read_ledger(spec))
            except (ValueError, EOFError, OSError) as exc:
                if isinstance(exc, OSError) and exc.errno is not None:
                    raise   # the file system's refusal (missing, unreadable), not damage
                raise DamagedRunError(f"{self.path}: its records ({EXTREMA}, {BLOCKS}) are "
                                      f"damaged ({exc}); run the run again") from None
            return red
        _, sigma = self.read_stress(spec)
        phase = self.read_phase(spec)
        ledger = self.read_ledger(spec) if spec.writes_energy else None
        return reduced.from_series(sigma, *args[:3], args[3], phase, spec.phase_nevery, ledger)

    def stress_outline(self, spec: RunSpec) -> tuple[np.ndarray, np.ndarray]:
        """sigma_x(t) as the run kept it: the raw series where its scene wrote it (series,
        full), else its turning points (``EXTREMA``: every maximum and minimum of the drops
        above the extrema threshold, the stick-slip's outline)."""
        if self.keeps_raw_stress():
            return self.read_stress(spec)
        red = self.read_reduced(spec)
        if not red.has_extrema:
            raise AnalysisError(f"{self.path} keeps its stress as block means only (a companion "
                                "run): read them as Run.blocks")
        return red.sample_index() * spec.stress_nevery * spec.dt, \
            np.asarray(red.extrema["sigma"], float)

    def keeps_raw_stress(self) -> bool:
        """Whether the run kept its raw stress series (scenes series, full; every run of an
        older bkflow)."""
        return self.file(SERIES_STRESS).exists() or self.file(STRESS).exists()

    def phase_series(self, spec: RunSpec, red=None) -> dict | None:
        """The contacts' phase statistics as the run kept them: the raw series where its
        scene wrote it (phase.npy), else their means over the blocks (``BLOCKS``, of ``red``
        where the caller has read the records already); None without phases."""
        if self.file(SERIES_PHASE).exists() or self.file(PHASE).exists() or \
                not self.file(BLOCKS).exists():
            return self.read_phase(spec)
        _, _, phase = (red or self.read_reduced(spec)).series()
        return phase

    def _series(self, name: str, spec: RunSpec | None = None):
        """A raw series' records (stress.npy, phase.npy) and the time step of ``spec`` (the
        run's own by default)."""
        from bkflow.observables.reduced import SERIES_FIELDS, checked

        try:
            r = checked(np.load(formats.regular(self.file(name)), allow_pickle=False),
                        SERIES_FIELDS, name)
        except (ValueError, EOFError) as exc:
            raise DamagedRunError(f"{self.file(name)} is damaged ({exc}); run the run "
                                  "again") from None
        return r, (spec or self.spec()).dt

    def read_stress(self, spec: RunSpec | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The raw stress series: (t, sigma_x) (stress.npy; stress.csv of an older run).
        ``spec``: the run's parameters where the directory has no record of them."""
        if self.file(SERIES_STRESS).exists():
            r, dt = self._series(SERIES_STRESS, spec)
            return np.asarray(r["step"], float) * dt, np.asarray(r["sigma"], float)
        try:
            c = formats.read_columns(self.file(STRESS), ("t", "sigma_x"))
        except FileNotFoundError:
            raise
        except ValueError as exc:
            raise DamagedRunError(f"{self.file(STRESS)} is damaged ({exc})") from None
        return c["t"], c["sigma_x"]

    def read_ledger(self, spec: RunSpec | None = None) -> dict | None:
        """The breaks and the energy ledger at every stress sample (stress.csv of a scene that
        keeps it: ``LEDGER_COLUMNS``), or None."""
        if self.file(SERIES_STRESS).exists():
            r, dt = self._series(SERIES_STRESS, spec)
            if "work" not in (r.dtype.names or ()):
                return None
            return {"t": np.asarray(r["step"], float) * dt,
                    **{c: np.asarray(r[c], float) for c in LEDGER_COLUMNS}}
        path = self.file(STRESS)
        with open(path, "rb") as f:
            head = f.readline().decode(errors="replace").strip().split(",")
        if head[2:] != list(LEDGER_COLUMNS):
            return None
        try:
            ledger = formats.read_columns(path, ("t", *LEDGER_COLUMNS))
        except ValueError as exc:
            raise DamagedRunError(f"{path} is damaged ({exc})") from None
        sums = ("work", "diss_break", "diss_damp")
        if all(np.isnan(ledger[c]).all() for c in sums):  # a substrate fix without `energy`
            return None
        bad = np.zeros(len(ledger["t"]), bool)
        for c in ("t", *LEDGER_COLUMNS):
            bad |= ~np.isfinite(ledger[c])
        if bad.any():
            raise DamagedRunError(f"{path} is damaged: {int(bad.sum())} row(s) without every "
                                  f"column of its header (the first near t = "
                                  f"{ledger['t'][bad][0]:g}); run the run again")
        return ledger

    def read_phase(self, spec: RunSpec | None = None):
        """The contacts' phase series (phase.csv): a dict of float columns t, R, Z_re, Z_im,
        R2, u_mean, u_std; None for a run made before bkflow recorded it."""
        if self.file(SERIES_PHASE).exists():
            r, dt = self._series(SERIES_PHASE, spec)
            return {"t": np.asarray(r["step"], float) * dt,
                    **{c: np.asarray(r[c], float) for c in PHASE_COLUMNS[1:]}}
        if not self.file(PHASE).exists():
            if PHASE in ((self.meta() or {}).get("file_bytes") or {}):
                raise DamagedRunError(f"{self.file(PHASE)} is missing (meta.json lists it)")
            return None
        try:
            return formats.read_columns(self.file(PHASE), PHASE_COLUMNS)
        except ValueError as exc:
            raise DamagedRunError(f"{self.file(PHASE)} is damaged ({exc})") from None

    def read_snapshots(self, n_atoms: int) -> formats.Frames:
        return self._frames(SNAPSHOTS, n_atoms)

    def read_fronts(self) -> list[formats.Front]:
        """The rupture fronts of the run (fix bk/fronts, scenes fronts and full): one
        ``bkflow.store.formats.Front`` per recorded slip; [] when the scene recorded none."""
        if not self.file(FRONTS).exists():
            meta = self.meta() or {}
            if (meta.get("fronts") or {}).get("written"):
                raise DamagedRunError(f"{self.file(FRONTS)} is missing (meta.json says "
                                      f"{meta['fronts']['written']} slips were recorded)")
            return []
        try:
            return formats.read_fronts(self.file(FRONTS))
        except ValueError as exc:
            raise DamagedRunError(f"{self.file(FRONTS)} is cut or damaged ({exc})") from None

    def read_slip_frames(self, n_atoms: int) -> formats.Frames:
        return self._frames(SLIPS, n_atoms)

    def _frames(self, name: str, n_atoms: int) -> formats.Frames:
        try:
            return formats.read_frames(self.file(name), n_atoms)
        except (OSError, MemoryError):  # missing, unreadable, the machine's limit: named
            raise
        except Exception as exc:  # MDAnalysis reports a cut dump in many ways
            raise DamagedRunError(f"{self.file(name)} is cut or damaged "
                                  f"({type(exc).__name__}: {exc})") from None

    # ------------------------------------------------------------------ the analysis
    def summary(self) -> dict | None:
        """summary.json, or None when there is none or it is unreadable."""
        return self._record(SUMMARY)

    def analysis_problem(self, settings: AnalysisSettings | None = None,
                         spec: RunSpec | None = None) -> str | None:
        """Why the analysis here is missing or stale (None when it is current): no or a cut
        summary.json, one made by another revision of the analysis (ANALYSIS_REVISION) or
        under other settings than ``settings`` (resolved for this run), for other parameters
        than ``spec``, or a table it wrote gone."""
        s = self.summary()
        if s is None:
            return "no summary.json" if not self.file(SUMMARY).exists() \
                else "summary.json unreadable"
        if "mu_bar" not in s or "settings" not in s or "params" not in s:
            return "summary.json is not a bkflow summary"
        spec = spec or self.spec()
        if s.get("analysis_revision") != ANALYSIS_REVISION:
            return (f"summary.json made by analysis revision {s.get('analysis_revision')}, "
                    f"this bkflow's is {ANALYSIS_REVISION}")
        wanted = (settings or AnalysisSettings()).resolved(spec).to_dict()
        if s["settings"] != formats.json_ready(wanted):
            changed = sorted(k for k in wanted if s["settings"].get(k) != formats.json_ready(
                wanted[k]))
            return f"summary.json made under other analysis settings ({', '.join(changed)})"
        if s["params"] != formats.json_ready(spec.to_dict()):
            return "summary.json belongs to other parameters"
        return self.table_problem(s)

    def only_analysis_left(self, spec: RunSpec) -> bool:
        """Whether this directory holds the finished, intact run of ``spec`` (as requested)
        whose analysis is missing or stale: the same command again after its analysis was
        cut short has only that left to do."""
        meta = self.meta() if self.is_complete() else None
        return (meta is not None and meta.get("requested") == spec.to_dict()
                and self.problem() is None and self.analysis_problem() is not None)

    def write_analysis(self, summary: dict, tables: dict) -> dict:
        """Write the analysis's tables, then summary.json (last: it lists the tables)."""
        self.file(SUMMARY).unlink(missing_ok=True)
        for name in (EVENTS, EVENTS_PARQUET, PSI, CLUSTERS):
            self.file(name).unlink(missing_ok=True)
        for name, table in tables.items():
            if name == EVENTS:   # a table for programs: stored once, as Parquet
                from bkflow.observables.catalogue import typed

                formats.write_parquet(self.file(EVENTS_PARQUET), typed(table))
            else:
                formats.write_table(self.file(name), table)
        tables = {EVENTS_PARQUET if name == EVENTS else name: t for name, t in tables.items()}
        # the record last, with the size and digest of every table it made: a table cut, emptied
        # or replaced since is known (``table_problem``), and redone by whichever command needs
        # it (analyze, collect, sweep)
        summary = {**summary, "tables": sorted(tables), "analysis_revision": ANALYSIS_REVISION,
                   "table_files": {name: formats.file_record(self.file(name)) for name in tables}}
        formats.write_json_atomic(self.file(SUMMARY), summary)
        return formats.json_ready(summary)

    def table_problem(self, summary: dict | None = None) -> str | None:
        """Why the analysis's tables are not the ones its summary.json made (None: they are):
        one missing, cut, emptied or replaced (its size, then its digest, changed), or a
        summary without the record of them (made by an older bkflow). The tables are one set
        with their summary: a reader of one checks them all."""
        s = summary if summary is not None else self.summary()
        if s is None:
            return "no summary.json"
        record = s.get("table_files")
        if not isinstance(record, dict):
            return "summary.json does not record its tables"
        for name in s.get("tables", []):
            p = self.file(name)
            if p.is_symlink() or not p.is_file():
                return f"{name} is missing"
            want = record.get(name) or {}
            if p.stat().st_size != want.get("bytes") or formats.file_record(p) != want:
                return f"{name} is not the table the analysis wrote (cut, emptied or replaced)"
        return None

    def _checked(self, name: str) -> Path:
        """The path of the analysis's table ``name``, after checking it is the one its summary
        recorded (DamagedRunError otherwise, naming the repair)."""
        why = self.table_problem()
        if why is not None:
            raise DamagedRunError(f"{self.path}: {why}; bkflow analyze "
                                  f"{formats.shell_word(self.path)} (or bkflow "
                                  "collect, for a sweep) makes the analysis again")
        return self.file(name)

    def read_events(self):
        """The event catalogue as a typed DataFrame (events.parquet; events.csv where there is
        no Parquet copy): one row per slip, columns ``EVENT_COLUMNS`` and those of
        bkflow.observables.catalogue the scene recorded."""
        import pandas as pd

        from bkflow.observables.catalogue import typed

        if self.file(EVENTS_PARQUET).exists():
            return pd.read_parquet(self._checked(EVENTS_PARQUET), engine="pyarrow")
        return typed(formats.read_table(self._checked(EVENTS)))

    def has_events(self) -> bool:
        """Whether the analysis wrote the event catalogue (events.parquet; events.csv of an
        older bkflow): there, or listed by summary.json (then missing: damage, said by
        ``read_events``)."""
        if self.file(EVENTS).exists() or self.file(EVENTS_PARQUET).exists():
            return True
        s = self.summary()
        return s is not None and EVENTS_PARQUET in (s.get("tables") or [])

    def read_psi_record(self, spec: RunSpec):
        """Psi(t) as fix bk/psi computed it in the run: (steps, psi), or None."""
        if not self.file(PSI_RECORD).exists():
            return None
        try:
            from bkflow.observables.reduced import PSI_FIELDS, checked

            r = checked(np.load(formats.regular(self.file(PSI_RECORD)), allow_pickle=False),
                        PSI_FIELDS, PSI_RECORD)
            return np.asarray(r["step"], np.int64), np.asarray(r["psi"], float)
        except (ValueError, EOFError, KeyError) as exc:
            raise DamagedRunError(f"{self.file(PSI_RECORD)} is damaged ({exc}); run the run "
                                  "again") from None

    def read_slip_rows(self):
        """(slips, clusters): each slip's catalogue row and its clusters as the run computed
        them (fix bk/slips ``catalogue``; structured arrays)."""
        from bkflow.observables.reduced import CLUSTER_FIELDS, SLIP_FIELDS, checked

        out = []
        for name, fields in ((SLIP_ROWS, SLIP_FIELDS), (CLUSTER_ROWS, CLUSTER_FIELDS)):
            try:
                out.append(checked(np.load(formats.regular(self.file(name)), allow_pickle=False),
                                   fields, name))
            except (ValueError, EOFError) as exc:
                raise DamagedRunError(f"{self.file(name)} is damaged ({exc}); run the run "
                                      "again") from None
        return tuple(out)

    def read_psi(self):
        """Psi(t) as a DataFrame (t, psi): the run's psi.npy, or the psi.csv the analysis of
        an older run's snapshots wrote; None when the run recorded neither."""
        import pandas as pd

        if self.file(PSI_RECORD).exists():
            spec = self.spec()
            steps, psi = self.read_psi_record(spec)
            return pd.DataFrame({"t": steps * spec.dt, "psi": psi})
        return formats.read_table(self._checked(PSI)) if self.file(PSI).exists() else None

    def read_clusters(self):
        """One row per slip cluster of the analysed slips (``CLUSTER_COLUMNS`` and n_x, n_y,
        slip, bond_change, eq2_estimate): the run's clusters.npy joined to its events (scene
        figures), or the clusters.csv the analysis made from the slips' frames; None when the
        run recorded neither."""
        import pandas as pd

        if self.file(CLUSTER_ROWS).exists():
            summary = self.summary()
            if summary is None:
                return None
            events = self.read_events()
            spec = self.spec()
            # an event by the steps of its maximum and minimum (a slip of another threshold
            # than the analysis's may share its maximum): as the analysis matched them
            at = {(int(round(a / spec.dt)), int(round(b / spec.dt))): k
                  for k, (a, b) in enumerate(zip(events["t_max"], events["t_min"]))
                  if a >= summary["t_transient"]}
            slips, rows = self.read_slip_rows()
            end = dict(zip(slips["step_max"].tolist(), slips["step_min"].tolist()))
            steps = [(int(s), int(end.get(s, -1))) for s in rows["step_max"].tolist()]
            keep = np.array([s in at for s in steps], bool)
            out = {"event": [at[s] for s, k in zip(steps, keep) if k]}
            out["t"] = events["t_max"].to_numpy()[out["event"]]
            for c in ("n_c", "l_x", "l_y", "n_x", "n_y", "slip", "bond_change", "eq2_estimate"):
                out[c] = rows[c][keep]
            return pd.DataFrame(out)
        return formats.read_table(self._checked(CLUSTERS)) if self.file(CLUSTERS).exists() else None


def sweep_run_dir(root, job_id: str) -> RunDir:
    """The run directory of job ``job_id`` of the sweep in ``root``."""
    return RunDir(Path(root) / WORKSPACE / str(job_id))

