"""A longer run continues a shorter one from its restart file (bkflow.lammps.engine.continuation):
never simulating again what it has, and the very run a longer request makes from the start,
bit for bit on the fused path; a continuation cut short is undone; a sweep with a longer
--t-end continues its shorter runs."""

from __future__ import annotations

import json
import subprocess

import pandas as pd
import pytest

from bkflow.lammps.continuation import continuation
from bkflow.lammps.engine import run
from bkflow.model.params import RunSpec
from bkflow.model.protocols import protocol_fields
from bkflow.store.layout import CONTINUING
from bkflow.store.rundir import RunDir
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
    # the companion keeps its slips' turning points too (the pair's estimate reads both)
    _same(tmp_path / "c" / "companion", tmp_path / "fresh" / "companion")


def test_a_stricter_target_continues_a_run_that_stopped_by_its_rule(tmp_path):
    """A run that stopped by its rule, asked again on its directory with a smaller
    --target-error, goes on from its restart file to where the stricter rule stops: the very
    run the stricter request makes from the start, nothing simulated twice; a larger cap alone
    is answered by the finished run, and a looser target refused with the reason."""
    from bkflow.lammps.engine import RunExistsError

    loose = _spec("steady", phi=10.0, t_end=50000.0, target_error=2e-3)
    first = run(loose, tmp_path / "c", progress=False).meta
    assert first["adaptive"]["reached"]
    done = first["derived"]["n_steps"]
    # a larger cap: the finished run is the run that request makes (it stops at the same check)
    again = run(loose.replace(t_end=90000.0), tmp_path / "c", progress=False)
    assert not again.ran and again.meta == RunDir(tmp_path / "c").meta()
    strict = loose.replace(target_error=1e-3)
    meta = run(strict, tmp_path / "c", progress=False).meta
    assert meta["continued"][0]["to_step"] == done < meta["derived"]["n_steps"]
    assert meta["adaptive"]["reached"] and meta["requested"]["target_error"] == 1e-3
    fresh = run(strict, tmp_path / "fresh", progress=False).meta
    assert fresh["derived"]["n_steps"] == meta["derived"]["n_steps"]
    _same(tmp_path / "c", tmp_path / "fresh")
    _same(tmp_path / "c" / "companion", tmp_path / "fresh" / "companion")
    with pytest.raises(RunExistsError, match="a stricter target than this request"):
        run(loose, tmp_path / "c", progress=False)


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


@pytest.mark.slow
def test_a_sweep_with_a_longer_t_end_continues_its_runs(tmp_path):
    """The same sweep asked again with a longer --t-end asks it of the same jobs: the run that
    stopped at its cap goes on in place (the very run a sweep with that cap makes from the
    start), the one that stopped by its rule is left as it was, nothing is simulated twice,
    the tables keep one row per run and the figures their paths; a shorter --t-end is
    refused before anything is written."""
    args = [tool("bkflow"), "sweep", "--phi", "1,1000", "--seeds", "1", "--sizes", "12x3",
            "--aspect", "any", "--scene", "friction", "--target-error", "2e-3", "--jobs", "1",
            "--quiet"]

    def sweep(out, t):
        proc = subprocess.run(args + ["--out", str(out), "--t-end", t], capture_output=True,
                              text=True, timeout=600)
        assert proc.returncode == 0, proc.stderr
        return proc

    def plot(out):
        proc = subprocess.run([tool("bkflow"), "plot", str(out)], capture_output=True,
                              text=True, timeout=600)
        assert proc.returncode == 0, proc.stderr
        return sorted(p.relative_to(out).as_posix() for p in (out / "figures").rglob("*.png"))

    s = tmp_path / "s"
    sweep(s, "3000")
    figures = plot(s)
    before = {p.parent.name: p.read_bytes() for p in s.glob("workspace/*/meta.json")}
    assert len(before) == 2
    sweep(s, "6000")
    after = {p.parent.name: p.read_bytes() for p in s.glob("workspace/*/meta.json")}
    assert set(after) == set(before)   # the same jobs: no new run
    metas = {k: json.loads(v) for k, v in after.items()}
    stopped = [k for k, m in metas.items() if "continued" not in m]
    continued = [k for k, m in metas.items() if "continued" in m]
    assert len(stopped) == len(continued) == 1
    assert after[stopped[0]] == before[stopped[0]]   # left as it was
    m = metas[continued[0]]
    assert [c["to_step"] for c in m["continued"]][0] == json.loads(
        before[continued[0]])["derived"]["n_steps"]
    runs = pd.read_csv(s / "runs.csv")
    assert len(runs) == 2 and (runs.t_end == 6000).all()
    assert plot(s) == figures
    # the continued sweep's runs are the runs a sweep with the longer cap makes at once
    fresh = tmp_path / "fresh"
    sweep(fresh, "6000")

    def by_phi(root):
        return {json.loads(p.read_text())["phi"]: p.parent
                for p in root.glob("workspace/*/signac_statepoint.json")}

    ours, theirs = by_phi(s), by_phi(fresh)
    assert set(ours) == set(theirs) == {1.0, 1000.0}
    for phi, d in ours.items():   # (the deck of the run left as it was names its cap)
        _same(d, theirs[phi], SERIES[:2])
        _same(d / "companion", theirs[phi] / "companion", SERIES[:2])
    proc = subprocess.run(args + ["--out", str(s), "--t-end", "3000"], capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 2 and "only go on" in proc.stderr and proc.stdout == ""


def test_what_a_finished_run_answers_goes_on_with_or_refuses(tmp_path):
    """The rules of bkflow.lammps.continuation on real runs: a fixed run is not continued by an
    adaptive request; a capped run is not continued by a stricter target at the same cap; a
    run that stopped by its rule answers a stricter target its records meet where it stopped;
    a record of another stop rule, or of another step, is neither answered nor continued; and
    each refusal says why."""
    from types import SimpleNamespace

    from bkflow.lammps.continuation import answers, other_request
    from bkflow.store.formats import write_json_atomic
    from bkflow.sweeps.lengths import _takes

    fixed = _spec(t_end=1000.0)
    run(fixed, tmp_path / "f", progress=False)
    f = RunDir(tmp_path / "f")
    adaptive = fixed.replace(t_end=2000.0, target_error=1e-3)
    assert continuation(f, adaptive) is None and not answers(f, adaptive)
    assert "a run of a fixed length" in other_request(f, adaptive)

    capped = _spec("steady", phi=10.0, t_end=1500.0, target_error=1e-6)
    run(capped, tmp_path / "c", progress=False)
    c = RunDir(tmp_path / "c")
    stricter = capped.replace(target_error=1e-7)
    assert continuation(c, stricter) is None and not answers(c, stricter)
    assert "it ran to its cap" in other_request(c, stricter)

    loose = _spec("steady", phi=10.0, t_end=50000.0, target_error=2e-3)
    meta = run(loose, tmp_path / "s", progress=False).meta
    s = RunDir(tmp_path / "s")
    ad = meta["adaptive"]
    assert ad["reached"] and meta["derived"]["n_steps"] < loose.n_steps
    met = loose.replace(target_error=0.5 * (ad["mu_bar_err_at_stop"] + 2e-3))
    assert answers(s, met) and continuation(s, met) is None
    unmet = loose.replace(target_error=0.5 * ad["mu_bar_err_at_stop"])
    assert not answers(s, unmet) and continuation(s, unmet) is not None
    job = SimpleNamespace(path=s.path)
    assert _takes(job, unmet) and _takes(job, met)
    assert not _takes(job, loose.replace(target_error=4e-3))   # looser: refused
    # a record of an earlier stop rule, or of another step: another run
    for key, value in (("adaptive", {**ad, "rule": 1}),
                       ("derived", {**meta["derived"], "dt": 1.01 * meta["derived"]["dt"]})):
        write_json_atomic(s.file("meta.json"), {**meta, key: value})
        assert not answers(s, loose.replace(t_end=90000.0))
        assert continuation(s, unmet) is None
    write_json_atomic(s.file("meta.json"), {**meta, "adaptive": {**ad, "rule": 1}})
    assert "an earlier bkflow" in other_request(s, unmet)
    assert _takes(job, unmet)   # a sweep redoes a run of an earlier stop rule
