"""The steady protocol end to end on a small lattice (a run from the random start beside its
companion from the partial start, until both are steady and agree), the paper's protocol
marked for what it is, and what every summary says of its state."""

from __future__ import annotations

import json
import subprocess

import pandas as pd
import pytest

from bkflow.analysis.summary import analyze
from bkflow.lammps.engine import run
from bkflow.model.params import (
    STEADY_COMPANION,
    STEADY_DRIFT_BOUND,
    STEADY_START,
    RunSpec,
)
from bkflow.model.protocols import protocol_fields
from bkflow.store.layout import BLOCKS, COMPANION, EXTREMA
from bkflow.store.rundir import RunDir
from tests.support import tool


def _steady(**kw) -> RunSpec:
    fields = protocol_fields("steady")
    # a 12x3 layer is small: the preset's mu_bar error (2e-4) would take it past the cap, and
    # what these tests are about is the stop on the steady state
    fields.update(t_end=20000.0, target_error=2e-3)
    return RunSpec(**{"phi": 10.0, "Lx": 12, "Ly": 3, "scene": "friction", **fields, **kw})


def test_the_steady_protocol_stops_steady_and_equals_fixed_runs(lammps, tmp_path):
    spec = _steady()
    assert (spec.start, spec.companion, spec.until_steady) == (STEADY_START, STEADY_COMPANION,
                                                               True)
    meta = run(spec, tmp_path / "a", progress=False).meta
    ad = meta["adaptive"]
    assert ad["reached"] and ad["t_run"] < spec.t_end and ad["until_steady"]
    assert ad["state_at_stop"] == "steady" and ad["drift_bound_at_stop"] <= STEADY_DRIFT_BOUND
    # the pair agrees within the error target, not within the switching's error
    assert abs(ad["companion_gap_at_stop"]) <= ad["agreement_required"] == pytest.approx(
        spec.target_error / ad["mu_bar_at_stop"])
    assert ad["estimate"] == "pair" and ad["mu_bar_err_at_stop"] <= spec.target_error
    assert meta["params"]["t_end"] == ad["t_run"] and meta["companion"]["start"] == "partial"
    comp = RunDir(tmp_path / "a").companion()
    assert comp.meta()["params"]["start"] == STEADY_COMPANION
    assert comp.meta()["params"]["t_end"] == ad["t_run"]
    s = analyze(tmp_path / "a")
    assert s["state"] == "steady" and s["state_evidence"] == "pair"
    assert s["companion_gap"] == pytest.approx(ad["companion_gap_at_stop"], rel=1e-9)
    assert s["drift"] == pytest.approx(ad["drift_at_stop"])
    # the printed error is the one the rule stopped on
    assert s["mu_bar"] == pytest.approx(ad["mu_bar_at_stop"], rel=1e-12)
    assert s["mu_bar_err"] == pytest.approx(ad["mu_bar_err_at_stop"], rel=1e-12)
    # each leg is the very trajectory of a fixed run of the length the pair chose, and the
    # pair's estimate the mean of the two
    legs = {}
    for start, where in ((STEADY_START, tmp_path / "a"), (STEADY_COMPANION, comp.path)):
        fixed = spec.replace(start=start, companion=None, until_steady=False, target_error=None,
                             t_end=ad["t_run"])
        out = tmp_path / f"fixed_{start}"
        run(fixed, out, progress=False)
        for name in (EXTREMA, BLOCKS):   # both legs keep their slips' turning points
            assert (out / name).read_bytes() == (where / name).read_bytes(), (start, name)
        legs[start] = analyze(out)
    f = legs[STEADY_START]
    assert f["mu_bar"] == s["mu_bar_run"]   # (the pair's drift is its mean stress's)
    assert f["state_evidence"] == "single run" and f["estimate"] == "run"
    assert legs[STEADY_COMPANION]["mu_bar"] == s["companion_mu_bar"]
    assert s["estimate"] == "pair" and s["mu_bar"] == pytest.approx(
        0.5 * (f["mu_bar"] + legs[STEADY_COMPANION]["mu_bar"]), rel=1e-12)
    assert s["mean_stress_ratio"] == pytest.approx(0.5 * (
        f["mean_stress_ratio"] + legs[STEADY_COMPANION]["mean_stress_ratio"]), rel=1e-12)
    assert s["mu_bar_bracket"] == pytest.approx(
        0.5 * abs(f["mu_bar"] - legs[STEADY_COMPANION]["mu_bar"]), rel=1e-9)
    assert s["mu_bar_err"] >= s["mu_bar_bracket"]


def test_a_steady_run_that_hits_its_cap_says_why(lammps, tmp_path):
    """The synchronized start of a stiff layer stays on its metastable plateau past a short
    cap: the run says so, in meta.json (as data) and in its report (bkflow.cli.report), and names
    every cause with the value the last check found (here also an unreachable mu_bar error)."""
    from bkflow.cli.stops import stop_line
    from bkflow.observables.states import memory_chi

    spec = _steady(phi=1000.0, start="synchronized", t_end=1500.0, target_error=1e-7)
    ad = run(spec, tmp_path, progress=False).meta["adaptive"]
    assert not ad["reached"] and ad["t_run"] == 1500.0
    line = stop_line(ad, spec.companion)
    assert "the cap came first" in line and "of at most 1500" in line
    assert f"mu_bar error {ad['mu_bar_err_at_stop']:.4f} > 1e-07" in line
    assert ad["state_at_stop"] == "metastable"
    assert "metastable: the contacts still hold the start's common phase" in line
    s = analyze(tmp_path)
    assert s["state"] == "metastable" and s["contacts_coherent"]
    assert s["phase_fluctuation"] > memory_chi(spec.N)


def test_a_switching_layer_runs_to_its_cap_and_says_what_it_would_need(lammps, tmp_path):
    """At phi = 1000, N = 100 the layer switches between a quiet and a coherent state on
    scales of 10^4-10^5 time units (benchmarks/measure/stiff_states.py, its records
    benchmarks/records/stiff_states/): no affordable run averages over that, and the mean of
    the states a short run visited is not the long-run mean (nor is a random start's approach
    a state). So the run does not stop on its own error: it goes on to its cap, names the
    states it visited, reports the pair's mean with the error that covers the switching, and
    the run length the calibration gives for the target, which the printed lines and the
    summary say alike."""
    from bkflow.cli.report import summary_lines
    from bkflow.cli.stops import adaptive_lines, stop_line
    from bkflow.observables.states import SWITCHING, needed_length

    spec = RunSpec(phi=1000.0, scene="friction", **{**protocol_fields("steady"),
                                                    "t_end": 12000.0})
    assert spec.N == 100
    meta = run(spec, tmp_path, progress=False, command="bkflow run --phi 1000 --out x").meta
    ad = meta["adaptive"]
    assert not ad["reached"] and ad["t_run"] == spec.t_end
    assert ad["state_at_stop"] in SWITCHING and ad["estimate"] == "pair"
    assert ad["mu_bar_err_at_stop"] > spec.target_error
    # the advised length is the calibration's, for the pair's mean: the same for every run
    # of the layer up to its mu_bar's few percent
    assert ad["t_needed"] == pytest.approx(needed_length(spec, ad["mu_bar_at_stop"], 2))
    assert ad["t_needed"] > 1e6 and ad["advice"]["t_end"] >= ad["t_needed"]
    line = stop_line(ad, spec.companion)
    assert f"mu_bar error {ad['mu_bar_err_at_stop']:.4f} > {spec.target_error:g}" in line
    more = adaptive_lines(ad, spec.companion, meta["command"], meta["atom_steps_per_s"])[1]
    assert f"a run needs about t = {ad['advice']['t_end']:g}" in more
    assert ("--t-end" in more and "continues this run to it" in more) or "beyond" in more
    s = analyze(tmp_path)
    assert s["state"] in SWITCHING
    assert s["mu_bar_err"] == pytest.approx(ad["mu_bar_err_at_stop"], rel=1e-12)
    assert s["t_needed"] == pytest.approx(ad["t_needed"], rel=1e-12)
    assert s["mu_bar_err"] > 5 * s["mu_bar_err_run"]   # the switching, not the run's own
    printed = "\n".join(summary_lines(s))
    assert f"+- {s['mu_bar_err']:.4f} ({s['state']})" in printed
    assert f"needs a run of about t = {s['t_needed']:.2g}" in printed
    assert "by state (this run): " in printed


def test_every_summary_carries_its_state_and_reads_large_drops(lammps, tmp_path):
    run(RunSpec(phi=1000.0, t_end=1500.0, scene="clusters"), tmp_path, progress=False)
    s = analyze(tmp_path)
    for key in ("state", "state_evidence", "phase_coherence", "phase_fluctuation",
                "phase_coherence_static", "phase_r2", "phase_u_std", "contacts_coherent",
                "stationary", "drift", "drift_err", "drift_z", "block_means", "t_equil",
                "mu_bar_large", "mu_bar_large_err", "n_slips_large", "large_drop_threshold",
                "lx_over_ly_large", "regime_large"):
        assert key in s, key
    # the paper's start on a stiff layer: its early plateau is the synchronized start's
    assert s["state"] == "metastable" and s["state_evidence"] == "single run"
    ev = pd.read_parquet(tmp_path / "events.parquet")
    late = ev[ev.late == 1]
    assert s["large_drop_threshold"] == pytest.approx(late["drop"].mean())
    assert s["n_slips_large"] == int((late["drop"] > late["drop"].mean()).sum()) == ev.large.sum()
    assert s["mu_bar_large"] == pytest.approx(
        late.sigma_fail[late.large == 1].mean() / RunSpec.sigma_n)
    assert s["mu_bar_large"] > s["mu_bar"]


@pytest.mark.slow
def test_the_default_protocol_from_the_cli_and_the_sweep(lammps, tmp_path):
    """The default protocol in the default scene (figures: the table's and the figures'
    observables, Psi's snapshots and the slips' frames, no energy ledger), then a sweep."""
    out = tmp_path / "r"
    proc = subprocess.run([tool("bkflow"), "run", "--phi", "10", "--size", "12x3",
                           "--target-error", "2e-3", "--out", str(out)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "and steady (drift bound" in proc.stdout and "\n  steady over t = " in proc.stdout
    assert "  energy: the balance" not in proc.stdout and "  Psi(inf) = " in proc.stdout
    assert all((out / n).is_file() for n in ("psi.npy", "slips.npy", "clusters.npy"))
    assert not any((out / n).exists() for n in ("snapshots.lammpstrj", "slips.lammpstrj",
                                                 "stress.npy"))
    assert "(steady)" in proc.stdout and f"companion run from the {STEADY_COMPANION}" \
        in proc.stdout
    meta = json.loads((out / "meta.json").read_text())
    assert meta["params"]["start"] == STEADY_START and meta["adaptive"]["reached"]
    assert (out / COMPANION / "meta.json").is_file()
    sw = tmp_path / "s"
    proc = subprocess.run([tool("bkflow"), "sweep", "--phi", "1,10", "--seeds", "1",
                           "--sizes", "12x3", "--aspect", "any", "--scene", "friction",
                           "--target-error", "2e-3", "--jobs", "2", "--out", str(sw)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "2 of 2 runs are steady" in proc.stdout
    runs = pd.read_csv(sw / "runs.csv")
    assert set(runs.start) == {STEADY_START} and runs.until_steady.all()
    assert (runs.state == "steady").all() and (runs.state_evidence == "pair").all()
    assert set(runs.companion) == {STEADY_COMPANION}


def test_the_papers_protocol_is_a_fixed_run_from_the_synchronized_start(lammps, tmp_path):
    out = tmp_path / "p"
    proc = subprocess.run([tool("bkflow"), "run", "--phi", "1000", "--size", "12x3",
                           "--protocol", "paper", "--t-end", "1500", "--scene", "friction",
                           "--out", str(out)], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    meta = json.loads((out / "meta.json").read_text())
    p = meta["params"]
    assert (p["start"], p["until_steady"], p["companion"], p["t_end"]) == \
        ("synchronized", False, None, 1500.0)
    assert "METASTABLE" in proc.stdout and "(metastable)" in proc.stdout
    assert not (out / COMPANION).exists()
