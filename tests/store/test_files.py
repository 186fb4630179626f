"""bkflow.store.files, tested directly: regular files only, nothing outside the directory
given, atomic writes, only bkflow's own files replaced, digests that notice a change, paths a
shell reads as one word."""

from __future__ import annotations

import os
import shlex
import stat

import pytest

from bkflow.store import files


def test_only_regular_files_are_read(tmp_path):
    (tmp_path / "f").write_text("x")
    os.mkfifo(tmp_path / "fifo")
    (tmp_path / "d").mkdir()
    assert files.regular(tmp_path / "f") == tmp_path / "f"
    with pytest.raises(files.NotRegularFileError, match="not a regular file"):
        files.regular(tmp_path / "fifo")          # a FIFO would wait for a writer forever
    with pytest.raises(IsADirectoryError):
        files.regular(tmp_path / "d")
    with pytest.raises(FileNotFoundError):
        files.regular(tmp_path / "none")


@pytest.mark.parametrize("name", ["/etc/passwd", "../x", "a/../../x", "", ".", "link/x"])
def test_nothing_leads_out_of_the_directory(tmp_path, name):
    (tmp_path / "link").symlink_to(tmp_path.parent)
    assert files.within(tmp_path, name) is None
    with pytest.raises(files.OutsideError, match="leads out of"):
        files.inside(tmp_path, name, "the name")


def test_plain_names_stay_inside(tmp_path):
    assert files.within(tmp_path, "a/b.txt") == tmp_path / "a" / "b.txt"
    assert files.inside(tmp_path, "c", "c") == tmp_path / "c"


def test_an_atomic_write_leaves_the_old_file_whole_when_it_fails(tmp_path):
    p = tmp_path / "table.csv"
    p.write_text("old\n")
    with pytest.raises(RuntimeError):
        with files.atomic_file(p) as f:
            f.write("half of the new")
            raise RuntimeError("cut")
    assert p.read_text() == "old\n"
    assert sorted(q.name for q in tmp_path.iterdir()) == ["table.csv"]   # no temporary left
    files.write_text_atomic(p, "new\n")
    assert p.read_text() == "new\n"
    # readable as any file the user writes (mkstemp alone would make it 0600)
    assert stat.S_IMODE(p.stat().st_mode) == 0o666 & ~files._UMASK


def test_only_files_bkflow_made_are_replaced(tmp_path):
    ours, theirs = tmp_path / "a.png", tmp_path / "b.png"
    ours.write_bytes(b"\x89PNG..." + files.MARK.encode() + b"...")
    theirs.write_bytes(b"\x89PNG... a user's figure")
    assert files.made_by_bkflow(ours) and not files.made_by_bkflow(theirs)
    assert files.foreign_file(ours) is None and files.foreign_file(tmp_path / "none") is None
    assert "was not written by bkflow" in files.foreign_file(theirs)
    assert files.foreign_file(theirs, recorded=("b.png",)) is None   # named in a record


def test_a_digest_notices_a_change(tmp_path):
    p = tmp_path / "r.npy"
    p.write_bytes(b"1" * 100)
    first = files.sha256_of(p)
    assert files.file_record(p) == {"bytes": 100, "sha256": first}
    p.write_bytes(b"2" * 100)                    # the same size, written since
    os.utime(p, ns=(p.stat().st_atime_ns, p.stat().st_mtime_ns + 1000))
    assert files.sha256_of(p) != first


@pytest.mark.parametrize("path", ["runs/a b", "g $(touch X)", "-x", "it's", "plain/dir"])
def test_a_path_is_one_shell_word(path):
    word = files.shell_word(path)
    assert shlex.split(word) == [path if not path.startswith("-") else "./" + path]
