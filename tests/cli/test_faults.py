"""Nothing lost, nothing misread: one test per class of fault (the full fuzz of about 80
cases is benchmarks/checks/faults/). Each asserts the exit code, the one-line message and that
no finished result changed or was mis-marked."""

from __future__ import annotations

import errno
import hashlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from bkflow.cli.guards import (
    EXIT_BAD_INPUT,
    EXIT_BUSY,
    EXIT_FILE_SYSTEM,
    EXIT_INTERRUPTED,
    EXIT_RUN_FAILED,
)
from bkflow.store.layout import META, SUMMARY
from bkflow.store.rundir import RunDir
from tests.support import fresh_python, tool

ROOT = Path(__file__).resolve().parents[2]

SHORT = ["--t-end", "100", "--scene", "friction", "--quiet"]


def bk(*args, cwd=None, timeout=300):
    return subprocess.run([tool("bkflow"), *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=timeout)


def started(*args) -> subprocess.Popen:
    """``bkflow run ARGS --quiet`` in the background, once its records have begun."""
    out = Path(args[args.index("--out") + 1])
    # SIGINT at its default, as for a terminal's foreground job: a shell starts a background
    # job (and so this suite, when it runs in one) with SIGINT ignored, which children inherit
    p = subprocess.Popen([tool("bkflow"), "run", *map(str, args), "--quiet"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.time() + 60
    while not (out / "extrema.npy").exists() and time.time() < deadline:
        time.sleep(0.1)
    return p


def one_line(proc, needle: str) -> None:
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], proc.stderr
    assert "Traceback" not in proc.stderr


def digest(d: Path) -> dict:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(d.iterdir())
            if p.is_file() and p.suffix != ".lock"}


@pytest.fixture(scope="module")
def finished(lammps, tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("finished") / "run"
    p = bk("run", "--phi", "10", "--t-end", "200", "--scene", "full", "--out", d, "--quiet")
    assert p.returncode == 0, p.stderr
    return d


@pytest.mark.parametrize("name", ["with space", "hash#", "dollar$HOME", "quote'\"", "ünï ß"])
@pytest.mark.slow
def test_paths_of_any_characters_work(lammps, tmp_path, name):
    d = tmp_path / name
    d.mkdir()
    p = bk("run", "--phi", "10", *SHORT, "--out", "r", cwd=d)
    assert p.returncode == 0, p.stderr
    assert RunDir(d / "r").problem() is None
    assert bk("analyze", d / "r").returncode == 0


def test_a_cut_file_is_refused_not_analysed(tmp_path, finished):
    d = tmp_path / "run"
    shutil.copytree(finished, d)
    data = (d / "extrema.npy").read_bytes()
    (d / "extrema.npy").write_bytes(data[:len(data) // 2])
    before = (d / SUMMARY).read_bytes()
    p = bk("analyze", d)
    assert p.returncode == EXIT_BAD_INPUT
    one_line(p, "extrema.npy has")
    assert (d / SUMMARY).read_bytes() == before
    d2 = tmp_path / "slips"
    shutil.copytree(finished, d2)
    data = (d2 / "slips.lammpstrj").read_bytes()
    (d2 / "slips.lammpstrj").write_bytes(data[:len(data) // 2])
    p = bk("analyze", d2)
    assert p.returncode == EXIT_BAD_INPUT
    one_line(p, "slips.lammpstrj has")


@pytest.mark.slow
def test_two_writers_one_directory(lammps, tmp_path, finished):
    before = digest(finished)
    first = started("--phi", "1000", "--n", "400", "--t-end", "1000", "--out", tmp_path / "r")
    second = bk("run", "--phi", "1000", "--n", "400", "--t-end", "1000", "--quiet", "--out",
                tmp_path / "r")
    first.communicate(timeout=600)
    assert second.returncode == EXIT_BUSY
    one_line(second, "another bkflow process is writing")
    assert first.returncode == 0 and RunDir(tmp_path / "r").problem() is None
    # a directory that is not bkflow's run is refused, and left as it was
    deck = tmp_path / "deck"
    assert bk("deck", "--phi", "10", "--out", deck).returncode == 0
    p = bk("run", "--phi", "10", *SHORT, "--out", deck)
    assert p.returncode == EXIT_BAD_INPUT
    one_line(p, "holds a deck written by bkflow deck")
    assert sorted(os.listdir(deck)) == ["data.bk", "in.bk", "params.json"]
    p = bk("deck", "--phi", "10", "--out", finished)
    assert p.returncode == EXIT_BAD_INPUT
    one_line(p, "holds a run")
    assert digest(finished) == before


def test_file_system_errors_are_one_line(lammps, tmp_path, finished):
    (tmp_path / "file").write_text("x")
    p = bk("run", "--phi", "10", *SHORT, "--out", tmp_path / "file" / "r")
    assert p.returncode == EXIT_FILE_SYSTEM
    one_line(p, "Not a directory")
    p = bk("run", "--phi", "10", *SHORT, "--out", tmp_path / ("n" * 300))
    assert p.returncode == EXIT_FILE_SYSTEM
    one_line(p, "File name too long")
    small = tmp_path / "small"
    small.mkdir()
    # a run of 40000 time units writes about 400 kB of records (the friction scene): more
    # than the 64 kB here
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(small)],
                      capture_output=True).returncode != 0:
        pytest.skip("a full disk needs a tmpfs mount (root)")
    try:
        p = bk("run", "--phi", "10", "--t-end", "40000", "--protocol", "paper", "--scene",
               "friction", "--quiet", "--force", "--out", small / "r")
        assert p.returncode == EXIT_FILE_SYSTEM
        one_line(p, "No space left on device")
        assert not (small / "r" / META).exists()
    finally:
        subprocess.run(["umount", str(small)])


def test_damaged_inputs_are_one_line(lammps, tmp_path, finished):
    d = tmp_path / "run"
    shutil.copytree(finished, d)
    meta = json.loads((d / META).read_text())
    del meta["params"]
    (d / META).write_text(json.dumps(meta))
    p = bk("analyze", d)
    assert p.returncode == EXIT_BAD_INPUT
    one_line(p, "holds no run parameters")
    deck = tmp_path / "deck"
    bk("deck", "--phi", "10", "--out", deck)
    (deck / "extrema.npy").write_bytes(b"")
    (deck / "params.json").write_text("[1, 2]")
    p = bk("analyze", deck)
    assert p.returncode == EXIT_BAD_INPUT
    one_line(p, "params.json is not the one bkflow deck wrote beside in.bk")
    pipe = subprocess.run(f"'{tool('bkflow')}' run --help | head -1", shell=True,
                          capture_output=True, text=True)
    assert "usage" in pipe.stdout and pipe.stderr == ""


@pytest.mark.parametrize("args, needle", [
    (["run", "--phi", "1e12"], "atom-steps"),
    (["run", "--phi", "1", "--size", "40000x10000"], "of memory"),
    (["run", "--phi", "1", "--t-end", "1e300"], "more than LAMMPS counts"),
    (["sweep", "--phi", "1:10", "--points-per-decade", "10000", "--seeds", "1000", "--init"],
     "runs (limit"),
    (["sweep", "--phi", "1:1e300", "--points-per-decade", "1000000000", "--init"],
     "at most 100000"),
    (["sweep", "--phi", "1e-300:1e300", "--init"], "runs (limit"),  # B/A overflows a float
    (["sweep", "--phi", "1e-300:1e300", "--points-per-decade", "1", "--init"],
     "more than LAMMPS counts"),
    (["sweep", "--phi", "1,2", "--jobs", "1000"], "processes per core"),
])
def test_absurd_requests_are_refused_before_anything_is_created(tmp_path, args, needle):
    out = tmp_path / "out"
    p = bk(*args, "--out", out)
    assert p.returncode == EXIT_BAD_INPUT
    one_line(p, needle)
    assert not out.exists()


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP],
                         ids=["ctrl-c", "sigterm", "sighup"])
@pytest.mark.slow
def test_interrupts_are_honoured_within_a_second_and_the_advice_is_right(lammps, tmp_path,
                                                                          sig):
    """Ctrl-C, SIGTERM and SIGHUP (a closed terminal) stop a run within a second, after MPI
    and LAMMPS are loaded, and the same command resumes."""
    args = ("--phi", "1000", "--n", "900", "--t-end", "20000", "--out", tmp_path / "r")
    p = started(*args)  # LAMMPS is stepping: its stress series has begun
    time.sleep(0.2)
    t0 = time.time()
    p.send_signal(sig)
    _, err = p.communicate(timeout=60)
    # within a piece of LAMMPS's run (about 0.5 s; the run itself would take minutes), with
    # room for a loaded machine
    assert time.time() - t0 < 3.0 and p.returncode == EXIT_INTERRUPTED, err
    assert "run the same command again" in err and not RunDir(tmp_path / "r").is_complete()
    assert len(err.strip().splitlines()) == 1
    if sig != signal.SIGINT:
        return
    # a layer too soft for its drive tears at any time step: the message says so
    tear = bk("run", "--phi", "0.01", "--t-end", "2000", "--scene", "friction", "--quiet",
              "--out", tmp_path / "t")
    assert tear.returncode == EXIT_RUN_FAILED
    one_line(tear, "whatever the time step")


@pytest.mark.slow
def test_the_same_command_after_an_interrupted_analysis_only_analyses(lammps, tmp_path):
    out = tmp_path / "r"
    args = ["run", "--phi", "10", "--t-end", "300", "--scene", "friction", "--quiet"]
    assert bk(*args, "--no-analyze", "--out", out).returncode == 0
    meta = (out / META).read_bytes()
    p = bk(*args, "--out", out)
    assert p.returncode == 0 and "finished earlier; analysing" in p.stdout
    assert (out / META).read_bytes() == meta and (out / SUMMARY).exists()
    p = bk(*args, "--out", out)  # now analysed: the finished run is refused as before
    assert p.returncode == EXIT_BAD_INPUT
    one_line(p, "already holds a finished run")


def test_cluster_file_systems_without_flock_fsync_and_unique_temporaries(tmp_path, monkeypatch,
                                                                          capsys):
    import fcntl

    from bkflow.store import formats, lock

    def no_flock(fd, op):
        raise OSError(errno.ENOSYS, "Function not implemented")

    monkeypatch.setattr(fcntl, "flock", no_flock)
    monkeypatch.setattr(lock, "_WARNED_NO_FLOCK", set())
    for _ in range(2):
        with RunDir(tmp_path / "a").lock(), RunDir(tmp_path / "b").lock():
            pass
    err = capsys.readouterr().err
    assert err.count("does not support file locks") == 1  # warned once
    synced = []
    monkeypatch.setattr(os, "fsync", lambda fd: synced.append(fd))
    seen = []
    real_replace = os.replace
    monkeypatch.setattr(os, "replace", lambda a, b: (seen.append(Path(a).name),
                                                     real_replace(a, b)))
    formats.write_json_atomic(tmp_path / "x.json", {"a": 1})
    formats.write_json_atomic(tmp_path / "x.json", {"a": 2})
    assert len(synced) == 2 and len(set(seen)) == 2  # flushed to disk; a fresh name each time
    assert json.loads((tmp_path / "x.json").read_text()) == {"a": 2}


# --------------------------------------------------------------------------- lost workers
def _children(pid: int) -> list[int]:
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return []
    return [int(c) for c in text.split()]


def test_loading_mpi_leaves_the_signal_handlers_as_they_were(lammps):
    """MPICH's library installs a SIGHUP handler of its own when it is loaded (a sweep loads
    it before forking its workers), which swallowed the signal: a sweep sent SIGHUP ran on
    and exited 0. Loading it keeps the process' handlers, as the kernel sees them (a C
    extension's among them), from any thread."""
    code = (
        "import ctypes, signal\n"
        "libc = ctypes.CDLL(None)\n"
        "class SA(ctypes.Structure):\n"
        "    _fields_ = [('h', ctypes.c_void_p), ('mask', ctypes.c_ulong * 16),\n"
        "                ('flags', ctypes.c_int), ('r', ctypes.c_void_p)]\n"
        "def handler(n):\n"
        "    sa = SA(); libc.sigaction(n, None, ctypes.byref(sa)); return sa.h or 0\n"
        "import faulthandler, threading\n"
        "signal.signal(signal.SIGINT, lambda *a: None)\n"
        "faulthandler.register(signal.SIGTERM)\n"   # a handler Python's signal does not know
        "before = [handler(s) for s in (1, 2, 15)]\n"
        "from bkflow.lammps.plugin import load_mpi\n"
        "t = threading.Thread(target=load_mpi)\n"   # from a thread, as an API user may
        "t.start(); t.join()\n"
        "print(before == [handler(s) for s in (1, 2, 15)], before)\n")
    out = fresh_python(code, timeout=60)
    assert out.startswith("True"), out


@pytest.mark.slow
@pytest.mark.parametrize("cmd", ["run", "sweep", "sweep --jobs 1"])
def test_a_directory_removed_under_a_command_is_said_so(lammps, cmd, tmp_path):
    """The directory a run or a sweep writes into, removed while it runs (by the user, a
    cleanup script): one line that says so, the file system's exit code, no traceback (a
    sweep's worker met it inside flow, which wrapped it: "internal error", exit 70; in one
    process, --jobs 1, too)."""
    out = tmp_path / "gone"
    args = (["run", "--phi", "10", "--t-end", "20000", "--dt-factor", "0.05"] if cmd == "run"
            else ["sweep", "--phi", "300,1000", "--seeds", "1", "--t-end", "3000",
                  "--dt-factor", "0.02", "--protocol", "paper", "--jobs",
                  "1" if cmd.endswith("1") else "2"])
    p = subprocess.Popen([tool("bkflow"), *args, "--scene", "friction", "--quiet", "--out",
                          str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    while time.time() < deadline and not (list(out.glob("extrema.npy"))
                                          or list(out.glob("workspace/*/extrema.npy"))):
        time.sleep(0.1)
    time.sleep(0.5)
    assert p.poll() is None, "the command ended before its directory was removed"
    shutil.rmtree(out)
    stdout, stderr = p.communicate(timeout=120)
    done = subprocess.CompletedProcess(p.args, p.returncode, stdout, stderr)
    assert p.returncode == EXIT_FILE_SYSTEM, stderr
    one_line(done, "was removed while bkflow wrote into it")


@pytest.mark.slow
def test_a_sweep_under_nohup_outlives_the_hangup(lammps, tmp_path):
    """Started with SIGHUP ignored (nohup), a sweep and its workers keep ignoring it: a
    hangup sent to the whole process group (the terminal closed) leaves the sweep to finish."""
    out = tmp_path / "s"
    cmd = [tool("bkflow"), "sweep", "--phi", "300,1000", "--seeds", "1", "--t-end", "3000",
           "--dt-factor", "0.02", "--protocol", "paper", "--scene", "friction", "--jobs", "2",
           "--quiet", "--out", str(out)]
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         start_new_session=True,
                         preexec_fn=lambda: signal.signal(signal.SIGHUP, signal.SIG_IGN))
    deadline = time.time() + 120
    while time.time() < deadline and not list((out / "workspace").glob("*/extrema.npy")):
        time.sleep(0.1)
    time.sleep(0.5)
    assert p.poll() is None, "the sweep ended before the hangup"
    os.killpg(p.pid, signal.SIGHUP)
    stdout, stderr = p.communicate(timeout=300)
    assert p.returncode == 0, stderr
    assert "2 run(s) done" in stdout


@pytest.mark.slow
@pytest.mark.parametrize("target, sig", [("worker", signal.SIGKILL), ("worker", signal.SIGTERM),
                                         ("sweep", signal.SIGTERM), ("sweep", signal.SIGHUP)])
def test_a_sweep_whose_worker_dies_stops_by_itself_and_resumes(lammps, target, sig, tmp_path):
    """A worker killed mid-run (SIGKILL, the out-of-memory killer; SIGTERM): the sweep exits
    within 30 s with one line naming the runs under way. SIGTERM or SIGHUP to the sweep
    itself: it stops at once, its workers with it, as after Ctrl-C. The same command
    finishes."""
    out = tmp_path / "s"
    cmd = [tool("bkflow"), "sweep", "--phi", "300,1000", "--seeds", "2", "--t-end", "3000",
           "--dt-factor", "0.02", "--protocol", "paper", "--scene", "friction", "--jobs", "2",
           "--quiet", "--out", str(out)]
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    while time.time() < deadline and not list((out / "workspace").glob("*/extrema.npy")):
        time.sleep(0.1)
    workers = _children(p.pid)
    assert workers, "no worker process found"
    time.sleep(0.5)
    os.kill(workers[0] if target == "worker" else p.pid, sig)
    t_kill = time.time()
    stdout, stderr = p.communicate(timeout=60)
    done = subprocess.CompletedProcess(cmd, p.returncode, stdout, stderr)
    if target == "worker":
        assert time.time() - t_kill < 30
        assert p.returncode == EXIT_RUN_FAILED, stderr
        one_line(done, "a worker process of the sweep died")
        assert "phi=" in stderr and "the same command resumes" in stderr
    else:
        assert time.time() - t_kill < 5
        assert p.returncode == EXIT_INTERRUPTED, stderr
        one_line(done, "run the same command again to resume")
        time.sleep(0.5)
        assert not [w for w in workers if _alive(w)], "a worker outlived its sweep"
    again = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert again.returncode == 0, again.stderr
    assert "0 failed" in again.stdout
    assert len(list((out / "workspace").glob("*/meta.json"))) == 4


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.slow
def test_a_sweep_never_writes_over_the_users_files(tmp_path):
    """`bkflow sweep --out DIR` writes runs.csv, results.csv, analysis.json and a workspace:
    it refuses a directory of the user's own files, a run directory and a signac project that
    is not a sweep, before it writes anything, and goes on in its own sweeps, old or new."""
    cases = {
        "tables": {"results.csv": "mine\n", "runs.csv": "mine\n", "analysis.json": "{}\n"},
        "notes": {"notes.txt": "mine\n"},
        "run": {".bkflow-run": "", "stress.csv": "t,sigma_x\n"},
        "finished run": {"meta.json": "{}\n"},
        "signac": {".signac/config": "schema_version = 2\n",
                   "signac_project_document.json": '{"mine": 1}'},
    }
    for name, files in cases.items():
        d = tmp_path / name
        for rel, text in files.items():
            (d / rel).parent.mkdir(parents=True, exist_ok=True)
            (d / rel).write_text(text)
        before = {p: p.read_bytes() for p in d.rglob("*") if p.is_file()}
        for extra in ([], ["--init"]):
            p = bk("sweep", "--phi", "1,2", "--t-end", "100", "--out", d, *extra)
            assert p.returncode == EXIT_BAD_INPUT, (name, p.stderr)
            one_line(p, "choose another --out")
        assert {p: p.read_bytes() for p in d.rglob("*") if p.is_file()} == before, name
    # a file is not a directory
    (tmp_path / "file").write_text("mine\n")
    one_line(bk("sweep", "--phi", "1", "--out", tmp_path / "file"), "is a file")
    # its own sweep, and one made before sweeps were marked, are bkflow's
    own = tmp_path / "own"
    assert bk("sweep", "--phi", "1,2", "--t-end", "100", "--out", own, "--init").returncode == 0
    doc = own / "signac_project_document.json"
    assert "bkflow_sweep" in json.loads(doc.read_text())
    doc.write_text("{}")
    (own / "notes.txt").write_text("the user's notes in their own sweep\n")
    p = bk("sweep", "--phi", "1,2", "--t-end", "100", "--out", own, "--init")
    assert p.returncode == 0, p.stderr
    assert (own / "notes.txt").read_text().startswith("the user's")


def test_a_deck_replaces_only_a_deck_bkflow_wrote(tmp_path):
    """`bkflow deck` signs what it writes; a hand-written or hand-edited in.bk, data.bk or
    params.json is the user's and is never replaced."""
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "in.bk").write_text("# my own deck\nunits lj\n")
    p = bk("deck", "--phi", "10", "--out", mine)
    assert p.returncode == EXIT_BAD_INPUT
    one_line(p, "was not written by bkflow deck")
    assert (mine / "in.bk").read_text() == "# my own deck\nunits lj\n"
    assert sorted(os.listdir(mine)) == ["in.bk"]
    own = tmp_path / "own"
    assert bk("deck", "--phi", "10", "--out", own).returncode == 0
    assert bk("deck", "--phi", "20", "--out", own).returncode == 0  # its own: replaced
    assert "phi = 20" in (own / "in.bk").read_text()
    for name, edit in (("in.bk", lambda t: t.replace("run ", "run  ")),
                       ("data.bk", lambda t: t.replace("200 bonds", "200 bonds ")),
                       ("params.json", lambda t: t.replace("20.0", "20.5"))):
        d = tmp_path / f"edited_{name}"
        shutil.copytree(own, d)
        (d / name).write_text(edit((d / name).read_text()))
        before = digest(d)
        p = bk("deck", "--phi", "30", "--out", d)
        assert p.returncode == EXIT_BAD_INPUT, name
        one_line(p, f"{name} was not written by bkflow deck, or was edited")
        assert digest(d) == before


@pytest.mark.parametrize("fault", [KeyboardInterrupt, SystemExit,
                                   lambda: OSError(errno.ENOSPC, "No space left on device")],
                         ids=["ctrl-c", "sigterm", "disk full"])
def test_figures_and_movies_are_whole_or_not_written(tmp_path, monkeypatch, fault):
    """SIGTERM, Ctrl-C or a full disk while a figure or a movie is written leaves the old
    file as it was and no temporary behind."""
    import matplotlib
    import numpy as np

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    from bkflow.figures.fronts import front_movie
    from bkflow.figures.writer import save_figure as _save
    from bkflow.store.formats import Front

    fig = Figure()
    fig.add_subplot().plot([0, 1], [1, 0])
    _save(fig, tmp_path, "fig", ["png", "pdf"])
    front = Front(10, 20, np.arange(10, 20), np.random.default_rng(1).normal(size=(10, 12)),
                  False)
    gif = tmp_path / "slip.gif"
    assert front_movie(front, 4, 3, 0.01, gif) == 10
    old = digest(tmp_path)

    def failing(*args, **kw):  # write half, then the fault
        raise fault()

    # the fault strikes inside the writers (matplotlib's and Pillow's), after they began
    from PIL import Image
    monkeypatch.setattr(Figure, "savefig", lambda self, f, **kw: (f.write(b"half"), failing()))
    monkeypatch.setattr(Image.Image, "save", lambda self, f, **kw: (f.write(b"GIF8"),
                                                                  failing()))
    raised = (KeyboardInterrupt, SystemExit, OSError)
    for call in (lambda: _save(fig, tmp_path, "fig", ["png", "pdf"]),
                 lambda: front_movie(front, 4, 3, 0.01, gif)):
        with pytest.raises(raised):
            call()
    assert digest(tmp_path) == old
    assert not [p for p in os.listdir(tmp_path) if p.endswith(".tmp")]


@pytest.mark.parametrize("env, needle", [
    ({"OMP_NUM_THREADS": "4,2"}, None),  # a valid OpenMP value: works (numexpr read it badly)
    ({"MPLBACKEND": "garbage"}, None),  # the command line writes files: Agg
    ({"SIGNAC_FLOW_ENVIRONMENT": "garbage"}, None),  # a local command submits nothing
    ({"OMP_NUM_THREADS": "abc"}, "OMP_NUM_THREADS='abc' is not an OpenMP thread count"),
    ({"OMP_NUM_THREADS": "1.5"}, "OMP_NUM_THREADS='1.5'"),
    ({"NUMEXPR_NUM_THREADS": "x"}, "NUMEXPR_NUM_THREADS='x' is not a number of threads"),
    ({"NUMEXPR_MAX_THREADS": "-3"}, "NUMEXPR_MAX_THREADS"),
    ({"TQDM_MININTERVAL": "abc"}, "TQDM_MININTERVAL: tqdm (the progress bars) cannot read it"),
    ({"PMI_SIZE": "1"}, None),  # one process under a launcher (srun -n 1): works
    ({"OMPI_COMM_WORLD_SIZE": "3"}, "started as 3 MPI processes (mpirun -np 3)"),
    # an outer srun -n 1's PMI_SIZE does not hide Open MPI's count; a non-ASCII digit is no count
    ({"PMI_SIZE": "1", "OMPI_COMM_WORLD_SIZE": "4"}, "started as 4 MPI processes"),
    ({"PMI_SIZE": "\u00b2"}, None),
], ids=lambda v: "-".join(f"{k}={x}" for k, x in v.items()) if isinstance(v, dict) else "")
def test_the_environment_is_named_never_blamed_on_the_run(tmp_path, finished, env, needle):
    """A bad environment variable of a library under bkflow is named in one line (exit 2);
    a run is damaged only when its files are."""
    d = tmp_path / "run"
    shutil.copytree(finished, d)
    before = digest(d)
    p = subprocess.run([tool("bkflow"), "analyze", str(d)], capture_output=True, text=True,
                       env={**os.environ, **env}, timeout=300)
    if needle is None:
        assert p.returncode == 0, p.stderr
        assert "mu_bar" in p.stdout
    else:
        assert p.returncode == EXIT_BAD_INPUT
        one_line(p, needle)
        assert "damaged" not in p.stderr
        assert digest(d) == before


def _refused_under_mpirun(p, prefix):
    """Every copy that got to say anything said the refusal in one line; MPICH's launcher may
    end the others once the first has left with exit 2 (then only it speaks, and the launcher's
    own exit code is its)"""
    assert p.returncode != 0, p.stderr
    ours = [ln for ln in p.stderr.splitlines() if ln.startswith(prefix.split(":")[0])]
    assert 1 <= len(ours) <= 2, p.stderr
    assert all(ln.startswith(prefix) and "bkflow deck" in ln for ln in ours), p.stderr
    assert "Traceback" not in p.stderr


def test_bkflow_under_mpirun_is_refused_not_hung(lammps, tmp_path):
    """mpirun -np 2 bkflow run started two bkflow processes in one MPI world: one took the
    run's lock and the other left, and the first waited for it forever. Each copy now says in
    one line what to do instead (exit 2), and nothing is created."""
    d = tmp_path / "run"
    p = subprocess.run([tool("mpirun"), "-np", "2", tool("bkflow"), "run", "--phi", "1",
                        "--t-end", "10", "--out", str(d)],
                       capture_output=True, text=True, timeout=120)
    _refused_under_mpirun(p, "bkflow: error: bkflow was started as 2 MPI processes")
    assert not d.exists()
    p = subprocess.run([tool("mpirun"), "-np", "2", tool("bkflow"), "--version"],
                       capture_output=True, text=True, timeout=120)
    _refused_under_mpirun(p, "bkflow: error: bkflow was started as 2 MPI processes")
    assert p.stdout == ""
    # the cluster's command line too (its run would hang the same way), before it reads anything
    p = subprocess.run([tool("mpirun"), "-np", "2", sys.executable, "-m", "bkflow.slurm",
                        "run"], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    _refused_under_mpirun(p, "bkflow.slurm: error: bkflow was started as 2 MPI processes")
    assert sorted(os.listdir(tmp_path)) == []


@pytest.mark.slow
def test_odd_process_states_are_one_line(lammps, tmp_path):
    """stderr closed, the current directory deleted, a name that is not UTF-8, a memory
    limit, and a bug of bkflow's own: one line each, a documented exit code, no traceback."""
    from bkflow.cli.guards import EXIT_INTERNAL, EXIT_RESOURCES

    short = ["--phi", "1", "--t-end", "20", "--scene", "friction", "--quiet"]
    # stderr closed: the run runs (it has nowhere to complain)
    p = subprocess.run(f"'{tool('bkflow')}' run {' '.join(short)} --out '{tmp_path}/se' 2>&-",
                       shell=True, capture_output=True, text=True)
    assert p.returncode == 0 and RunDir(tmp_path / "se").is_complete()
    # the current directory deleted: absolute paths work, a relative one is named
    gone = tmp_path / "gone"
    gone.mkdir()
    for out, rc in ((tmp_path / "abs", 0), ("rel", EXIT_FILE_SYSTEM)):
        p = subprocess.run(f"cd '{gone}' && rmdir '{gone}' && '{tool('bkflow')}' run "
                           f"{' '.join(short)} --out '{out}'", shell=True, capture_output=True,
                           text=True)
        gone.mkdir(exist_ok=True)
        assert p.returncode == rc, p.stderr
        if rc:
            one_line(p, "the current directory no longer exists")
    # a name that is not UTF-8 (signac and the tables need one)
    bad = os.fsdecode(os.fsencode(str(tmp_path)) + b"/bad\xff")
    for cmd in (["sweep", "--phi", "1", "--seeds", "1", *short[2:]], ["collect"]):
        p = subprocess.run([tool("bkflow"), *cmd, bad] if cmd == ["collect"]
                           else [tool("bkflow"), *cmd, "--out", bad], capture_output=True)
        assert p.returncode == EXIT_BAD_INPUT
        assert len(p.stderr.splitlines()) == 1 and b"not a UTF-8 name" in p.stderr
    assert not os.path.exists(os.fsencode(bad))
    # a memory limit: named, not called damage
    import resource

    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (400 * 2**20, 400 * 2**20))

    p = subprocess.run([tool("bkflow"), "run", *short, "--out", str(tmp_path / "mem")],
                       capture_output=True, text=True, preexec_fn=limit, timeout=120)
    assert p.returncode == EXIT_RESOURCES, p.stderr
    one_line(p, "out of memory")
    def analyze_raising(error: str):  # `bkflow analyze` whose command raises ``error``
        return subprocess.run(
            [sys.executable, "-c", "import bkflow.cli.commands as c, sys\n"
             f"def f(a):\n    raise {error}\n"
             "c._analyze = f\nsys.exit(c.main(['analyze', '/nonexistent']))"],
            capture_output=True, text=True)

    # memory that runs out later, in the middle of a command (pandas, MDAnalysis): exit 5
    oom = analyze_raising("MemoryError()")
    assert oom.returncode == EXIT_RESOURCES
    one_line(oom, "out of memory")
    # a bug: one line, exit 70, the traceback kept in a file
    from bkflow.cli import guards

    boom = analyze_raising("ZeroDivisionError('division by zero')")
    assert boom.returncode == EXIT_INTERNAL == guards.EXIT_INTERNAL
    one_line(boom, "internal error (ZeroDivisionError: division by zero)")
    saved = boom.stderr.split("the traceback is in ")[1].split(":")[0]
    assert "ZeroDivisionError" in Path(saved).read_text()
    os.unlink(saved)


@pytest.fixture(scope="module")
def small_sweep(lammps, tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("sweep") / "s"
    p = bk("sweep", "--phi", "1,3", "--seeds", "1", "--t-end", "200", "--scene", "clusters",
           "--protocol", "paper", "--jobs", "1", "--quiet", "--out", d)
    assert p.returncode == 0, p.stderr
    return d


def _tree(d: Path) -> dict:
    return {str(p.relative_to(d)): p.read_bytes() for p in sorted(d.rglob("*"))
            if p.is_file() and not p.name.endswith(".lock")}


def _first_job(d: Path) -> Path:
    return sorted((d / "workspace").iterdir())[0]


@pytest.mark.parametrize("edit, needle", [
    ("statepoint", "holds a state point whose hash is not its name"),
    ("renamed", "holds a state point whose hash is not its name"),
    ("empty job", "has no signac_statepoint.json"),
    ("no statepoint", "has no signac_statepoint.json"),
    ("cut statepoint", "has an unreadable signac_statepoint.json"),
    ("cut job document", "has a cut signac_job_document.json"),
    ("cut project document", "signac_project_document.json is cut or damaged"),
    ("junk config", "is not a signac config"),
    ("rehashed, no run", "holds a state point that is no run (phi must be > 0"),
    ("no config", ".signac/config is missing from a sweep directory"),
])
@pytest.mark.slow
def test_a_hand_edited_workspace_is_named_with_its_repair(tmp_path, small_sweep, edit, needle):
    """Every hand edit of signac's records is one line that says what and how to repair it;
    nothing is changed, and once repaired as it says the sweep goes on."""
    d = tmp_path / "s"
    shutil.copytree(small_sweep, d)
    job = _first_job(d)
    sp = job / "signac_statepoint.json"
    if edit == "statepoint":
        sp.write_text(sp.read_text().replace('"seed": 1', '"seed": 2'))
    elif edit == "renamed":
        job = job.rename(job.with_name("f" * 32))
    elif edit == "empty job":
        job = d / "workspace" / ("0" * 32)
        job.mkdir()
    elif edit == "no statepoint":
        sp.unlink()
    elif edit == "cut statepoint":
        sp.write_text(sp.read_text()[:40])
    elif edit == "cut job document":
        (job / "signac_job_document.json").write_text('{"err')
    elif edit == "rehashed, no run":   # edited and renamed to its hash: consistent, no run
        from signac.job import calc_id

        point = json.loads(sp.read_text())
        point["phi"] = -1.0
        sp.write_text(json.dumps(point))
        job = job.rename(job.with_name(calc_id(point)))
    elif edit == "no config":
        (d / ".signac" / "config").unlink()
    elif edit == "cut project document":
        (d / "signac_project_document.json").write_text('{"ana')
    else:
        (d / ".signac" / "config").write_text("junk!!\n[[[\n")
    before = _tree(d)
    for cmd in (["collect", d], ["sweep", "--phi", "1,3", "--seeds", "1", "--t-end", "200",
                                 "--scene", "clusters", "--protocol", "paper", "--out", d]):
        p = bk(*cmd)
        assert p.returncode == EXIT_BAD_INPUT, p.stderr
        one_line(p, needle)
    assert _tree(d) == before
    # repaired as the message says: the sweep is whole again
    msg = p.stderr
    if "move it out of workspace/" in msg:
        shutil.move(str(job), str(tmp_path / "aside"))
    elif "delete that file" in msg or "delete it" in msg:
        (job / "signac_job_document.json").unlink(missing_ok=True)
        (d / "signac_project_document.json").unlink(missing_ok=True)
    else:
        (d / ".signac" / "config").write_text("schema_version = 2\n")
    p = bk("collect", d)
    assert p.returncode == 0, p.stderr


@pytest.mark.slow
def test_figures_come_from_one_analysis_or_none(tmp_path, small_sweep):
    """An interrupted `collect --analysis` leaves some runs re-analysed and the tables old:
    plot refuses, naming the cure; after it, plot draws. A second sweep that changes the
    tables removes the figures of the old ones (and only those)."""
    from bkflow.analysis.summary import analyze
    from bkflow.model.settings import AnalysisSettings

    d = tmp_path / "s"
    shutil.copytree(small_sweep, d)
    assert bk("plot", d).returncode == 0
    (d / "figures" / "mine.txt").write_text("the user's own\n")
    analyze(_first_job(d), AnalysisSettings(slip_threshold=0.05))  # the collect cut short
    before = _tree(d / "figures")
    p = bk("plot", d)
    assert p.returncode == EXIT_BAD_INPUT
    one_line(p, f"run bkflow collect {d} to bring them together")
    assert _tree(d / "figures") == before
    # the sweep's own settings changed, the tables not
    doc = json.loads((d / "signac_project_document.json").read_text())
    doc["analysis_settings"] = {"slip_threshold": 0.05}
    (d / "signac_project_document.json").write_text(json.dumps(doc))
    one_line(bk("plot", d), "the sweep's analysis settings are not those its tables")
    p = bk("collect", d, "--analysis", "slip_threshold=0.05")
    assert p.returncode == 0, p.stderr
    assert "removed 14 figure file(s)" in p.stdout  # the tables changed (7 figures, 2 formats)
    assert sorted(os.listdir(d / "figures")) == ["mine.txt"]
    assert bk("plot", d).returncode == 0
    assert (d / "figures" / "fig2a_friction.png").is_file()


@pytest.mark.slow
def test_lmp_in_a_finished_run_leaves_it_finished(lammps, tmp_path):
    """The README invites `lmp -in in.bk` in a finished run: it writes every file again bit
    for bit (an adaptive run's deck runs the steps it ran), only log.lammps changes, and the
    run stays finished and analysed."""
    d = tmp_path / "r"
    p = bk("run", "--phi", "10", "--size", "12x3", "--target-error", "2e-3", "--out", d,
           "--quiet")
    assert p.returncode == 0, p.stderr
    assert json.loads((d / META).read_text())["adaptive"]["reached"]
    before = {k: v for k, v in _tree(d).items() if not k.endswith("log.lammps")}
    for where in (d, d / "companion"):
        lmp = subprocess.run([tool("lmp"), "-in", "in.bk"], cwd=where, capture_output=True,
                             text=True, timeout=300)
        assert lmp.returncode == 0, lmp.stdout[-2000:]
    assert {k: v for k, v in _tree(d).items() if not k.endswith("log.lammps")} == before
    assert RunDir(d).problem() is None
    p = bk("analyze", d)
    assert p.returncode == 0 and "re-analysed" not in p.stdout
    # a file that did change is still damage
    (d / "extrema.npy").write_bytes((d / "extrema.npy").read_bytes()[:-10])
    one_line(bk("analyze", d), "extrema.npy has")


@pytest.mark.slow
def test_the_documented_slurm_commands_run(lammps, tmp_path):
    """Every `python -m bkflow.slurm run ...` that README, docs and slurm.py show is
    accepted by flow and finishes the runs."""
    import re

    texts = [p.read_text() for p in (ROOT / "README.md", ROOT / "docs" / "slurm.md",
                                     ROOT / "src" / "bkflow" / "slurm.py")]
    cmds = sorted({m.strip() for t in texts
                   for m in re.findall(r"python -m bkflow\.slurm run([^`\n#]*)", t)})
    assert cmds, "no documented SLURM run command found"
    for i, args in enumerate(cmds):
        d = tmp_path / f"c{i}"
        assert bk("sweep", "--phi", "1,3", "--seeds", "1", "--t-end", "50", "--scene",
                  "friction", "--protocol", "paper", "--out", d, "--init").returncode == 0
        p = subprocess.run([sys.executable, "-m", "bkflow.slurm", "run", *args.split()],
                           cwd=d, capture_output=True, text=True, timeout=600)
        assert p.returncode == 0, (args, p.stderr[-2000:])
        assert len(list((d / "workspace").glob("*/meta.json"))) == 2, args


@pytest.mark.parametrize("how", ["a directory", "a symlink loop", "a dangling symlink"])
def test_an_unreadable_run_record_is_never_redone(lammps, tmp_path, finished, how):
    """A meta.json that is there but cannot be read: bkflow cannot tell whether the run is
    finished, so it neither redoes nor analyses it (exit 4), with or without --overwrite."""
    d = tmp_path / "r"
    shutil.copytree(finished, d)
    meta = d / META
    meta.unlink()
    if how == "a directory":
        meta.mkdir()
    elif how == "a symlink loop":
        meta.symlink_to(META)
    else:
        meta.symlink_to(tmp_path / "nowhere.json")
    before = digest(d)
    for args in (["run", "--phi", "3", *SHORT, "--out", d],
                 ["run", "--phi", "3", *SHORT, "--overwrite", "--out", d], ["analyze", d]):
        p = bk(*args)
        if how == "a dangling symlink" and args[0] == "analyze":
            assert p.returncode in (EXIT_BAD_INPUT, EXIT_FILE_SYSTEM)
        else:
            assert p.returncode == EXIT_FILE_SYSTEM, (args, p.stderr)
        assert len(p.stderr.strip().splitlines()) == 1 and "Traceback" not in p.stderr
        assert digest(d) == before, args


@pytest.mark.slow
def test_plot_and_movie_never_replace_a_users_file(lammps, tmp_path, small_sweep, finished):
    out = tmp_path / "figs"
    out.mkdir()
    (out / "fig2a_friction.png").write_text("my figure\n")
    p = bk("plot", small_sweep, "--out", out)
    assert p.returncode == EXIT_BAD_INPUT
    one_line(p, "exists and was not written by bkflow")
    assert (out / "fig2a_friction.png").read_text() == "my figure\n"
    mine = tmp_path / "precious.gif"
    mine.write_text("my movie\n")
    p = bk("movie", finished, "--out", mine)
    assert p.returncode == EXIT_BAD_INPUT and mine.read_text() == "my movie\n"
    one_line(p, "exists and was not written by bkflow")
    (tmp_path / "fronts_slip0.png").write_text("my maps\n")
    p = bk("movie", finished, "--out", tmp_path / "new.gif")
    assert p.returncode == EXIT_BAD_INPUT and not (tmp_path / "new.gif").exists()
    ok = tmp_path / "ok"
    ok.mkdir()
    for _ in range(2):  # its own movie is replaced
        assert bk("movie", finished, "--out", ok / "m.gif").returncode == 0
    p = bk("movie", finished, "--out", tmp_path / "no" / "m.gif")
    one_line(p, "does not exist")
    # what matplotlib cannot write here, or a selection with nothing to draw: one line, or a
    # note per figure
    p = bk("plot", small_sweep, "--out", tmp_path / "pgf", "--format", "pgf")
    if p.returncode != 0:
        assert p.returncode == EXIT_BAD_INPUT
        one_line(p, "matplotlib cannot write pgf here")
    p = bk("plot", small_sweep, "--out", tmp_path / "w", "--where", "state=steady")
    assert p.returncode in (0, EXIT_BAD_INPUT) and "Traceback" not in p.stderr
    record = json.loads((out.parent / "w" / "figures.json").read_text()) \
        if (tmp_path / "w" / "figures.json").exists() else {"complete": True}
    assert record["complete"]


@pytest.mark.parametrize("limit, needle", [("ulimit -n 20", "at most 20 files"),
                                           ("ulimit -f 200", "files of at most"),
                                           ("ulimit -v 300000", "out of memory")])
def test_process_limits_are_named_before_mpi_starts(tmp_path, limit, needle):
    """Below what MPI needs, its start aborts from C (exit 134 or 143, a stack of lines):
    bkflow names the limit first (exit 5)."""
    from bkflow.cli.guards import EXIT_RESOURCES

    p = subprocess.run(f"{limit}; '{tool('bkflow')}' run --phi 10 {' '.join(SHORT)} "
                       f"--out '{tmp_path}/r'", shell=True, capture_output=True, text=True)
    assert p.returncode == EXIT_RESOURCES, p.stderr
    one_line(p, needle)
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize("args, env", [
    (["status", "-j", "nosuchjob"], "StandardEnvironment"),
    (["run", "-j", "deadbeef"], "StandardEnvironment"),
    (["exec", "simulate", "nosuchjob"], "StandardEnvironment"),
    (["submit", "--bundle", "-1", "--pretend"], "StandardEnvironment"),
    (["status"], "NoSuchEnvironment"),
    (["submit", "--pretend"], "slurm"),
])
def test_cluster_bad_input_is_exit_2(tmp_path, small_sweep, args, env):
    """python -m bkflow.slurm: a job that does not exist, a bad option value or an
    environment signac-flow does not know is bad input (exit 2, one line), not "a run failed"
    (exit 1) with a scheduler hint, nor a traceback."""
    d = tmp_path / "s"
    shutil.copytree(small_sweep, d)
    p = subprocess.run([sys.executable, "-m", "bkflow.slurm", *args], cwd=d,
                       capture_output=True, text=True, timeout=120,
                       env={**os.environ, "SIGNAC_FLOW_ENVIRONMENT": env})
    assert p.returncode == EXIT_BAD_INPUT, p.stderr
    assert len(p.stderr.strip().splitlines()) == 1 and "Traceback" not in p.stderr
    assert "no working scheduler" not in p.stderr
    if env != "StandardEnvironment":
        assert f"SIGNAC_FLOW_ENVIRONMENT={env} is no environment" in p.stderr


def test_the_advice_names_the_file_that_was_changed(tmp_path):
    """Class 10: a deck directory whose in.bk was edited after bkflow deck wrote it: the
    advice is about the deck (write it again with the change), not params.json; with params.json
    changed instead, about params.json."""
    for changed in ("in.bk", "params.json"):
        d = tmp_path / changed
        assert bk("deck", "--phi", "10", "--t-end", "50", "--out", d).returncode == 0
        f = d / changed
        text = f.read_text()
        f.write_text(re.sub(r"(?m)^run( +)\d+", r"run\g<1>100", text) if changed == "in.bk"
                     else text.replace('"seed": 1', '"seed": 2'))
        assert f.read_text() != text
        (d / "extrema.npy").write_bytes(b"")
        p = bk("analyze", d)
        assert p.returncode == EXIT_BAD_INPUT
        one_line(p, f"{changed} was edited after bkflow deck wrote it" if changed == "in.bk"
                 else "params.json is not the one bkflow deck wrote")


# ------------------------------------------------- shared sweeps, derived files, pasted commands
def _small_sweep(root: Path) -> Path:
    p = bk("sweep", "--phi", "1,1000", "--seeds", "1", "--sizes", "12x3", "--aspect", "any",
           "--t-end", "300", "--protocol", "paper", "--jobs", "2", "--out", root, "--quiet")
    assert p.returncode == 0, p.stderr
    return root


def test_a_plot_and_a_collect_exclude_each_other_and_the_record_is_of_what_was_read(
        lammps, tmp_path):
    """A plot under way and a collect that changes the tables: one of them waits its turn
    (busy, exit 3); figures.json then names the tables its figures were drawn from, and every
    file it lists is there."""
    import json

    from bkflow.store.tables import tables_digest

    s = _small_sweep(tmp_path / "s")
    plot = subprocess.Popen([tool("bkflow"), "plot", str(s)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    while time.time() < deadline and not (s / "figures" / "figures.json").exists():
        time.sleep(0.05)
    collect = bk("collect", s, "--analysis", "slip_threshold=0.02")
    plot.communicate(timeout=300)
    assert plot.returncode == 0
    assert collect.returncode == 3 and "busy" in collect.stderr, collect.stderr
    record = json.loads((s / "figures" / "figures.json").read_text())
    assert record["complete"] and record["tables_sha256"] == tables_digest(s)
    assert all((s / "figures" / f).is_file() for f in record["files"])
    # and the collect, once the plot is done, retires the figures of the old tables
    assert bk("collect", s, "--analysis", "slip_threshold=0.02").returncode == 0
    assert not (s / "figures" / "figures.json").exists()


def test_a_collect_cut_short_leaves_no_mixed_set_that_reads(lammps, tmp_path):
    """runs.csv, results.csv and the catalogue are one set with analysis.json, their record,
    written last: tables from two collects (one cut short, here its first table written over
    the set before) are refused by every reader, one line and the repair; collect repairs."""
    from bkflow.api import load_sweep
    from bkflow.store.tables import StaleTablesError

    s = _small_sweep(tmp_path / "s")
    runs = (s / "runs.csv").read_text()
    (s / "runs.csv").write_text(runs.replace("\n", "\n", 1) + "")   # the same bytes: fine
    assert load_sweep(s).runs is not None
    (s / "runs.csv").write_text(runs.rsplit("\n", 2)[0] + "\n")       # the last row cut
    with pytest.raises(StaleTablesError, match="bkflow collect"):
        _ = load_sweep(s).events
    p = bk("plot", s)
    assert p.returncode == EXIT_BAD_INPUT
    one_line(p, "bkflow collect")
    assert bk("collect", s).returncode == 0
    assert (s / "runs.csv").read_text() == runs
    assert load_sweep(s).events is not None


@pytest.mark.parametrize("damage", ["events cut", "events gone"])
def test_damaged_derived_files_are_redone_by_the_command_that_needs_them(lammps, tmp_path,
                                                                          damage):
    """A run's events.parquet cut mid-file, or gone (summary.json lists it): Run.events and
    Run.clusters refuse them (DamagedRunError), and collect, or the sweep's own command again,
    makes the analysis again (exit 0) rather than drawing from half a table."""
    from bkflow.api import load_sweep
    from bkflow.store.errors import DamagedRunError

    s = _small_sweep(tmp_path / "s")
    before = (s / "results.csv").read_text()
    job = next(p for p in (s / "workspace").iterdir() if (p / "clusters.npy").exists())
    if damage == "events cut":
        data = (job / "events.parquet").read_bytes()
        (job / "events.parquet").write_bytes(data[: len(data) // 2])
    else:
        (job / "events.parquet").unlink()
    for what in ("events", "clusters"):
        with pytest.raises(DamagedRunError):
            _ = getattr(load_sweep(s).run(job.name), what)
    p = bk("sweep", "--phi", "1,1000", "--seeds", "1", "--sizes", "12x3", "--aspect", "any",
           "--t-end", "300", "--protocol", "paper", "--jobs", "2", "--out", s, "--quiet")
    assert p.returncode == 0, p.stderr
    assert (s / "results.csv").read_text() == before
    assert bk("plot", s).returncode == 0


@pytest.fixture(scope="module")
def pair(lammps, tmp_path_factory) -> Path:
    """A finished run of the steady protocol (with its companion) and two other runs whose
    directories can stand in for the companion: the same layer from the random start, and
    another seed from the partial start."""
    d = tmp_path_factory.mktemp("pair")
    base = ["--phi", "10", "--size", "12x3", "--scene", "friction", "--quiet"]
    for args in ((*base, "--t-end", "600", "--out", d / "run"),
                 (*base, "--t-end", "600", "--protocol", "paper", "--start", "random",
                  "--out", d / "random"),
                 (*base, "--t-end", "600", "--protocol", "paper", "--start", "partial",
                  "--seed", "2", "--out", d / "seed2")):
        p = bk("run", *args)
        assert p.returncode == 0, p.stderr
    return d


@pytest.mark.parametrize("stand_in", ["random", "seed2", "the run itself", "longer"])
def test_a_companion_that_is_not_the_runs_is_refused(pair, tmp_path, stand_in):
    """Class 7: a run's companion/ replaced by a copy of another run (the same layer from the
    main run's start, another seed, the main run itself, or its own companion made to claim
    another length) is not this run's: analyze and the API refuse it in one line, never a
    gap of zero and 'steady'."""
    from bkflow.api import load_run
    from bkflow.store.errors import DamagedRunError

    run = tmp_path / "run"
    shutil.copytree(pair / "run", run)
    comp = run / "companion"
    if stand_in == "longer":
        meta = json.loads((comp / META).read_text())
        meta["params"]["t_end"] *= 2
        (comp / META).write_text(json.dumps(meta))
    else:
        shutil.rmtree(comp)
        src = pair / stand_in if stand_in != "the run itself" else pair / "run"
        shutil.copytree(src, comp, ignore=shutil.ignore_patterns("companion"))
    p = bk("analyze", run)
    assert p.returncode == EXIT_BAD_INPUT
    one_line(p, "not this run's")
    with pytest.raises(DamagedRunError, match="not this run's"):
        _ = load_run(run).summary


@pytest.mark.parametrize("option, setting", [
    (["--start", "partial"], ["--set", "start=partial"]),
    (["--t-end", "100"], ["--set", "t_end=100"]),
    (["--accuracy", "fast"], ["--set", "accuracy=fast"]),
    (["--dt-factor", "0.5"], ["--set", "dt_factor=0.5"]),
    (["--companion", "partial"], ["--set", "companion=partial"]),
    (["--until-steady"], ["--set", "until_steady=true"]),
    (["--target-error", "1e-3"], ["--set", "target_error=1e-3"]),
    (["--dt-factor", "2.5"], ["--set", "dt_factor=2.5"]),
])
def test_set_goes_through_the_options_checks(tmp_path, option, setting):
    """Class 9: a --set of a setting with an option of its own means what the option means
    and is checked as it is: the same deck, or the same refusal (a deck is one fixed run: no
    companion, no adaptive length; a step past the stability bound)."""
    got = []
    for i, args in enumerate((option, setting)):
        p = bk("deck", "--phi", "10", *args, "--out", tmp_path / str(i))
        params = (json.loads((tmp_path / str(i) / "params.json").read_text())
                  if p.returncode == 0 else None)
        got.append((p.returncode, params, p.stderr.replace("--set", "").strip()[:40]))
    assert got[0][0] == got[1][0]
    if got[0][0] == 0:
        assert got[0][1] == got[1][1]
    else:
        assert got[0][0] == EXIT_BAD_INPUT
        for i in (0, 1):
            assert len(bk("deck", "--phi", "10", *(option, setting)[i], "--out",
                          tmp_path / f"x{i}").stderr.strip().splitlines()) == 1


def test_a_sweep_varies_the_start_as_the_option_does(tmp_path):
    """--vary start=random,partial under the steady protocol: each start gets the protocol's
    companion from the other side (as --start partial does), not a refusal."""
    from bkflow.sweeps.project import open_project, spec_of

    p = bk("sweep", "--phi", "10", "--seeds", "1", "--vary", "start=random,partial",
           "--scene", "friction", "--out", tmp_path / "s", "--init")
    assert p.returncode == 0, p.stderr
    pairs = sorted((spec_of(j).start, spec_of(j).companion)
                   for j in open_project(tmp_path / "s", create=False))
    assert pairs == [("partial", "random"), ("random", "partial")]


@pytest.mark.parametrize("name", ["g $(touch PWNED)", "-x", "a'b; touch PWNED", "sp ace"])
def test_printed_commands_are_safe_to_paste(tmp_path, name):
    """Class 11: a command bkflow prints with a path in it (here sweep --init's) does, pasted
    into a shell, what it says: the path one word (quoted; "./-x" for a name that looks like an
    option), nothing in it run."""
    import shlex

    p = subprocess.run([tool("bkflow"), "sweep", "--phi", "10", "--seeds", "1",
                        f"--out={name}", "--init"], cwd=tmp_path, capture_output=True,
                       text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    cd = p.stdout.split("(cd ", 1)[1].split(" && ", 1)[0]
    assert shlex.split(cd) in ([name], [f"./{name}"])
    sh = subprocess.run(["bash", "-c", f"cd {cd} && pwd -P"], cwd=tmp_path,
                        capture_output=True, text=True, timeout=30)
    assert sh.returncode == 0, sh.stderr
    assert Path(sh.stdout.strip()) == (tmp_path / name).resolve()
    assert not list(tmp_path.rglob("PWNED"))
    from bkflow.store.files import shell_word

    for word in (name, f"/abs/{name}"):   # and the helper every printed command uses
        assert shlex.split(shell_word(word)) in ([word], [f"./{word}"])


@pytest.mark.parametrize("mark", ["empty", "bkflow's, newer than the file",
                                  "copied from a run", "copied with its times (cp -p)"])
def test_a_planted_mark_replaces_nothing(lammps, tmp_path, mark, finished):
    """Class 12: a .bkflow-run mark that bkflow did not write (empty), or one that is newer
    than the user's stress.csv beside it, proves nothing about that file: bkflow run refuses
    the directory (exit 2, one line) and the file is as it was. A real interrupted run of
    bkflow's is still redone (tests of interrupts)."""
    d = tmp_path / "mine"
    d.mkdir()
    (d / "stress.csv").write_text("my measurements\n")
    old = time.time() - 3600
    os.utime(d / "stress.csv", (old, old))
    if mark == "empty":
        (d / ".bkflow-run").write_text("")
        needle = "mark that bkflow did not write"
    elif mark.startswith("copied"):
        (d / "stress.csv").touch()   # the user's file as new as can be: the copy is later
        (shutil.copy2 if "cp -p" in mark else shutil.copy)(finished / ".bkflow-run",
                                                            d / ".bkflow-run")
        needle = "mark that bkflow wrote in another directory"
    else:
        rec = json.loads((finished / ".bkflow-run").read_text())
        os.stat(d)
        rec["directory"] = [os.stat(d).st_dev, os.stat(d).st_ino]
        (d / ".bkflow-run").write_text(json.dumps(rec))
        needle = "older than its .bkflow-run mark"
    before = digest(d)
    p = bk("run", "--phi", "10", *SHORT, "--out", d)
    assert p.returncode == EXIT_BAD_INPUT
    one_line(p, needle)
    assert digest(d) == before and (d / "stress.csv").read_text() == "my measurements\n"


@pytest.mark.parametrize("damage", ["an absolute path listed", "files not a list"])
def test_a_damaged_figures_record_is_drawn_past(tmp_path, small_sweep, damage):
    """Classes 1 and 6: figures.json naming a path outside (or not a list of names) is no
    record of bkflow's figures: plot draws them again (exit 0), touching nothing outside."""
    d = tmp_path / "s"
    shutil.copytree(small_sweep, d)
    victim = tmp_path / "victim.png"
    victim.write_bytes(b"mine")
    assert bk("plot", d).returncode == 0
    rec = d / "figures" / "figures.json"
    r = json.loads(rec.read_text())
    r["files"] = [*r["files"], str(victim)] if damage.startswith("an absolute") \
        else "../../victim.png"
    rec.write_text(json.dumps(r))
    for _ in range(2):
        p = bk("plot", d)
        assert p.returncode == 0, p.stderr
    assert victim.read_bytes() == b"mine"
    assert all(not Path(f).is_absolute() for f in json.loads(rec.read_text())["files"])


def test_figures_of_another_selection_do_not_stay_beside_the_new_record(tmp_path, small_sweep):
    """Class 3: figures.json of another --where (or other tables) lists a figure this plot
    does not draw: it is removed, so that the directory holds only the record's figures."""
    d = tmp_path / "s"
    shutil.copytree(small_sweep, d)
    assert bk("plot", d, "--where", "phi=1").returncode == 0
    fig = d / "figures"
    old = fig / "fig_old.png"
    shutil.copy(fig / "fig2a_friction.png", old)     # a bkflow figure no plot draws now
    rec = json.loads((fig / "figures.json").read_text())
    rec["files"].append("fig_old.png")
    (fig / "figures.json").write_text(json.dumps(rec))
    assert bk("plot", d).returncode == 0
    assert not old.exists()
    now = json.loads((fig / "figures.json").read_text())
    assert now["complete"] and now["where"] is None
    assert {p.name for p in fig.iterdir() if p.name != "figures.json"} == set(now["files"])


@pytest.mark.parametrize("where", ["a run's summary.json", "a run's meta.json",
                                   "a deck's extrema.npy"])
def test_a_fifo_where_a_file_belongs_is_refused_never_waited_on(tmp_path, small_sweep, where):
    """Class 10: a FIFO in place of a file bkflow reads would block a read forever: every
    command refuses it in one line (or, where the file is bkflow's to write, replaces it) and
    none waits; a sweep calls such a run refused (exit 2), not 'retried'."""
    if where == "a deck's extrema.npy":
        d = tmp_path / "deck"
        assert bk("deck", "--phi", "10", "--t-end", "50", "--out", d).returncode == 0
        os.mkfifo(d / "extrema.npy")
        p = bk("analyze", d, timeout=60)
        assert p.returncode == EXIT_BAD_INPUT
        one_line(p, "is not a regular file")
        return
    d = tmp_path / "s"
    shutil.copytree(small_sweep, d)
    job = _first_job(d)
    name = "summary.json" if "summary" in where else "meta.json"
    (job / name).unlink()
    os.mkfifo(job / name)
    for cmd in (["collect", d], ["plot", d], ["analyze", job]):
        p = bk(*cmd, timeout=60)   # a hang fails here, by the timeout
        assert p.returncode in (0, EXIT_BAD_INPUT), p.stderr
        assert "Traceback" not in p.stderr
    if name == "meta.json":
        p = bk("sweep", "--phi", "1,3", "--seeds", "1", "--t-end", "200", "--scene", "clusters",
               "--protocol", "paper", "--jobs", "1", "--quiet", "--out", d, timeout=120)
        assert p.returncode == EXIT_BAD_INPUT
        assert "refused" in p.stderr and "retries them" not in p.stderr


def test_a_companion_beside_a_run_with_only_an_error_target(lammps, tmp_path):
    """A fixed-length protocol's run with an error target and a companion (the companion has
    no rule of its own): the run's own rule decides, no internal error; and until_steady=false
    under the steady protocol, which always runs until steady, is refused before anything."""
    p = bk("run", "--phi", "1", "--size", "12x3", "--protocol", "paper", "--companion",
           "partial", "--target-error", "1e-3", "--t-end", "300", "--scene", "friction",
           "--quiet", "--out", tmp_path / "r")
    assert p.returncode == 0, p.stderr
    for args in (["run", "--phi", "1", "--set", "until_steady=false", "--out", tmp_path / "a"],
                 ["sweep", "--phi", "1", "--vary", "until_steady=true,false", "--out",
                  tmp_path / "b"]):
        q = bk(*args)
        assert q.returncode == EXIT_BAD_INPUT
        one_line(q, "until_steady=false under the steady protocol")
        assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()
