"""Sweeps: the CLI end to end, resume after SIGKILL, corrupt runs redone, bad arguments,
the tables' statistics, and the cluster project's submission script."""

from __future__ import annotations

import contextlib
import fcntl
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from bkflow.analysis.results import results_table
from bkflow.cli.assignments import parse_sizes
from bkflow.cli.commands import main
from bkflow.model.checks import SpecError
from bkflow.model.params import RunSpec
from bkflow.store.errors import RunBusyError
from bkflow.store.layout import LOCK as LOCK_FILE
from bkflow.store.rundir import RunDir
from bkflow.sweeps.grid import phi_values, sweep_specs
from bkflow.sweeps.job import run_one
from bkflow.sweeps.local import sweep
from bkflow.sweeps.project import finished, open_project
from tests.figures.reading import hidden_points
from tests.support import ROOT, fake_scheduler, tool


def is_complete(d):
    return RunDir(d).is_complete()


def run_problem(d):
    return RunDir(d).problem()


@contextlib.contextmanager
def _job_lock(d):
    """The run directory's lock held by someone else (a separate open file description, as
    another process would hold it)."""
    fd = os.open(Path(d) / LOCK_FILE, os.O_RDWR | os.O_CREAT)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        yield
    finally:
        os.close(fd)

TINY = ["--phi", "1,1000", "--seeds", "1", "--t-end", "300", "--jobs", "2"]


def bkflow(*args, **kw):
    return subprocess.run([tool("bkflow"), *map(str, args)], capture_output=True, text=True,
                          timeout=600, **kw)


def job_dirs(root) -> list[Path]:
    return sorted(p for p in (Path(root) / "workspace").iterdir() if p.is_dir())


def done_counts(stdout: str) -> tuple[int, int]:
    m = re.search(r"(\d+) run\(s\) done in .*?, (\d+) finished earlier", stdout)
    assert m, stdout
    return int(m.group(1)), int(m.group(2))


@pytest.fixture(scope="module")
def tiny_sweep(lammps, tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep") / "tiny"
    proc = bkflow("sweep", *TINY, "--out", out)
    assert proc.returncode == 0, proc.stderr
    return out, proc


# --------------------------------------------------------------------------- parameters
def test_phi_range_is_log_spaced_with_whole_decades_exact():
    v = phi_values("1e-1:1e3")
    assert len(v) == 13
    assert v[0] == 0.1 and v[3] == 1.0 and v[6] == 10.0 and v[-1] == 1000.0
    assert np.allclose(np.diff(np.log10(v)), 1 / 3, atol=1e-6)
    assert len(phi_values("1:100", points_per_decade=5)) == 11
    # the same phi reached from two ranges is the same job
    assert set(phi_values("1:10")) <= set(phi_values("1e-1:1e3"))
    assert phi_values("100,1,10") == [1.0, 10.0, 100.0]
    assert phi_values("1:5", 1) == [1.0, 5.0]  # the end of a range is always swept


@pytest.mark.parametrize("text,needle", [("1e3:1e-1", "must increase"), ("0:1", "> 0"),
                                         ("-1,2", "> 0"), ("a:b", "not a number"),
                                         ("1:2:3", "A:B")])
def test_bad_phi_is_refused(text, needle):
    with pytest.raises(SpecError, match=needle):
        phi_values(text)


def test_sizes_follow_the_papers_aspect_unless_told():
    assert parse_sizes("20x5,40x10") == [(20, 5), (40, 10)]
    assert parse_sizes("100,900") == [(20, 5), (60, 15)]
    with pytest.raises(SpecError, match="--aspect"):
        parse_sizes("7x3")
    assert parse_sizes("7x3", aspect=None) == [(7, 3)]
    assert parse_sizes("10x10", aspect=1.0) == [(10, 10)]


@pytest.mark.parametrize("args,needle", [
    (["--phi", "1e3:1e-1"], "must increase"),
    (["--phi", "0:1"], "phi must be > 0"),
    (["--phi", "1", "--sizes", "7x3"], "Ly = Lx/4"),
    (["--phi", "1", "--jobs", "0"], "--jobs must be >= 1"),
    (["--phi", "1", "--seeds", "0"], "--seeds must be >= 1"),
    (["--phi", "1", "--sizes", "8x2"], "Ly must be an integer >= 3"),
    (["--phi", "1", "--dt-factor", "5"], "stability bound"),
])
def test_bad_sweep_arguments_exit_2_before_running(args, needle, tmp_path, capsys):
    out = tmp_path / "s"
    assert main(["sweep", *args, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert needle in err and err.count("\n") == 1, err
    assert not out.exists()


def test_other_aspect_accepted_when_asked(tmp_path, capsys):
    out = tmp_path / "s"
    assert main(["sweep", "--phi", "1", "--sizes", "7x3", "--aspect", "any", "--seeds", "2",
                 "--init", "--out", str(out)]) == 0
    jobs = list(open_project(out, create=False))
    assert sorted((j.sp.Lx, j.sp.Ly, j.sp.seed) for j in jobs) == [(7, 3, 1), (7, 3, 2)]
    assert not any(finished(j) for j in jobs)


# --------------------------------------------------------------------------- end to end
@pytest.mark.slow
def test_tiny_sweep_runs_end_to_end_through_the_cli(tiny_sweep):
    out, proc = tiny_sweep
    assert done_counts(proc.stdout) == (2, 0)
    runs = pd.read_csv(out / "runs.csv")
    res = pd.read_csv(out / "results.csv")
    assert len(runs) == 2 and sorted(runs.phi) == [1.0, 1000.0]
    assert set(runs.seed) == {1} and (runs.t_end == 300).all()
    assert len(res) == 2 and (res.n_seeds == 1).all()
    assert np.isfinite(runs.mu_bar).all() and np.isfinite(runs.psi_inf).all()
    # the table printed is the table written
    for phi, mu in zip(res.phi, res.mu_bar):
        assert re.search(rf"\n\s+{phi:g}\s+20x5\s+1\s+(steady|(drifting|metastable|quiet|"
                         rf"coherent|quiet\+coherent) \d/1)"
                         rf"\s+{mu:.4f}", proc.stdout), proc.stdout
    for d in job_dirs(out):
        assert run_problem(d) is None
        assert (d / "summary.json").exists() and (d / "clusters.npy").exists()
        assert not (d / "clusters.csv").exists()   # the run's own rows, not a second copy


def test_rerunning_a_finished_sweep_recomputes_nothing(tiny_sweep):
    out, _ = tiny_sweep
    stamps = {d: (d / "meta.json").stat().st_mtime_ns for d in job_dirs(out)}
    proc = bkflow("sweep", *TINY, "--out", out)
    assert proc.returncode == 0, proc.stderr
    assert done_counts(proc.stdout) == (0, 2)
    assert stamps == {d: (d / "meta.json").stat().st_mtime_ns for d in job_dirs(out)}


@pytest.mark.slow
def test_plot_writes_every_figure(tiny_sweep, tmp_path):
    out, _ = tiny_sweep
    figs = tmp_path / "figs"
    proc = bkflow("plot", out, "--out", figs)
    assert proc.returncode == 0, proc.stderr
    names = {"fig1b_stress", "fig2a_friction", "fig2b_asymmetry", "fig3_order",
             "fig4a_clusters", "fig_drops", "fig_potency", "fig_contacts"}
    assert {p.name for p in figs.iterdir()} == {f"{n}.{e}" for n in names for e in ("png", "pdf")} \
        | {"figures.json"}  # and the record of what was drawn from which tables
    for p in figs.glob("*.png"):
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and p.stat().st_size > 10_000


def test_plot_of_a_directory_without_a_sweep_exits_2(tmp_path):
    proc = bkflow("plot", tmp_path)
    assert proc.returncode == 2 and "no runs.csv" in proc.stderr


def test_plot_skips_what_a_scene_did_not_record(lammps, tmp_path):
    specs = sweep_specs([10.0], [(20, 5)], 1, t_end=200.0, scene="friction")
    rep = sweep(specs, tmp_path / "s", jobs=1, progress=False)
    assert len(rep.finished) == 1
    from bkflow.figures.writer import plot

    written, skipped = plot(tmp_path / "s", formats=("png",))
    assert {p.stem for p in written} == {"fig1b_stress", "fig2a_friction", "fig_drops",
                                         "fig_contacts"}
    assert set(skipped) == {"fig2b_asymmetry", "fig3_order", "fig4a_clusters", "fig_potency"}
    assert all("friction" in why for why in skipped.values())
    # the sweep's event catalogue: the run's slips, its job id and parameters first
    import pyarrow.parquet as pq

    from bkflow.api import load_sweep

    # stored once: the runs' own catalogues, gathered when asked for
    assert not any((tmp_path / "s" / n).exists() for n in ("catalogue.csv",
                                                           "catalogue.parquet"))
    cat = load_sweep(tmp_path / "s").events
    events = pq.read_table(job_dirs(tmp_path / "s")[0] / "events.parquet").to_pandas()
    assert len(cat) == len(events) > 0 and list(cat.columns[:2]) == ["job", "Lx"]
    assert (cat.phi == 10.0).all() and (cat.scene == "friction").all()
    np.testing.assert_array_equal(cat["drop"].to_numpy(), events["drop"].to_numpy())


@pytest.mark.slow
def test_corrupt_or_half_written_runs_are_detected_and_redone(lammps, tiny_sweep, tmp_path):
    src, _ = tiny_sweep
    out = tmp_path / "copy"
    shutil.copytree(src, out)
    a, b = job_dirs(out)
    a_size = (a / "extrema.npy").stat().st_size
    a_started = (a / "meta.json").read_text()
    with open(a / "extrema.npy", "r+b") as f:  # a cut file under a complete meta.json
        f.truncate(a_size // 2)
    (b / "summary.json").write_text('{"mu_bar": 0.1')  # an analysis cut short
    b_meta = (b / "meta.json").stat().st_mtime_ns
    assert is_complete(a) and "extrema.npy has" in run_problem(a)
    proj = open_project(out, create=False)
    assert not any(finished(j) for j in proj)

    proc = bkflow("sweep", *TINY, "--out", out)
    assert proc.returncode == 0, proc.stderr
    assert done_counts(proc.stdout) == (2, 0)
    assert all(finished(j) for j in proj)
    assert (a / "extrema.npy").stat().st_size == a_size         # run again from scratch
    assert (a / "meta.json").read_text() != a_started
    assert (b / "meta.json").stat().st_mtime_ns == b_meta       # only analysed again


@pytest.mark.slow
def test_sweep_killed_mid_way_resumes_without_recomputing_finished_runs(lammps, tmp_path):
    out = tmp_path / "s"
    args = ["sweep", "--phi", "3,10,30", "--seeds", "2", "--t-end", "4000", "--jobs", "2",
            "--scene", "friction", "--out", str(out)]
    proc = subprocess.Popen([tool("bkflow"), *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 300
    try:
        while time.time() < deadline:
            ws = out / "workspace"
            if ws.is_dir() and any((d / "summary.json").exists() for d in ws.iterdir()):
                break
            assert proc.poll() is None, proc.communicate()
            time.sleep(0.02)
        os.kill(proc.pid, signal.SIGKILL)  # the sweep process only: its workers must follow
    finally:
        proc.wait()
    time.sleep(1.0)
    # no worker outlived the sweep: every run's lock is free
    for d in job_dirs(out):
        fd = os.open(d / LOCK_FILE, os.O_RDWR | os.O_CREAT)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        finally:
            os.close(fd)
    proj = open_project(out, create=False)
    done = {j.id: (Path(j.path) / "meta.json").read_text() for j in proj if finished(j)}
    assert 1 <= len(done) < 6
    for j in proj:  # an interrupted run never looks finished
        assert j.id in done or not finished(j)

    res = bkflow(*args)
    assert res.returncode == 0, res.stderr
    assert done_counts(res.stdout) == (6 - len(done), len(done))
    assert all(finished(j) for j in proj)
    for j in proj:  # finished runs untouched
        if j.id in done:
            assert (Path(j.path) / "meta.json").read_text() == done[j.id]


def test_a_run_locked_by_another_process_is_not_touched(lammps, tmp_path):
    spec = sweep_specs([10.0], [(20, 5)], 1, t_end=50.0)[0]
    with _job_lock(tmp_path):
        with pytest.raises(RunBusyError, match="another bkflow process"):
            run_one(spec, tmp_path)
    assert not (tmp_path / "meta.json").exists()
    s = run_one(spec, tmp_path)
    assert s["params"]["phi"] == 10.0 and s == run_one(spec, tmp_path)


# --------------------------------------------------------------------------- tables
def test_results_are_means_over_seeds_with_standard_errors():
    base = dict(sweep_specs([1.0], [(20, 5)], 1)[0].to_dict())
    rows = []
    for seed, mu, psi, reg in ((1, 0.10, 0.5, "DP"), (2, 0.12, 0.7, "DT"), (3, 0.14, 0.9, "DP")):
        rows.append({**base, "seed": seed, "mu_bar": mu, "mu_bar_err": 0.01 * seed,
                     "mean_stress_ratio": mu / 2, "psi_inf": psi, "lx_over_ly": math.nan,
                     "lx_mean_over_Lx": 1.0, "ly_mean_over_Ly": 1.0, "drop_exponent": 2.0,
                     "n_slips": 100 * seed, "regime": reg})
    other = {**rows[0], "phi": 10.0, "seed": 1}
    res = results_table(pd.DataFrame(rows + [other]))
    assert len(res) == 2
    r = res[res.phi == 1.0].iloc[0]
    assert r.n_seeds == 3 and r.N == 100
    assert r.mu_bar == pytest.approx(0.12) and r.mu_bar_sem == pytest.approx(0.02 / math.sqrt(3))
    assert r.psi_inf_sem == pytest.approx(0.2 / math.sqrt(3))
    assert r.mu_bar_err_within_run == pytest.approx(0.02)
    assert math.isnan(r.lx_over_ly) and r.regime == "DP"
    one = res[res.phi == 10.0].iloc[0]
    assert one.n_seeds == 1 and math.isnan(one.mu_bar_sem)


def test_the_tables_write_each_float_as_its_shortest_text_and_read_it_back_exactly(tmp_path):
    """runs.csv and results.csv give every float as the shortest text that reads back as the
    same double: phi = 0.1 as ``0.1`` (``%.17g`` wrote 0.10000000000000001), and reading the
    tables back gives the very floats that were written, bit for bit."""
    from bkflow.analysis.results import write_tables
    from bkflow.store.tables import read_tables

    awkward = (1 / 3, 2.15443469003188, 1e-300, 0.1 + 0.2, -0.0, math.inf, math.nan)
    finished = []
    for seed, phi in ((1, 0.1), (2, 0.1), (1, float(phi_values("1e-1:1e1")[1]))):
        statepoint = sweep_specs([phi], [(20, 5)], 1)[0].replace(seed=seed).to_dict()
        summary = {"mu_bar": 0.1 + seed * 1e-17 + awkward[seed], "psi_inf": awkward[seed + 2],
                   "drift": awkward[seed + 4], "regime": "C", "state": "steady"}
        finished.append((f"job{seed}-{phi}", statepoint, summary))
    runs, results = write_tables(tmp_path, finished, {})
    text = (tmp_path / "results.csv").read_text()
    assert "\n0.1," in text and "0.10000000000000001" not in text
    assert "0.10000000000000001" not in (tmp_path / "runs.csv").read_text()
    for written, read in zip((runs, results), read_tables(tmp_path)):
        assert list(read.columns) == list(written.columns)
        for col in written.columns:
            if pd.api.types.is_float_dtype(written[col]):
                a, b = written[col].to_numpy(), read[col].to_numpy(dtype=float)
                assert np.array_equal(a, b, equal_nan=True) and np.array_equal(
                    np.signbit(a), np.signbit(b)), col


# --------------------------------------------------------------------------- cluster


def slurm_directives(script: str) -> dict:
    """The #SBATCH options of a job script as sbatch reads them: directive lines before the
    first command (blank lines and comments may come between them), each option after
    ``#SBATCH``, up to a second ``#`` (the rest of the line is a comment); ``--opt=value``,
    ``--opt value`` and ``-t value`` alike. A repeated option is an error here."""
    options = {}
    for line in script.splitlines()[1:]:   # after the shebang
        text = line.strip()
        if not text:
            continue
        if not text.startswith("#"):
            break                          # the first command: sbatch stops reading
        if not text.startswith("#SBATCH"):
            continue                       # a comment
        words = text[len("#SBATCH"):].split("#", 1)[0].split()
        while words:
            word = words.pop(0)
            name, eq, value = word.partition("=")
            if not eq:
                value = words.pop(0) if words and not words[0].startswith("-") else ""
            assert name not in options, f"{name} given twice in {line!r}"
            options[name] = value
    return options


def test_slurm_directives_are_read_as_sbatch_reads_them():
    script = "\n".join(['#!/bin/bash', '#SBATCH --job-name="x"', '', '# a comment',
                         '#SBATCH -t 01:00:00', '#SBATCH --cpus-per-task=1#SBATCH --nodes=1',
                         'echo hi', '#SBATCH --mem=1G'])
    assert slurm_directives(script) == {"--job-name": '"x"', "-t": "01:00:00",
                                        "--cpus-per-task": "1"}


def test_the_script_sbatch_is_given_is_a_job_script(tmp_path):
    """What sbatch receives, saved by a fake sbatch: a script whose first line is its #!, then
    its #SBATCH directives as Slurm reads them (nothing of the template's own comments leaks
    in front: a Jinja comment holding its own closing delimiter once did)."""
    out = tmp_path / "grid"
    assert main(["sweep", "--phi", "1,10", "--seeds", "1", "--t-end", "100", "--init",
                 "--out", str(out)]) == 0
    saved = tmp_path / "saved"
    saved.mkdir()
    env = fake_scheduler(tmp_path, {
        "squeue": "exit 0",
        "sbatch": f'n=$(ls {saved} | wc -l); for a in "$@"; do [ -f "$a" ] && '
                  f'cp "$a" {saved}/$n.sh; done; [ -t 0 ] || cat > {saved}/stdin$n.sh; '
                  'echo "Submitted batch job 1$n"'})
    sub = subprocess.run([sys.executable, "-m", "bkflow.slurm", "submit", "--bundle", "2"],
                         cwd=out, env=env, capture_output=True, text=True, timeout=300)
    assert sub.returncode == 0, sub.stderr
    scripts = [p.read_text() for p in saved.iterdir() if p.stat().st_size]
    assert scripts, "sbatch was given no script"
    for text in scripts:
        assert text.startswith("#!/bin/bash\n"), text[:200]
        d = slurm_directives(text)
        assert d["--nodes"] == "1" and d["--cpus-per-task"] == "1" and "-t" in d


@pytest.mark.slow
def test_cluster_project_bundles_runs_into_slurm_jobs_and_runs_the_same_operation(lammps, tmp_path):
    out = tmp_path / "grid"
    assert main(["sweep", "--phi", "1,10", "--seeds", "2", "--t-end", "100", "--init",
                 "--out", str(out)]) == 0
    env = fake_scheduler(tmp_path, {"squeue": "exit 0"})  # an empty queue
    # the project ships in the package: python -m bkflow.slurm (workflows/project.py is a
    # thin example of the same)
    sub = subprocess.run([sys.executable, "-m", "bkflow.slurm", "submit", "--pretend",
                          "--bundle", "2", "--parallel"], cwd=out, env=env, capture_output=True,
                         text=True, timeout=300)
    assert sub.returncode == 0, sub.stderr
    scripts = sub.stdout.split("#!/bin/bash")[1:]
    assert len(scripts) == 2
    for s in scripts:
        d = slurm_directives("#!/bin/bash" + s)
        assert d["--ntasks"] == "2" and "-t" in d
        assert d["--nodes"] == "1"  # the bundle's runs share the script's node
        assert d["--cpus-per-task"] == "1"
        assert "export OMP_NUM_THREADS=1" in s  # our template, not only flow's
        assert len(re.findall(rf"{re.escape(sys.executable)} -m bkflow.slurm run -o simulate "
                              r"-j \w+ &", s)) == 2
    jobs = sorted(set(re.findall(r"-j (\w+)", sub.stdout)))
    assert len(jobs) == 4
    # what a cluster node runs: the same operation, for one job
    run = subprocess.run([sys.executable, str(ROOT / "workflows" / "project.py"), "run", "-o",
                          "simulate", "-j", jobs[0]], cwd=out, env=env, capture_output=True,
                         text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    proj = open_project(out, create=False)
    assert [j.id for j in proj if finished(j)] == [jobs[0]]
    col = bkflow("collect", out)
    assert col.returncode == 0 and "4 jobs, 1 finished, 0 failed, 3 not run" in col.stdout
    assert len(pd.read_csv(out / "runs.csv")) == 1


def test_a_failed_run_is_reported_and_the_others_finish(lammps, tmp_path):
    good = sweep_specs([10.0], [(20, 5)], 1, t_end=100.0)[0]
    torn = good.replace(phi=0.1, t_end=400.0, bond_limit=1.5)  # tears apart (test_cli)
    rep = sweep([torn, good], tmp_path / "s", jobs=1, progress=False)
    proj = open_project(tmp_path / "s", create=False)
    assert rep.finished == [proj.open_job(good.to_dict()).id]
    (job_id, msg), = rep.failed.items()
    assert "bond stretched" in msg and proj.open_job(id=job_id).document["error"] == msg
    assert len(pd.read_csv(tmp_path / "s" / "runs.csv")) == 1
    # the next sweep retries it (and fails the same way), the finished run is left alone
    rep2 = sweep([torn, good], tmp_path / "s", jobs=1, progress=False)
    assert rep2.finished_before == 1 and list(rep2.failed) == [job_id]


def test_a_runs_cost_counts_its_companion(tmp_path):
    """The steady protocol's companion runs beside the run, step for step: its atom-steps,
    memory and series are counted, and the refusal says so and what the time is at the
    estimate's rate (the request that was told 1.35 h for one of its two halves)"""
    from bkflow.lammps.limits import (
        ATOM_STEPS_PER_SECOND,
        MAX_ATOM_STEPS,
        CostError,
        check_cost,
        cost,
    )
    from bkflow.model.protocols import protocol_fields

    spec = RunSpec(phi=1000, Lx=240, Ly=60, seed=1, **{**protocol_fields("steady"),
                                                       "t_end": 240000.0, "scene": "friction"})
    alone = spec.replace(companion=None)
    assert cost(spec).atom_steps == 2 * cost(alone).atom_steps == 2 * 14400 * spec.n_steps
    assert cost(spec).memory_bytes > cost(alone).memory_bytes
    assert cost(spec).disk_bytes > cost(alone).disk_bytes
    assert cost(alone).atom_steps < MAX_ATOM_STEPS < cost(spec).atom_steps
    check_cost(alone, tmp_path)  # within the limit alone
    with pytest.raises(CostError) as e:
        check_cost(spec, tmp_path)
    hours = 2 * 14400 * spec.n_steps / ATOM_STEPS_PER_SECOND / 3600
    assert f"{spec.n_steps} steps and as many for its companion" in str(e.value)
    assert f"up to {hours:.2g} h of one core" in str(e.value)
    check_cost(spec, tmp_path, force=True)


def test_a_refusal_names_what_would_lift_it(tmp_path):
    """The advice follows the cause: the frames (snapshots, slip frames) are lifted by
    --scene friction, so is a long raw series (scene series), the records of a very long run
    only by a shorter one; a long time is said in whole hours"""
    from bkflow.lammps.limits import Cost, CostError, check, check_cost

    def said(spec):
        with pytest.raises(CostError) as e:
            check_cost(spec, tmp_path)
        return str(e.value)

    base = RunSpec(phi=10, Lx=60, Ly=15, seed=1)
    frames = said(base.replace(t_end=1e8, scene="full"))  # frames every 20: 230 GB to read
    assert "of memory" in frames and "choose --scene friction or shorten --t-end" in frames
    series = said(base.replace(t_end=1e8, scene="series"))  # 60 GB of raw series
    assert "would write about" in series and "sample the stress less often" in series
    assert "choose a scene without the raw series (--scene friction)" in series
    records = said(base.replace(t_end=1e9, scene="friction"))  # 16 GB of records to read
    assert "of memory" in records and "shorten --t-end (the analysis reads the run's " \
        "records at once)" in records
    with pytest.raises(CostError, match=r"up to 5,556 h of one core"):
        check(Cost(1e15, 0.0, 0.0), tmp_path, "this run")


def test_force_lets_a_sweeps_runs_above_the_cost_limits(lammps, tmp_path, monkeypatch):
    """--force of a sweep reaches its runs (each run checks its own cost again): without it a
    run above the limits fails with the limit named, with it the run is made; a later sweep
    without it takes the permission back"""
    import bkflow.lammps.limits

    spec = sweep_specs([10.0], [(20, 5)], 1, t_end=100.0)[0]
    monkeypatch.setattr(bkflow.lammps.limits, "MAX_ATOM_STEPS", spec.N * spec.n_steps / 2)
    out = tmp_path / "s"
    rep = sweep([spec], out, jobs=1, progress=False)
    (job_id, msg), = rep.failed.items()
    assert "atom-steps" in msg and "pass --force" in msg
    rep = sweep([spec], out, jobs=1, progress=False, force=True)
    assert rep.finished == [job_id] and not rep.failed
    job = open_project(out, create=False).open_job(id=job_id)
    assert job.document["force"] is True
    sweep([spec], out, jobs=1, progress=False)
    assert "force" not in job.document


def test_plot_refuses_an_unknown_format(tiny_sweep, tmp_path):
    out, _ = tiny_sweep
    proc = bkflow("plot", out, "--out", tmp_path, "--format", "png,jpgx")
    assert proc.returncode == 2 and "jpgx" in proc.stderr and not any(tmp_path.iterdir())


def test_a_sweeps_workers_run_many_runs_each(lammps, tmp_path):
    """Sweeps pay Python's imports (and the plugin check, and loading LAMMPS) once per worker,
    not once per run: 6 runs on 2 workers are run by at most 2 processes, each of which goes
    on after its first run (meta.json "process")."""
    specs = [RunSpec(phi=phi, t_end=60.0, scene="friction", seed=seed)
             for phi in (1.0, 10.0, 100.0) for seed in (1, 2)]
    rep = sweep(specs, tmp_path / "s", jobs=2, progress=False)
    assert len(rep.finished) == 6
    procs = [json.loads((d / "meta.json").read_text())["process"]
             for d in job_dirs(tmp_path / "s")]
    pids = {p["pid"] for p in procs}
    assert len(pids) <= 2 and os.getpid() not in pids
    assert max(p["runs_before"] for p in procs) >= 2
    for pid in pids:
        assert sorted(p["runs_before"] for p in procs if p["pid"] == pid) == list(
            range(sum(p["pid"] == pid for p in procs)))


@pytest.mark.slow
def test_any_parameter_is_set_or_swept_from_the_cli(lammps, tmp_path):
    """--vary adds an axis (any RunSpec field), --set fixes a parameter: 2 phi x 2 gamma = 4
    points, each a row of results.csv with its gamma; figures per gamma."""
    out = tmp_path / "vary"
    proc = bkflow("sweep", "--phi", "1,10", "--vary", "gamma=0.1,0.2", "--set", "V_d=0.03",
                  "--seeds", "1", "--t-end", "100", "--scene", "friction", "--out", out,
                  "--quiet")
    assert proc.returncode == 0, proc.stderr
    assert "x 2 gamma x 1 seed(s) = 4 runs" in proc.stdout and "gamma = 0.1, 0.2" in proc.stdout
    res = pd.read_csv(out / "results.csv")
    assert len(res) == 4
    assert sorted(zip(res.phi, res.gamma)) == [(1, 0.1), (1, 0.2), (10, 0.1), (10, 0.2)]
    assert (res.V_d == 0.03).all()
    # the table printed has the column too
    assert re.search(r"phi\s+size\s+gamma\s+seeds", proc.stdout), proc.stdout
    plot = bkflow("plot", out, "--format", "png")
    assert plot.returncode == 0, plot.stderr
    for g in ("0.1", "0.2"):
        assert (out / "figures" / f"gamma={g}" / "fig2a_friction.png").is_file()
    single = bkflow("run", "--phi", "3", "--set", "gamma=0.05", "--set", "k_e=12", "--t-end",
                    "20", "--scene", "friction", "--no-analyze", "--out", tmp_path / "one")
    assert single.returncode == 0, single.stderr
    params = json.loads((tmp_path / "one" / "meta.json").read_text())["params"]
    assert params["gamma"] == 0.05 and params["k_e"] == 12.0


@pytest.mark.parametrize("args, needle", [
    (("--set", "gamma=fast"), "gamma must be a float"),
    (("--set", "phi=3"), "use --phi"),
    (("--set", "nothing=3"), "not a parameter"),
    (("--set", "gamma=-1"), "gamma must be >= 0"),
    (("--vary", "gamma=0.1,0.1"), "given twice"),
    (("--vary", "gamma=0.1", "--set", "gamma=0.2"), "choose one"),
])
def test_bad_set_or_vary_is_one_line_and_exit_2(args, needle, tmp_path):
    proc = bkflow("sweep", "--phi", "1", *args, "--out", tmp_path / "s")
    assert proc.returncode == 2
    assert needle in proc.stderr and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert not (tmp_path / "s").exists()


def test_every_figure_shows_every_point_with_a_key_and_units(tiny_sweep):
    """Each figure, as drawn: no data point outside its axes or under a key or an inset; a
    key of the marker convention (fill = state) wherever points are drawn by state; every axis
    labelled, with units unless the quantity is a pure number."""
    import bkflow

    out, _ = tiny_sweep
    sweep = bkflow.load_sweep(out)
    pure = ("phi", "mu", "Psi", "/\\sigma_n", "l_x", "l_y", "probability", "R =", "1 -")
    for name in sweep.figures:
        fig = sweep.figure(name)
        assert hidden_points(fig) == [], name
        for ax in fig.axes:
            if not ax.get_visible() or not (ax.get_lines() or ax.collections):
                continue
            # a panel stacked on another with the same x axis shares that axis' label
            xs = [a.get_xlabel() for a in ax.get_shared_x_axes().get_siblings(ax)]
            ys = [a.get_ylabel() for a in ax.get_shared_y_axes().get_siblings(ax)]
            for label in (max(xs, key=len), max(ys, key=len)):
                assert label, f"{name}: an axis without a label"
                assert "(" in label or any(w in label for w in pure), f"{name}: {label!r}"
        texts = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
        if name in ("fig2a_friction", "fig2b_asymmetry", "fig3_order"):
            assert any(t.startswith(("steady", "drifting", "metastable")) for t in texts), name
        if name == "fig_drops":   # each phi's key entry names its point's state
            states = ("(steady", "(drifting", "(metastable", "(switching", "(coherent", "(quiet")
            assert any(w in t for t in texts for w in states), (name, texts)


def test_a_point_with_one_seed_has_the_runs_own_error_bar_in_every_panel(tiny_sweep):
    """One seed: no spread over seeds, so each panel of fig2a falls back to the run's own
    standard error (mu_bar_err, mu_bar_large_err, mean_stress_ratio_err), never no bar."""
    from matplotlib.container import ErrorbarContainer

    import bkflow

    out, _ = tiny_sweep
    sweep = bkflow.load_sweep(out)
    assert (sweep.results.n_seeds == 1).all()
    fig = sweep.figure("fig2a_friction")
    for ax in fig.axes:
        bars = [c for c in ax.containers if isinstance(c, ErrorbarContainer)]
        assert bars, ax.get_ylabel()
        segments = np.concatenate([seg.get_segments() for b in bars for seg in b.lines[2]])
        heights = np.abs(segments[:, 1, 1] - segments[:, 0, 1])
        assert len(heights) == 2 and (heights > 0).all(), ax.get_ylabel()


def test_the_drop_figure_draws_a_power_law_only_where_it_is_plausible(tiny_sweep, monkeypatch):
    """fig_drops with the analysis finding a power law plausible at phi = 1 and rejecting it
    at phi = 1000 (lognormal favoured): one fitted line (phi = 1's), the rejection written in
    phi = 1000's key, and the stiff layer's two populations beside it adding up to all its
    drops."""
    from bkflow.figures import drops as drop_figures
    from bkflow.figures.data import SweepData
    from bkflow.figures.style import Figures, style

    out, _ = tiny_sweep
    data = SweepData(out)
    one = np.isclose(data.runs.phi, 1.0)
    data.runs["drop_power_law"] = np.where(one, "plausible", "rejected")
    data.runs["drop_fit_p"] = np.where(one, 0.43, 0.0)
    data.runs["drop_exponent"] = np.where(one, 1.8, 1.6)
    data.runs["drop_exponent_err"] = 0.05
    data.runs["drop_vs_lognormal"] = np.where(one, 0.5, -10.0)
    data.runs["drop_vs_lognormal_p"] = np.where(one, 0.6, 1e-6)
    rng = np.random.default_rng(3)
    drops = {1.0: 0.01 * (1 - rng.random(2000)) ** (-1 / 0.8),
             1000.0: 0.01 + np.exp(rng.normal(-3.5, 0.8, 2000))}
    whole = {1.0: np.zeros(2000, bool), 1000.0: rng.random(2000) < 0.7}

    def fake(data, runs):
        phi = float(runs.phi.iloc[0])
        return drops[phi], whole[phi]

    monkeypatch.setattr(drop_figures, "_late_drops", fake)
    with style():
        fig = drop_figures.fig_drops(data, Figures())
    left, right = fig.axes
    fits = [ln for ln in left.get_lines() if ln.get_marker() in ("None", "", None)]
    assert len(fits) == 1
    # one key below both panels: each phi with its point's state
    keys = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    assert r"$\phi$ = 1 (steady): $\alpha$ = 1.80 $\pm$ 0.05 (p >= 0.43)" in keys, keys
    assert (r"$\phi$ = 1000 (switching): power law rejected (p < 0.001, lognormal favoured)"
            in keys), keys
    parts = [t.get_text() for t in right.get_legend().get_texts()]
    assert parts[0].startswith("system-wide") and parts[0].endswith("of 2000")
    shares = [float(re.search(r"(\d+)% of", t).group(1)) for t in parts]
    assert sum(shares) == pytest.approx(100, abs=1)
    assert hidden_points(fig) == []


def test_notebook_objects_leave_the_users_figures_backend_and_style_alone(tiny_sweep):
    """bkflow.load_sweep / load_run: tables as DataFrames, figures as Figures, and making one
    neither switches the backend, nor changes rcParams, nor touches open figures."""
    import matplotlib
    import matplotlib.pyplot as plt
    from matplotlib.figure import Figure

    import bkflow

    out, _ = tiny_sweep
    backend = matplotlib.get_backend()
    plt.close("all")   # figures another test left open are not the user's
    mine = plt.figure()
    rc = dict(matplotlib.rcParams)
    try:
        sweep = bkflow.load_sweep(out)
        assert len(sweep.runs) == 2 and len(sweep.results) == 2 and "Sweep(" in repr(sweep)
        fig = sweep.figure("fig2a")
        assert isinstance(fig, Figure) and len(fig.axes) == 3
        assert isinstance(sweep.figure("fig_drops"), Figure)
        run = sweep.run(0)
        assert list(run.stress.columns) == ["t", "sigma_x"] and len(run.stress) > 100
        assert len(run.blocks) > 5 and {"t", "sigma_x", "R"} <= set(run.blocks.columns)
        assert run.summary["mu_bar"] == pytest.approx(sweep.runs.mu_bar.iloc[0])
        assert run.events is not None and len(run.events) >= run.summary["n_slips"] > 0
        assert run.clusters is not None and run.psi is not None
        assert isinstance(run.figure(window=50), Figure)
        assert bkflow.load_run(run.path).spec == run.spec
        with pytest.raises(Exception, match="no figure"):
            sweep.figure("fig9")
        assert matplotlib.get_backend() == backend
        assert plt.get_fignums() == [mine.number]
        changed = {k for k, v in matplotlib.rcParams.items() if rc.get(k) != v}
        assert not changed, changed
    finally:
        plt.close(mine)


def test_the_readmes_sweep_example_runs_as_written(tiny_sweep, tmp_path):
    """README's ``bkflow.load_sweep`` block, run as written on a sweep (the tiny one in place
    of runs/sweep): the columns it names are results.csv's, the figure is drawn."""
    out, _ = tiny_sweep
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), re.S)
    block, = [b for b in blocks if "load_sweep" in b]
    assert '"runs/sweep"' in block
    code = block.replace('"runs/sweep"', repr(str(out))) + (
        "\nprint(type(sweep).__name__, len(sweep.results), len(sweep.runs))\n")
    p = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                       text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-2000:]
    assert p.stdout.split() == ["Sweep", "2", "2"]


def test_load_run_refuses_what_is_not_a_finished_run(tmp_path):
    import bkflow
    from bkflow.store.errors import AnalysisError

    with pytest.raises(AnalysisError, match="no finished run"):
        bkflow.load_run(tmp_path)


@pytest.mark.slow
def test_the_example_notebook_runs(lammps, tmp_path):
    """docs/example.ipynb, executed as a user would (a kernel of this environment, in an
    empty directory): no cell fails and the figure cells show images."""
    nbformat = pytest.importorskip("nbformat")
    from nbclient import NotebookClient

    nb = nbformat.read(ROOT / "docs" / "example.ipynb", as_version=4)
    NotebookClient(nb, timeout=600, kernel_name="python3",
                   resources={"metadata": {"path": str(tmp_path)}}).execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.output_type == "error"]
    images = [o for o in outputs if "image/png" in o.get("data", {})]
    assert len(images) >= 2
    assert (tmp_path / "nb_sweep" / "results.csv").exists()


def test_vary_takes_parameters_that_have_options_of_their_own(lammps, tmp_path):
    """--vary start=... and --vary t_end=... override what --start and the preset give."""
    out = tmp_path / "v"
    proc = bkflow("sweep", "--phi", "1", "--vary", "start=random,synchronized", "--vary",
                  "t_end=40,50", "--seeds", "1", "--scene", "friction", "--out", out, "--quiet")
    assert proc.returncode == 0, proc.stderr
    res = pd.read_csv(out / "results.csv")
    assert sorted(zip(res.start, res.t_end)) == [("random", 40), ("random", 50),
                                                 ("synchronized", 40), ("synchronized", 50)]


def test_the_cluster_command_outside_a_sweep_is_one_line_and_exit_2(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "bkflow.slurm", "status"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert "is not a sweep directory" in proc.stderr and len(proc.stderr.splitlines()) == 1


@pytest.mark.slow
def test_plot_of_runs_without_stress_drops_and_of_unset_or_slashed_values(lammps, tmp_path):
    """Runs too short for two stress drops: fig_drops is skipped, not a traceback; a varied
    parameter left unset in some runs (target_error=none) and a value with '/' (reset/step)
    each get their own figure directory."""
    out = tmp_path / "p"
    proc = bkflow("sweep", "--phi", "1", "--seeds", "1", "--t-end", "50", "--scene", "friction",
                  "--jobs", "1", "--vary", "contact_rule=reset,reset/step", "--vary",
                  "target_error=none,0.01", "--out", out, "--quiet")
    assert proc.returncode == 0, proc.stderr
    plot = bkflow("plot", out, "--format", "png")
    assert plot.returncode == 0, plot.stderr
    dirs = sorted(p.name for p in (out / "figures").iterdir() if p.is_dir())
    assert dirs == ["contact_rule=reset,target_error=0.01", "contact_rule=reset,target_error=nan",
                    "contact_rule=reset-step,target_error=0.01",
                    "contact_rule=reset-step,target_error=nan"]
    assert "fig_drops: no data" in plot.stdout
    col = bkflow("collect", out)
    assert col.returncode == 0 and re.search(r"contact_rule\s+target_error", col.stdout)


def test_the_cluster_command_says_in_one_line_when_the_scheduler_fails(tmp_path):
    out = tmp_path / "grid"
    assert main(["sweep", "--phi", "1", "--seeds", "1", "--t-end", "50", "--init",
                 "--out", str(out)]) == 0
    failing = "echo 'squeue: fatal: no config' >&2\nexit 1"
    env = fake_scheduler(tmp_path, {"squeue": failing, "sbatch": failing})
    proc = subprocess.run([sys.executable, "-m", "bkflow.slurm", "status"], cwd=out, env=env,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 1
    ours = [ln for ln in proc.stderr.splitlines() if ln.startswith("bkflow.slurm:")]
    assert len(ours) == 1 and "StandardEnvironment" in ours[0]
    assert "Traceback" not in proc.stderr
    help_ = subprocess.run([sys.executable, "-m", "bkflow.slurm", "--help"], cwd=tmp_path,
                           capture_output=True, text=True, timeout=120)
    assert help_.returncode == 0 and "python -m bkflow.slurm" in help_.stdout


def test_the_cluster_scatter_shows_every_cluster_and_rounds_its_key():
    """fig4a: clusters past 1.15 of the box (a soft layer's reach 1.2) are inside the axes;
    a sparse set is drawn over a dense one; the key says phi = 2.15, not 2.15443."""
    import matplotlib

    matplotlib.use("Agg")
    from bkflow.figures.clusters import cluster_scatter
    from bkflow.figures.style import new_figures

    clusters = {0.1: pd.DataFrame({"l_x": [4.0] * 500 + [2.0], "l_y": [6.1] * 500 + [1.0]}),
                2.15443: pd.DataFrame({"l_x": [20.0, 10.0], "l_y": [5.0, 2.0]})}

    class Stub:
        def runs_of(self, lx, ly, phi):
            return pd.DataFrame({"phi": [phi], "seed": [1]})

        def run_dir(self, row):
            return type("R", (), {"read_clusters": lambda _: clusters[row["phi"]]})()

    plt = new_figures()
    fig = cluster_scatter(Stub(), plt, 20, 5, [2.15443, 0.1], "t")
    ax = fig.axes[0]
    assert ax.get_ylim()[1] >= 6.1 / 5 and ax.get_xlim()[0] < 0 < ax.get_ylim()[1]
    labels = [t.get_text() for t in ax.get_legend().get_texts()][:2]  # then the guides' key
    assert labels == [r"$\phi$ = 2.15: 2 clusters", r"$\phi$ = 0.1: 501 clusters"]
    from bkflow.figures.style import value_label

    assert [value_label(v) for v in (1000.0, 215.443, 0.215443, 2.15443)] == [
        "1000", "215", "0.215", "2.15"]
    from bkflow.figures.style import phi_colour

    drawn = {tuple(ln.get_color()): ln.get_zorder() for ln in ax.get_lines()
             if len(ln.get_xdata()) and ln.get_label() == "_nolegend_"}
    assert drawn[tuple(phi_colour(2.15443))] > drawn[tuple(phi_colour(0.1))]  # sparse on top
    plt.close(fig)


def test_a_sweep_is_selected_by_numbers_from_python(tiny_sweep):
    """load_sweep(path, where={"Lx": 20}): a number from Python selects the runs whose column
    has that value (it compared the column's text with the number, and matched none)."""
    from bkflow import load_sweep

    out, _ = tiny_sweep
    every = load_sweep(out).runs
    lx = int(every.Lx.iloc[0])
    assert len(load_sweep(out, where={"Lx": lx}).runs) == len(every) > 0
    assert len(load_sweep(out, where={"Lx": float(lx)}).runs) == len(every)
    assert len(load_sweep(out, where={"phi": 1}).runs) == int((every.phi == 1).sum()) > 0
    from bkflow.figures.style import PlotError

    with pytest.raises(PlotError, match=f"no finished run has Lx = {lx + 1}"):
        load_sweep(out, where={"Lx": lx + 1})
