"""Nothing outside the directory a command was given is deleted, replaced or written: every
path bkflow reads from a file, or finds in a directory it did not make (figures.json's list,
the figures directory, a sweep's job folders, a run's files, its lock and its companion), is
followed only where it stays inside, resolved, through no symbolic link
(bkflow.store.files.within).

Each case plants links and absolute paths that lead to a directory ``outside``, runs the
command a user would, and checks that ``outside`` is as it was: the same files, bytes and
times, nothing added."""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
from pathlib import Path

import pytest

from tests.support import tool

pytestmark = pytest.mark.usefixtures("lammps")

TINY = ["--phi", "10", "--size", "12x3", "--t-end", "200", "--protocol", "paper",
        "--scene", "friction"]


def _snapshot(root: Path) -> dict:
    out = {}
    for p in sorted(root.rglob("*")):
        st = p.lstat()
        body = p.read_bytes() if p.is_file() and not p.is_symlink() else b""
        out[str(p.relative_to(root))] = (st.st_mode, st.st_size, st.st_mtime_ns,
                                         hashlib.sha256(body).hexdigest())
    return out


@pytest.fixture
def outside(tmp_path):
    o = tmp_path / "outside"
    (o / "dir").mkdir(parents=True)
    (o / "victim.txt").write_text("the user's own file\n")
    (o / "dir" / "kept.png").write_bytes(b"not bkflow's")
    return o


def _bkflow(*args, cwd=None):
    return subprocess.run([tool("bkflow"), *map(str, args)], capture_output=True, text=True,
                          timeout=600, cwd=cwd)


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    root = tmp_path_factory.mktemp("outside_sweep") / "s"
    proc = _bkflow("sweep", "--phi", "10", "--seeds", "1", "--sizes", "12x3", "--aspect", "any",
                   "--t-end", "200", "--protocol", "paper", "--scene", "friction", "--jobs",
                   "1", "--out", root)
    assert proc.returncode == 0, proc.stderr
    return root


def _copy(src: Path, dst: Path) -> Path:
    subprocess.run(["cp", "-a", str(src), str(dst)], check=True)
    return dst


def test_collect_never_deletes_what_figures_json_names_outside(sweep, outside, tmp_path):
    s = _copy(sweep, tmp_path / "s")
    figs = s / "figures"
    figs.mkdir()
    os.symlink(outside / "victim.txt", figs / "link.png")
    (figs / "figures.json").write_text(json.dumps({
        "tables_sha256": "0", "complete": True,
        "files": [str(outside / "victim.txt"), "../../outside/victim.txt", "link.png",
                  "../outside/dir/kept.png"]}))
    before = _snapshot(outside)
    for args in (("collect", s), ("sweep", "--phi", "10", "--seeds", "1", "--sizes", "12x3",
                                  "--aspect", "any", "--t-end", "200", "--protocol", "paper",
                                  "--scene", "friction", "--out", s)):
        proc = _bkflow(*args)
        assert proc.returncode == 0, proc.stderr
    assert _snapshot(outside) == before
    assert (figs / "link.png").is_symlink()   # not ours either: left as it is


def test_a_figures_directory_that_leads_out_is_refused(sweep, outside, tmp_path):
    s = _copy(sweep, tmp_path / "s")
    os.symlink(outside / "dir", s / "figures")
    before = _snapshot(outside)
    proc = _bkflow("plot", s)
    assert proc.returncode == 2 and "symbolic link" in proc.stderr, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
    assert _bkflow("collect", s).returncode == 0
    assert _snapshot(outside) == before


def test_a_job_folder_that_leads_out_is_refused(sweep, outside, tmp_path):
    s = _copy(sweep, tmp_path / "s")
    job = next((s / "workspace").iterdir())
    _copy(job, outside / job.name)
    job.rename(tmp_path / "moved")
    os.symlink(outside / job.name, job)
    before = _snapshot(outside)
    proc = _bkflow("collect", s)   # it would re-analyse into the job's folder
    assert proc.returncode == 2 and "symbolic link" in proc.stderr, proc.stderr
    _bkflow("plot", s)             # it only reads the runs, and writes into s/figures
    assert _snapshot(outside) == before


@pytest.mark.parametrize("planted", ["extrema.npy", "log.lammps", ".bkflow.lock",
                                     "companion"])
def test_a_runs_files_that_lead_out_are_never_written(planted, outside, tmp_path):
    """A finished run whose file (or lock, or companion) was replaced by a link out: a longer
    run does not continue through it, an analysis does not read it as the run's, and a
    dangling link is not brought to life."""
    run = tmp_path / "r"
    args = TINY if planted != "companion" else [a for a in TINY if a not in
                                                ("--protocol", "paper")] + ["--target-error",
                                                                            "1e-9"]
    proc = _bkflow("run", *args, "--out", run)
    assert proc.returncode == 0, proc.stderr
    target = outside / "dir" / ("gone" if planted == ".bkflow.lock" else "kept.png")
    if planted == "companion":
        _copy(run / "companion", outside / "companion")
        target = outside / "companion"
    p = run / planted
    if p.is_dir():
        subprocess.run(["rm", "-r", str(p)], check=True)
    else:
        p.unlink(missing_ok=True)
    os.symlink(target, p)
    before = _snapshot(outside)
    longer = [a if a != "200" else "400" for a in args]
    for cmd in (["run", *longer, "--out", run], ["analyze", run]):
        proc = _bkflow(*cmd)
        assert proc.returncode != 0, (cmd, proc.stdout)
    assert _snapshot(outside) == before
    assert not (outside / "dir" / "gone").exists()
