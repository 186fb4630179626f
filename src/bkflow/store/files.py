"""How bkflow touches a file: it reads only regular files (``regular``: a FIFO would wait
forever), deletes, replaces and writes only inside the directory it was given (``within``,
``inside``), writes every file atomically (``atomic_file``), replaces only the files it made
(``MARK``, ``foreign_file``), knows a file again by its digest (``sha256_of``,
``file_record``), and names a path so a shell reads it as one word (``shell_word``).
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

_UMASK = os.umask(0)
os.umask(_UMASK)


class NotRegularFileError(ValueError):
    """A path bkflow reads that is not a regular file (a FIFO, a device, a socket; a
    directory is the file system's IsADirectoryError): reading a FIFO would wait forever
    for a writer."""


def regular(path) -> Path:
    """``path``, once it is known to be a regular file (or a link to one); FileNotFoundError
    where there is none, NotRegularFileError where it is something else. Every file bkflow
    reads passes here first (a stat, which does not block)."""
    import stat

    p = Path(path)
    mode = os.stat(p).st_mode
    if stat.S_ISDIR(mode):   # the file system's refusal, as open() gives it
        import errno

        raise IsADirectoryError(errno.EISDIR, "is a directory, where bkflow keeps a file",
                                str(p))
    if not stat.S_ISREG(mode):
        raise NotRegularFileError(f"{p} is not a regular file (a FIFO, device or socket where "
                                  "bkflow keeps a file): bkflow reads only regular files; "
                                  "remove it (the command that makes it makes it again)")
    return p


#: sha256 of files already hashed in this process, by what identifies their contents on disk
#: (device, inode, size, modification time in ns): a file written since is hashed again
_DIGESTS: dict = {}


def sha256_of(path) -> str:
    """The sha256 of a file's bytes (``regular`` first), remembered while the file is not
    changed: the checks of a run's records cost one pass over them per process."""
    st = os.stat(regular(path))
    key = (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)
    if key not in _DIGESTS:
        if len(_DIGESTS) > 4096:
            _DIGESTS.clear()
        _DIGESTS[key] = file_record(path)["sha256"]
    return _DIGESTS[key]


def file_record(path) -> dict:
    """{"bytes", "sha256"} of a file: what a record of a set of files keeps of each, so that a
    member cut, emptied or replaced since is known."""
    import hashlib

    h = hashlib.sha256()
    n = 0
    with open(regular(path), "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
            n += len(block)
    return {"bytes": n, "sha256": h.hexdigest()}


def shell_word(path) -> str:
    """``path`` as one word of a shell command a user may paste: quoted where the shell would
    read anything in it (spaces, $(...), quotes, ;), and a relative path that starts with "-"
    written "./-x", so that no command reads it as an option.

    >>> shell_word("runs/a b"), shell_word("g $(touch X)"), shell_word("-x")
    ("'runs/a b'", "'g $(touch X)'", './-x')
    """
    import shlex

    text = str(path)
    if text.startswith("-"):
        text = "./" + text
    return shlex.quote(text)


def within(root, name) -> Path | None:
    """``root / name`` when it stays inside ``root`` (a directory bkflow was given, or made):
    ``name`` relative and made of plain names (not absolute, no '..'), and no component of
    the path below ``root`` a symbolic link, so that nothing is followed out of it; None
    otherwise. Every path bkflow reads from a file, or finds in a directory it did not make,
    and then deletes, replaces or writes through, passes here first."""
    p = Path(name)
    if p.is_absolute() or not p.parts or any(part in ("", ".", "..") for part in p.parts):
        return None
    here = Path(root)
    for part in p.parts:
        here = here / part
        if here.is_symlink():
            return None
    return here


class OutsideError(ValueError):
    """A path that would take bkflow out of the directory it was given (a symbolic link, an
    absolute path or '..' where bkflow deletes, replaces or writes)."""


def inside(root, name, what: str) -> Path:
    """``within``, or an OutsideError naming ``what`` and why it is refused."""
    p = within(root, name)
    if p is None:
        raise OutsideError(f"{Path(root) / name}: {what} is a symbolic link or leads out of "
                           f"{root}; bkflow deletes, replaces and writes only inside the "
                           "directory it was given: remove it or move the directory")
    return p


@contextlib.contextmanager
def atomic_file(path, binary: bool = False):
    """Open a uniquely named temporary file beside ``path`` for writing; when the block ends
    without an exception, flush it to disk and rename it over ``path``. A reader (and a user
    after Ctrl-C, SIGTERM or a full disk) sees the old file or the whole new one, never half.
    Every file bkflow writes outside a run under way goes through here (tests/test_house.py
    checks the source for other writers)."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.fchmod(fd, 0o666 & ~_UMASK)  # mkstemp makes 0600: readable as any file the user writes
    try:
        with os.fdopen(fd, "wb" if binary else "w", **({} if binary else {"newline": ""})) as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        _unlink_quietly(tmp)
        raise


#: the mark bkflow leaves in the figures and movies it writes (PNG, PDF, SVG and PostScript
#: metadata, a GIF comment): an existing file without it is the user's, never replaced
MARK = "bkflow"


def made_by_bkflow(path, recorded=()) -> bool:
    """Whether the file at ``path`` is one bkflow wrote: it carries ``MARK`` near its
    start or end (where the formats keep their metadata), or its name is in ``recorded``
    (figures.json, for formats without metadata)."""
    path = Path(path)
    if path.name in recorded:
        return True
    try:
        with open(regular(path), "rb") as f:
            head = f.read(65536)
            f.seek(max(0, f.seek(0, os.SEEK_END) - 65536))
            tail = f.read()
    except OSError:
        return False
    return MARK.encode() in head or MARK.encode() in tail


def foreign_file(path, recorded=()) -> str | None:
    """Why bkflow must not replace the file at ``path`` (None: there is none, or it is one
    bkflow wrote: ``made_by_bkflow``)."""
    if os.path.lexists(path) and not made_by_bkflow(path, recorded):
        return (f"{path} exists and was not written by bkflow: it is not replaced; choose "
                "another --out, or move it")
    return None


def write_text_atomic(path, text: str) -> None:
    """Write a text file atomically (``atomic_file``)."""
    with atomic_file(path) as f:
        f.write(text)


def _unlink_quietly(path) -> None:
    try:
        os.unlink(path)
    except OSError:
        pass
