"""Who may write a run directory: the lock a writer holds, and the mark that claims the
directory for a run of bkflow's (what bkflow replaces there, and what it refuses to).

``RunLock`` is a part of ``bkflow.store.rundir.RunDir`` (its methods ``lock``, ``busy``,
``mark`` and ``foreign``); the lock is ``flock`` on ``LOCK`` in the directory, held by the
process (released when it dies) and re-entrant within it.
"""

from __future__ import annotations

import contextlib
import errno
import os

from bkflow.store import files, formats
from bkflow.store.errors import RunBusyError
from bkflow.store.layout import (
    ANALYSIS_FILES,
    CONTINUING,
    DATA,
    DECK,
    EXTREMA,
    FRONT_MAPS_PATTERN,
    LOCK,
    MARK,
    MARK_SLACK_S,
    META,
    MOVIE_PATTERN,
    PARAMS,
    RESTART,
    RUN_FILES,
    SIGNAC_FILES,
    STRESS,
    RunFiles,
    bookkeeping,
    listing,
)

#: run directories whose lock this process holds
_HELD: set[str] = set()
#: the file systems without flock (Lustre mounted without -o flock, some NFS) have been
#: warned about once
_WARNED_NO_FLOCK: set[str] = set()


class RunLock(RunFiles):
    """The lock and the claim of a run directory (a part of ``RunDir``)."""

    # ------------------------------------------------------------------ the lock
    def busy(self) -> bool:
        """Whether another process holds the directory's lock now (a run, an analysis, a
        collect), without taking it or creating a lock file."""
        import fcntl

        if str(self.path.resolve()) in _HELD:   # this process holds it: no other can
            return False

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
            raise files.OutsideError(f"{self.file(LOCK)} is a symbolic link: bkflow locks, "
                                       "deletes and writes only inside the directory it was "
                                       "given; remove it") from None
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

    # ------------------------------------------------------------------ the claim
    def mark(self) -> None:
        """Claim the directory for a run bkflow begins now (docs/running.md, "What bkflow
        replaces"): the mark records bkflow's version and the time; the run's files written
        after it are the ones a later run may replace (a partial run of ours is redone)."""
        import time

        from bkflow import __version__

        # written atomically; a link planted under the mark's name is refused (``inside``:
        # no component of the path is a link), never followed
        formats.write_json_atomic(files.inside(self.path, MARK, "the run's mark"),
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
