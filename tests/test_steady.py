"""Runs until stationary, the random start from the command line and the sweep, and what
every summary says about stationarity and large drops."""

from __future__ import annotations

import json
import subprocess

import pandas as pd
import pytest

from bkflow.analysis import analyze
from bkflow.engine import run
from bkflow.params import STATIONARY_DRIFT_BOUND, RunSpec
from bkflow.rundir import STRESS, RunDir
from tests.support import tool

pytestmark = pytest.mark.lammps


def test_a_run_until_stationary_stops_stationary_and_equals_a_fixed_run(tmp_path):
    spec = RunSpec(phi=10.0, t_end=20000.0, until_stationary=True, scene="friction",
                   start="random")
    meta = run(spec, tmp_path / "a", progress=False).meta
    ad = meta["adaptive"]
    assert ad["reached"] and ad["t_run"] < spec.t_end and ad["until_stationary"]
    assert ad["drift_bound_at_stop"] <= STATIONARY_DRIFT_BOUND
    assert "stationary" in ad["stopped_because"] and meta["params"]["t_end"] == ad["t_run"]
    s = analyze(tmp_path / "a")
    assert s["stationary"] and s["drift"] == pytest.approx(ad["drift_at_stop"])
    # the same trajectory as a fixed run of the length it chose
    fixed = spec.replace(t_end=ad["t_run"], until_stationary=False)
    run(fixed, tmp_path / "f", progress=False)
    assert RunDir(tmp_path / "a").file(STRESS).read_bytes() == \
        RunDir(tmp_path / "f").file(STRESS).read_bytes()
    f = analyze(tmp_path / "f")
    assert (f["mu_bar"], f["stationary"], f["drift"]) == (s["mu_bar"], True, s["drift"])


def test_a_run_until_stationary_that_hits_its_cap_says_why(tmp_path):
    spec = RunSpec(phi=10.0, t_end=600.0, until_stationary=True, target_error=1e-7,
                   scene="friction")
    ad = run(spec, tmp_path, progress=False).meta["adaptive"]
    assert not ad["reached"] and ad["t_run"] == 600.0
    assert "cap t_end = 600 came first" in ad["stopped_because"]
    # it names what fell short, with the value the last check found
    assert f"mu_bar error {ad['mu_bar_err_at_stop']:.2g} > 1e-07" in ad["stopped_because"]


def test_every_summary_says_whether_it_is_stationary_and_reads_large_drops(tmp_path):
    run(RunSpec(phi=1000.0, t_end=1500.0, scene="clusters"), tmp_path, progress=False)
    s = analyze(tmp_path)
    for key in ("stationary", "drift", "drift_err", "drift_z", "block_means", "t_equil",
                "mu_bar_large", "mu_bar_large_err", "n_slips_large", "large_drop_threshold",
                "lx_over_ly_large", "regime_large"):
        assert key in s, key
    assert isinstance(s["stationary"], bool) and len(s["block_means"]) == 10
    ev = pd.read_csv(tmp_path / "events.csv")
    late = ev[ev.late == 1]
    assert s["large_drop_threshold"] == pytest.approx(late["drop"].mean())
    assert s["n_slips_large"] == int((late["drop"] > late["drop"].mean()).sum()) == ev.large.sum()
    assert s["mu_bar_large"] == pytest.approx(
        late.sigma_fail[late.large == 1].mean() / RunSpec.sigma_n)
    # the large drops of a stiff layer are its big slips: their peaks are higher
    assert s["mu_bar_large"] > s["mu_bar"]


def test_random_start_and_until_stationary_from_the_cli_and_the_sweep(tmp_path):
    out = tmp_path / "r"
    proc = subprocess.run([tool("bkflow"), "run", "--phi", "10", "--start", "random",
                           "--until-stationary", "--t-end", "20000", "--scene", "friction",
                           "--out", str(out)], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "stopped because" in proc.stdout and "  stationary (no trend" in proc.stdout
    meta = json.loads((out / "meta.json").read_text())
    assert meta["params"]["start"] == "random" and meta["adaptive"]["reached"]
    sw = tmp_path / "s"
    proc = subprocess.run([tool("bkflow"), "sweep", "--phi", "1,10", "--seeds", "1",
                           "--start", "random", "--until-stationary", "--t-end", "20000",
                           "--scene", "friction", "--jobs", "2", "--out", str(sw)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "0 of 2 runs are NOT stationary" in proc.stdout
    runs = pd.read_csv(sw / "runs.csv")
    assert set(runs.start) == {"random"} and runs.until_stationary.all()
    assert runs.stationary.all() and (runs.t_run < 20000).all()
