"""A longer run continues a shorter one from its restart file (bkflow.lammps.engine.continuation):
never simulating again what it has, and the very run a longer request makes from the start,
bit for bit on the fused path; a continuation cut short is undone; a sweep with a longer
--t-end continues its shorter runs."""

from __future__ import annotations

import json
import subprocess

import pytest

from bkflow.lammps.engine import continuation, run
from bkflow.model.params import RunSpec
from bkflow.model.protocols import protocol_fields
from bkflow.store.rundir import CONTINUING, RunDir
from tests.support import tool

pytestmark = pytest.mark.usefixtures("lammps")

SERIES = ("extrema.npy", "blocks.npy", "in.bk")


def _spec(protocol="paper", **kw):
    fields = {**protocol_fields(protocol), **kw}
    return RunSpec(**{"phi": 1000.0, "Lx": 12, "Ly": 3, "seed": 2, "scene": "friction",
                      **fields})


def _same(a, b, names=SERIES):
    for name in names:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name


def test_a_longer_fixed_run_continues_the_shorter_one(tmp_path):
    short = _spec(t_end=1000.0)
    run(short, tmp_path / "c", progress=False)
    first = RunDir(tmp_path / "c").meta()
    meta = run(short.replace(t_end=2500.0), tmp_path / "c", progress=False).meta
    assert [c["to_step"] for c in meta["continued"]] == [first["derived"]["n_steps"],
                                                         meta["derived"]["n_steps"]]
    run(short.replace(t_end=2500.0), tmp_path / "fresh", progress=False)
    _same(tmp_path / "c", tmp_path / "fresh")
    # one restart file, the last step's, named in the record
    assert [p.name for p in RunDir(tmp_path / "c").restart_files()] == [meta["restart"]]
    assert RunDir(tmp_path / "c").problem() is None


def test_a_capped_pair_continued_is_the_pair_with_the_larger_cap(tmp_path):
    capped = _spec("steady", t_end=1500.0, target_error=1e-6)
    first = run(capped, tmp_path / "c", progress=False).meta
    assert not first["adaptive"]["reached"]
    longer = capped.replace(t_end=3000.0)
    meta = run(longer, tmp_path / "c", progress=False).meta
    fresh = run(longer, tmp_path / "fresh", progress=False).meta
    assert meta["adaptive"]["t_run"] == fresh["adaptive"]["t_run"]
    _same(tmp_path / "c", tmp_path / "fresh")
    # the companion keeps its blocks only
    _same(tmp_path / "c" / "companion", tmp_path / "fresh" / "companion", ("blocks.npy", "in.bk"))
    assert not (tmp_path / "c" / "companion" / "extrema.npy").exists()


@pytest.mark.parametrize("scene", ["figures", "series"])
def test_a_continuation_cut_short_is_undone(tmp_path, scene):
    """Every record a continuation rewrites in place (its header, the record under way) comes
    back as it was: the default scene's and the raw series' too."""
    short = _spec(t_end=1000.0, scene=scene)
    run(short, tmp_path / "c", progress=False)
    rd = RunDir(tmp_path / "c")
    before = {p.name: p.read_bytes() for p in rd.path.iterdir() if p.is_file()}
    records = sorted(n for n in before if n.endswith(".npy"))
    assert len(records) >= 4, records
    # what an interrupted continuation leaves: its note, its records rewritten in place
    # (the header, the record under way) and added to, a restart file
    rd.begin_continuation()
    for name in records:
        with open(rd.file(name), "r+b") as f:
            f.seek(100)
            f.write(b"rewritten")
            f.seek(0, 2)
            f.write(b"more records")
    rd.file("restart.99999.bk").write_bytes(b"half")
    assert rd.problem() is not None
    assert continuation(rd, short.replace(t_end=2000.0)) is not None
    after = {p.name: p.read_bytes() for p in rd.path.iterdir() if p.is_file()}
    assert after == before and not rd.file(CONTINUING).exists()


def test_a_continuation_stopped_after_it_committed_is_kept(tmp_path):
    """Killed between its record and its clean-up, a continuation is the run: the next
    command finishes the clean-up and puts nothing of the shorter run back."""
    short = _spec(t_end=1000.0, scene="figures")
    run(short, tmp_path / "c", progress=False)
    rd = RunDir(tmp_path / "c")
    rd.begin_continuation()                       # the note and the shorter run's copies
    note = rd.file(CONTINUING).read_text()
    run(short.replace(t_end=2000.0), tmp_path / "c", progress=False)   # commits and cleans
    rd.begin_continuation()
    rd.file(CONTINUING).write_text(note)          # as if stopped before its clean-up
    longer = {p.name: p.read_bytes() for p in rd.path.iterdir()
              if p.is_file() and not p.name.startswith(".")}
    assert rd.undo_continuation()
    after = {p.name: p.read_bytes() for p in rd.path.iterdir()
             if p.is_file() and not p.name.startswith(".")}
    assert after == longer and rd.problem() is None
    assert not list(rd.path.glob(".*before-continuing*"))


def test_analyze_undoes_a_continuation_cut_short(tmp_path):
    from bkflow.analysis.summary import analyze

    short = _spec(t_end=1000.0, scene="figures")
    run(short, tmp_path / "c", progress=False)
    first = analyze(tmp_path / "c")
    rd = RunDir(tmp_path / "c")
    rd.begin_continuation()
    with open(rd.file("extrema.npy"), "ab") as f:
        f.write(b"more records")
    again = analyze(tmp_path / "c")
    assert again["mu_bar"] == first["mu_bar"] and rd.problem() is None


def test_nothing_is_continued_from_another_run(tmp_path):
    run(_spec(t_end=1000.0), tmp_path / "c", progress=False)
    rd = RunDir(tmp_path / "c")
    for other in (_spec(t_end=2000.0, seed=3), _spec(t_end=2000.0, k_e=11.0),
                  _spec(t_end=500.0), _spec(t_end=1000.0)):
        assert continuation(rd, other) is None


def test_a_sweep_with_a_longer_t_end_continues_its_runs(tmp_path):
    args = [tool("bkflow"), "sweep", "--phi", "1000", "--seeds", "1", "--sizes", "12x3",
            "--aspect", "any", "--protocol", "paper", "--scene", "friction", "--jobs", "1",
            "--out", str(tmp_path / "s")]
    for t in ("1000", "2000"):
        proc = subprocess.run(args + ["--t-end", t], capture_output=True, text=True,
                              timeout=600)
        assert proc.returncode == 0, proc.stderr
    metas = [json.loads(p.read_text()) for p in (tmp_path / "s").glob("workspace/*/meta.json")]
    longer = next(m for m in metas if m["params"]["t_end"] == 2000.0)
    assert len(longer["continued"]) == 2
