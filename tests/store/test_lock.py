"""bkflow.store.lock, tested directly: the lock a writer holds (busy or not without taking it,
re-entrant within a process, RunBusyError for a second process, never through a symbolic
link, a file system without locks run unlocked with one warning) and the mark that claims a
directory for a run (what makes a directory not bkflow's to write a run into)."""

from __future__ import annotations

import errno
import json
import os
import subprocess
import sys
import time

import pytest

from bkflow import __version__
from bkflow.store.errors import RunBusyError
from bkflow.store.files import OutsideError
from bkflow.store.layout import DECK, LOCK, LOG, MARK, MARK_SLACK_S, META, PARAMS, STRESS
from bkflow.store.lock import RunLock

#: a second process that takes the lock of the directory argv[1], says so, and holds it until
#: its stdin closes
HOLDER = """
import sys
from bkflow.store.lock import RunLock
with RunLock(sys.argv[1]).lock():
    print("held", flush=True)
    sys.stdin.read()
"""


@pytest.fixture
def other_process(tmp_path):
    """Start a process holding the lock of a run directory; yields the directory."""
    d = tmp_path / "run"
    proc = subprocess.Popen([sys.executable, "-c", HOLDER, str(d)], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline() == "held\n"
        yield d
    finally:
        proc.stdin.close()
        proc.wait(timeout=30)
        proc.stdout.close()


def test_a_second_process_is_refused_while_the_first_holds_the_lock(other_process):
    d = other_process
    assert RunLock(d).busy()
    with pytest.raises(RunBusyError, match=f"another bkflow process is writing {d} now; wait"):
        with RunLock(d).lock():
            pass


def test_the_lock_is_free_again_once_its_process_ends(tmp_path):
    d = tmp_path / "run"
    proc = subprocess.run([sys.executable, "-c", HOLDER, str(d)], input="",
                          capture_output=True, text=True, timeout=60)
    assert proc.stdout == "held\n", proc.stderr
    assert (d / LOCK).is_file() and not RunLock(d).busy()
    with RunLock(d).lock():
        pass


def test_busy_takes_no_lock_and_makes_no_file(tmp_path):
    d = tmp_path / "run"
    assert not RunLock(d).busy() and not d.exists()
    d.mkdir()
    assert not RunLock(d).busy() and not (d / LOCK).exists()
    with RunLock(d).lock():                   # the directory and its lock file made
        pass
    assert (d / LOCK).is_file() and not RunLock(d).busy()


def test_busy_means_another_process_not_the_one_that_holds_the_lock(tmp_path):
    with RunLock(tmp_path).lock():
        assert not RunLock(tmp_path).busy()


def test_the_lock_is_reentrant_within_a_process(tmp_path):
    d = tmp_path / "run"
    with RunLock(d).lock() as outer:
        assert outer.path == d
        # the same directory by another path: the same lock
        with RunLock(tmp_path / "run" / ".." / "run").lock(), RunLock(d).lock():
            pass
        code = ("import sys\nfrom bkflow.store.lock import RunLock\n"
                "from bkflow.store.errors import RunBusyError\n"
                "try:\n    RunLock(sys.argv[1]).lock().__enter__()\n"
                "except RunBusyError:\n    print('busy')\n")
        # still held by the outer block after the inner ones ended
        out = subprocess.run([sys.executable, "-c", code, str(d)], capture_output=True,
                             text=True, timeout=60)
        assert out.stdout == "busy\n", out.stderr


def test_a_lock_file_that_is_a_symbolic_link_is_refused(tmp_path):
    d, outside = tmp_path / "run", tmp_path / "outside"
    d.mkdir()
    outside.mkdir()
    (d / LOCK).symlink_to(outside / "planted")
    with pytest.raises(OutsideError, match=r"\.bkflow\.lock is a symbolic link: bkflow locks"):
        with RunLock(d).lock():
            pass
    assert not (outside / "planted").exists()                 # nothing made through it
    assert not RunLock(d).busy()                               # nor opened


def test_a_file_system_without_locks_runs_unlocked_warning_once(tmp_path, monkeypatch, capsys):
    import fcntl

    def no_locks(fd, how):
        raise OSError(errno.ENOLCK, "No locks available")

    monkeypatch.setattr(fcntl, "flock", no_locks)
    for name in ("a", "b"):                                    # two runs on one file system
        with RunLock(tmp_path / name).lock():
            pass
    err = capsys.readouterr().err
    assert err.count("does not support file locks") == 1, err
    assert f"bkflow: warning: {tmp_path} does not support file locks (No locks" in err
    assert "do not start two writers on one run" in err


def test_a_lock_error_that_is_not_contention_is_raised(tmp_path, monkeypatch):
    import fcntl

    def broken(fd, how):
        raise OSError(errno.EBADF, "Bad file descriptor")

    monkeypatch.setattr(fcntl, "flock", broken)
    with pytest.raises(OSError) as exc:
        with RunLock(tmp_path).lock():
            pass
    assert exc.value.errno == errno.EBADF and not isinstance(exc.value, RunBusyError)


# ------------------------------------------------------------------------ the mark
def test_the_mark_records_bkflow_the_time_and_the_directory(tmp_path):
    before = time.time()
    RunLock(tmp_path).mark()
    mark = json.loads((tmp_path / MARK).read_text())
    st = os.stat(tmp_path)
    assert mark["bkflow"] == __version__
    assert before <= mark["began"] <= time.time()
    assert mark["directory"] == [st.st_dev, st.st_ino]


def test_a_link_planted_under_the_marks_name_is_never_followed(tmp_path):
    d, victim = tmp_path / "run", tmp_path / "victim.txt"
    d.mkdir()
    victim.write_text("the user's\n")
    (d / MARK).symlink_to(victim)
    with pytest.raises(OutsideError, match=r"\.bkflow-run: the run's mark is a symbolic link"):
        RunLock(d).mark()
    assert victim.read_text() == "the user's\n"
    assert (d / MARK).is_symlink() and sorted(p.name for p in d.iterdir()) == [MARK]


def _age(path, seconds: float) -> None:
    t = time.time() - seconds
    os.utime(path, (t, t), follow_symlinks=False)


def test_a_marked_directory_is_bkflows_with_the_files_of_its_run(tmp_path):
    RunLock(tmp_path).mark()
    for name in (DECK, STRESS, LOG, "restart.100.bk", "notes.txt"):
        (tmp_path / name).write_text("x")
    assert RunLock(tmp_path).foreign() is None
    _age(tmp_path / "notes.txt", 3600)                # not a file of the run's: not looked at
    _age(tmp_path / STRESS, MARK_SLACK_S / 2)         # within the file system's slack
    assert RunLock(tmp_path).foreign() is None


def test_a_file_older_than_the_mark_is_not_the_runs(tmp_path):
    RunLock(tmp_path).mark()
    for name in (DECK, STRESS, "restart.100.bk"):
        (tmp_path / name).write_text("x")
    _age(tmp_path / STRESS, 3600)
    _age(tmp_path / "restart.100.bk", 3600)
    assert RunLock(tmp_path).foreign() == (
        "holds restart.100.bk, stress.csv, older than its .bkflow-run mark: not files of the run "
        "bkflow began here, so not replaced")


@pytest.mark.parametrize("mark, why", [
    ("", "holds a .bkflow-run mark that bkflow did not write (an empty or edited file), beside "
         "in.bk"),
    ('{"began": 1}', "holds a .bkflow-run mark that bkflow did not write"),
    ("[1, 2]", "holds a .bkflow-run mark that bkflow did not write"),
    ("copied", "holds a .bkflow-run mark that bkflow wrote in another directory (copied here, "
               "or this directory is a copy), beside in.bk"),
    ("a link", "holds a .bkflow-run mark that bkflow did not write"),
])
def test_a_mark_bkflow_did_not_write_here_claims_nothing(tmp_path, mark, why):
    d = tmp_path / "run"
    d.mkdir()
    (d / DECK).write_text("x")
    if mark == "copied":
        RunLock(tmp_path).mark()
        (d / MARK).write_bytes((tmp_path / MARK).read_bytes())
    elif mark == "a link":
        RunLock(tmp_path).mark()
        (d / MARK).symlink_to(tmp_path / MARK)
    else:
        (d / MARK).write_text(mark)
    assert RunLock(d).foreign().startswith(why)


def test_a_mark_beside_no_run_files_says_so(tmp_path):
    (tmp_path / MARK).write_text("")
    assert RunLock(tmp_path).foreign().endswith("beside no run files")


def test_what_makes_a_directory_not_bkflows_to_write_a_run_into(tmp_path):
    d = tmp_path / "d"
    d.mkdir()
    for name in (LOCK, ".x.tmp", "signac_statepoint.json", "signac_job_document.json"):
        (d / name).write_text("x")                    # bookkeeping and signac's: nobody's run
    assert RunLock(d).foreign() is None
    (d / PARAMS).write_text("{}")
    (d / STRESS).write_text("t,sigma_x\n")
    assert RunLock(d).foreign() == "holds a run made with lmp -in in.bk (params.json, stress.csv)"
    (d / META).write_text("{}")                       # bkflow's run, finished or not
    assert RunLock(d).foreign() is None
    many = tmp_path / "many"
    many.mkdir()
    for k in range(5):
        (many / f"n{k}.txt").write_text("x")
    assert RunLock(many).foreign() == ("holds files that are not a bkflow run "
                                       "(n0.txt, n1.txt, n2.txt and 2 more)")
