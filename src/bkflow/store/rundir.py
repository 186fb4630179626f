"""The run directory: ``RunDir``, its completion record and the checks on it.

The engine writes a run into a directory and commits it by writing ``META`` last (atomically,
with the size of every file, so a cut file is detected): ``RunDir.commit``. ``RunDir.problem``
says whether the directory holds an intact finished run, ``RunDir.spec`` which parameters it
ran; a finished run being continued is undone to itself when the continuation is cut short
(``begin_continuation``, ``undo_continuation``). The other roles of ``RunDir`` have their own
modules, and ``RunDir`` holds them all:

- ``bkflow.store.layout``: the name of every file (the table of what each holds);
- ``bkflow.store.lock``: the lock a writer holds, and the mark that claims a directory;
- ``bkflow.store.readers``: the run's records as arrays (``read_reduced`` and the other
  ``read_*``);
- ``bkflow.store.analysed``: summary.json and the analysis's tables, checked and read;
- ``bkflow.store.errors``: the errors of a run directory.
"""

from __future__ import annotations

import os
from pathlib import Path

from bkflow.model.params import RunSpec
from bkflow.store import files, formats
from bkflow.store.analysed import RunAnalysisFiles
from bkflow.store.errors import DamagedRunError
from bkflow.store.layout import (
    ANALYSIS_FILES,
    BLOCKS,
    CLUSTER_ROWS,
    COMPANION,
    CONTINUING,
    DATA,
    DECK,
    EXTREMA,
    FRONT_MAPS_PATTERN,
    MAY_CHANGE,
    META,
    MOVIE_PATTERN,
    PARAMS,
    PSI_RECORD,
    RESTART,
    RUN_FILES,
    SERIES_PHASE,
    SERIES_STRESS,
    SLIP_ROWS,
    STRESS,
    WORKSPACE,
)
from bkflow.store.lock import RunLock
from bkflow.store.readers import RunReaders


class RunDir(RunLock, RunReaders, RunAnalysisFiles):
    """One run directory: its files, its completion record and its checks (the lock and the
    claim: ``RunLock``; the readers of the run's records: ``RunReaders``; the analysis's
    files: ``RunAnalysisFiles``).

    >>> d = RunDir("runs/phi10")
    >>> d.path.name, d.file(STRESS).name
    ('phi10', 'stress.csv')
    """

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
                with open(files.regular(meta), "rb"):
                    pass

    def is_complete(self) -> bool:
        """meta.json says the run finished (sizes not checked: see ``problem``)."""
        meta = self.meta()
        return meta is not None and meta.get("status") == "complete"

    def problem(self) -> str | None:
        """Why this directory does not hold an intact finished run, or None when it does.

        Finished means meta.json says complete and every file it lists still has the size and
        the sha256 it had when the run ended; a truncated, emptied, missing, changed or swapped
        output file is named.
        """
        try:
            meta = formats.read_json(self.file(META))
        except FileNotFoundError:
            return f"not run (no {META})"
        except (OSError, ValueError) as exc:
            return f"{META} unreadable ({exc})"
        if not isinstance(meta, dict) or meta.get("status") != "complete":
            return f"{META} does not say complete"
        why = self._files_problem(meta)
        if why is None and meta.get("companion"):
            why = self._companion_problem(meta)
        return why

    def _files_problem(self, meta: dict) -> str | None:
        """The first file the completion record ``meta`` lists that is not as the run left it
        (a link, missing, another size), or None."""
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
        for name, digest in (meta.get("file_sha256") or {}).items():  # runs of bkflow >= 0.6
            if name in MAY_CHANGE:
                continue
            try:
                actual = files.sha256_of(self.file(name))
            except OSError as exc:
                return f"{name} unreadable ({exc.strerror or exc})"
            if actual != digest:
                return (f"{name} is not the file the run wrote (its sha256 differs: changed "
                        "since, or another run's)")
        return None

    def _companion_problem(self, meta: dict) -> str | None:
        """Why the companion run of the run whose record is ``meta`` is not its own, intact
        finished companion (a link, another's run, damaged), or None."""
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
    #: and the decks it rewrites for the longer run before it commits, kept as they were until
    #: it commits: cutting them back to their size is not enough (their digests are recorded)
    REWRITTEN = (EXTREMA, BLOCKS, PSI_RECORD, SLIP_ROWS, CLUSTER_ROWS, SERIES_STRESS,
                 SERIES_PHASE, DECK, DATA)

    def _before(self, name: str) -> Path:
        return self.file(f".{name}.before-continuing.tmp")

    def begin_continuation(self) -> None:
        """Note that the finished run here is being continued (its record stays as it is):
        the records it rewrites in place are kept aside, and the note names the finished
        run's restart file (what tells an interrupted continuation from one that committed)."""
        for name in self.REWRITTEN:
            if self.file(name).is_file():
                data = formats.read_bytes(self.file(name))
                with files.atomic_file(self._before(name), binary=True) as f:
                    f.write(data)
        files.write_text_atomic(self.file(CONTINUING), str((self.meta() or {}).get("restart")))

    def end_continuation(self, keep: str | None) -> None:
        """After the new record is committed: remove the continuation's note and every
        restart file but ``keep``."""
        for p in self.restart_files():
            if p.name != keep:
                p.unlink(missing_ok=True)
        for name in self.REWRITTEN:
            self._before(name).unlink(missing_ok=True)
        self.file(CONTINUING).unlink(missing_ok=True)

    def damage_advice(self) -> str:
        """What to do about a run whose files are not as its record says: where a
        continuation of it (or of its companion) was cut short, the finished run is intact
        and comes back by itself; else it is damaged and is run again."""
        if any(d.file(CONTINUING).exists() for d in (self, self.companion())):
            return ("a continuation of the run was interrupted, and the finished run is intact: "
                    f"bkflow analyze {files.shell_word(self.path)}, or the same bkflow run "
                    "command, restores it")
        return "the run is damaged; run it again (bkflow run --overwrite, or the sweep redoes it)"

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
        names = sorted(p.name for p in self.path.iterdir()
                       if p.name in RUN_FILES or p.name == meta.get("restart"))
        meta = {**meta, "status": "complete", "files": sorted(set(names) | {META})}
        # sizes let a later check tell a finished run from one whose files were cut or lost
        meta["file_bytes"] = {f: self.file(f).stat().st_size for f in names if f != META}
        meta["bytes_written"] = sum(meta["file_bytes"].values())
        # and their digests, whose contents are the run's: a record of another run of the
        # same size, a value written over in place, another run's restart file
        meta["file_sha256"] = {f: files.sha256_of(self.file(f)) for f in names
                               if f != META and f not in MAY_CHANGE}
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
        for p in self.path.glob("run.*"):   # bkflow plot's figure of the old run, not a user's
            if p.is_file() and files.made_by_bkflow(p):
                p.unlink(missing_ok=True)

    def movie_file(self, slip: int) -> Path:
        return self.file(MOVIE_PATTERN.format(slip))

    def front_maps_file(self, slip: int) -> Path:
        return self.file(FRONT_MAPS_PATTERN.format(slip))

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
            spec = RunSpec.from_dict(params)
        except (TypeError, ValueError) as exc:
            raise DamagedRunError(f"{self.file(where)}: {exc}") from None
        return _at_its_step(spec, meta if where == META else None)

    def finished_standalone(self) -> str | None:
        """For a deck run with ``lmp -in in.bk``: why it is not finished (None when its stress
        series reaches the deck's t_end)."""
        records = EXTREMA if self.file(EXTREMA).exists() else STRESS
        if not (self.file(PARAMS).exists() and self.file(records).exists()):
            return (f"{self.path} holds no finished run (no {META} with status complete, "
                    f"nor a deck's {PARAMS} with its {EXTREMA}); run it first with bkflow run")
        spec = self.spec()
        red = self.read_reduced(spec)
        last = spec.stress_nevery * (spec.n_steps // spec.stress_nevery) * spec.dt
        if red.n_samples == 0 or red.t_end < last - 0.5 * spec.dt:
            return (f"{self.path}'s records end at t = {red.t_end:g}, before the run's end "
                    f"({last:g}): the run did not finish")
        return None


def sweep_run_dir(root, job_id: str) -> RunDir:
    """The run directory of job ``job_id`` of the sweep in ``root``."""
    return RunDir(Path(root) / WORKSPACE / str(job_id))


def _at_its_step(spec: RunSpec, meta: dict | None) -> RunSpec:
    """``spec`` at the time step the run was made with (meta.json's ``derived``): a preset's
    rule may give another step since (bkflow 0.6's fast preset at the stiff end), and the run's
    records are of its own."""
    try:
        dt = float(meta["derived"]["dt"])
    except (TypeError, KeyError, ValueError):
        return spec
    if not dt > 0 or abs(dt / spec.dt - 1) < 1e-12:
        return spec
    return spec.replace(dt_factor=dt * spec.omega_max)
