"""Accuracy controls: presets, the adaptive run length, and extreme inputs."""

from __future__ import annotations

import json
import math
import subprocess

import numpy as np
import pandas as pd
import pytest

from bkflow.analysis.summary import analyze
from bkflow.lammps.engine import run
from bkflow.model.checks import SpecError
from bkflow.model.params import ADAPTIVE_T_MIN, RunSpec
from bkflow.model.protocols import protocol_fields
from bkflow.model.timestep import ACCURACY, DT_FACTOR_MAX
from bkflow.sweeps.local import sweep
from bkflow.sweeps.project import open_project
from tests.support import tool


def test_adaptive_run_stops_once_the_error_is_below_target_and_equals_a_fixed_run(lammps, tmp_path):
    spec = RunSpec(phi=10.0, t_end=20000.0, target_error=5e-4, scene="friction")
    meta = run(spec, tmp_path / "a", progress=False).meta
    ad = meta["adaptive"]
    assert ad["reached"] and ADAPTIVE_T_MIN <= ad["t_run"] < spec.t_end
    assert meta["requested"]["t_end"] == 20000.0 and meta["params"]["t_end"] == ad["t_run"]
    s = analyze(tmp_path / "a")
    assert s["mu_bar_err"] <= 5e-4 and s["mu_bar_err"] == pytest.approx(ad["mu_bar_err_at_stop"])
    # the same trajectory as a fixed run of the length it chose: same series, same summary
    fixed = spec.replace(t_end=ad["t_run"], target_error=None)
    run(fixed, tmp_path / "f", progress=False)
    for name in ("extrema.npy", "blocks.npy"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "f" / name).read_bytes()
    assert analyze(tmp_path / "f")["mu_bar"] == s["mu_bar"]


def test_adaptive_sweep_is_not_redone(lammps, tmp_path):
    spec = RunSpec(phi=10.0, t_end=20000.0, target_error=1e-3, scene="friction")
    rep = sweep([spec], tmp_path, jobs=1, progress=False)
    assert len(rep.finished) == 1
    rep = sweep([spec], tmp_path, jobs=1, progress=False)
    assert rep.finished_before == 1 and not rep.finished
    (job,) = list(open_project(tmp_path, create=False))

    row = pd.read_csv(tmp_path / "runs.csv").iloc[0]
    assert row.t_end == 20000.0 and ADAPTIVE_T_MIN <= row.t_run < 20000.0


@pytest.mark.parametrize("preset", sorted(ACCURACY))
def test_accuracy_presets_set_the_time_step_and_length(preset, tmp_path):
    """A deck runs the preset's fixed length (a deck cannot stop by itself); a run of the
    steady protocol is capped at the preset's t_cap."""
    p_ = ACCURACY[preset]
    proc = subprocess.run([tool("bkflow"), "deck", "--phi", "10", "--accuracy", preset, "--out",
                           str(tmp_path)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    p = json.loads((tmp_path / "params.json").read_text())
    assert (p["accuracy"], p["dt_factor"], p["t_end"], p["until_steady"]) == \
        (preset, None, p_.t_end, False)
    spec = RunSpec.from_dict(p)
    assert f"timestep        {spec.dt!r}" in (tmp_path / "in.bk").read_text()
    steady = protocol_fields("steady", preset)
    assert (steady["accuracy"], steady["dt_factor"], steady["t_end"],
            steady["until_steady"]) == (preset, None, p_.t_cap, True)
    assert steady["target_error"] == p_.target_error


def test_explicit_options_override_the_preset(tmp_path):
    proc = subprocess.run([tool("bkflow"), "deck", "--phi", "10", "--accuracy", "fast",
                           "--dt-factor", "0.07", "--out", str(tmp_path)],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    p = json.loads((tmp_path / "params.json").read_text())
    assert (p["dt_factor"], p["t_end"]) == (0.07, ACCURACY["fast"].t_end)
    assert RunSpec.from_dict(p).dt == 0.07 / RunSpec(phi=10.0).omega_max


def test_a_deck_cannot_be_adaptive(tmp_path):
    proc = subprocess.run([tool("bkflow"), "deck", "--phi", "10", "--target-error", "1e-3",
                           "--out", str(tmp_path / "d")], capture_output=True, text=True)
    assert proc.returncode == 2 and "needs the engine" in proc.stderr
    assert not (tmp_path / "d").exists()


def test_a_deck_has_no_companion(tmp_path):
    """A companion is a second run: bkflow deck refuses it (it had dropped it silently)."""
    proc = subprocess.run([tool("bkflow"), "deck", "--phi", "10", "--companion", "partial",
                           "--out", str(tmp_path / "d")], capture_output=True, text=True)
    assert proc.returncode == 2 and "--start partial" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and not (tmp_path / "d").exists()
    ok = subprocess.run([tool("bkflow"), "deck", "--phi", "10", "--companion", "none",
                         "--out", str(tmp_path / "e")], capture_output=True, text=True)
    assert ok.returncode == 0, ok.stderr


@pytest.mark.parametrize("args, needle", [
    (["--target-error", "-1"], "target_error must be > 0"),
    (["--accuracy", "sloppy"], "invalid choice"),
    (["--dt-factor", str(DT_FACTOR_MAX * 1.01)], "stability bound"),
])
def test_bad_accuracy_options_exit_2(args, needle, tmp_path):
    proc = subprocess.run([tool("bkflow"), "run", "--phi", "10", *args, "--out",
                           str(tmp_path / "o")], capture_output=True, text=True)
    assert proc.returncode == 2 and needle in proc.stderr, proc.stderr


# --------------------------------------------------------------------------- extreme inputs
@pytest.mark.parametrize("changes", [
    {"phi": 1e4, "t_end": 60.0},                 # the stiffest layer of the stability scan
    {"V_d": 0.2, "t_end": 100.0},                # plate ten times faster
    {"dk_d": 1.0, "k_d": 1.0, "t_end": 100.0},   # k_d^i down to 0 (the default)
    {"phi": 0.1, "dk_d": 0.01, "t_end": 100.0},  # nearly homogeneous drive, very soft bonds
])
def test_extreme_but_valid_inputs_run_and_stay_finite(lammps, changes, tmp_path):
    meta = run(RunSpec(**{"phi": 10.0, "scene": "friction", **changes}), tmp_path,
               progress=False).meta
    assert meta["status"] == "complete"
    s = analyze(tmp_path)
    for key in ("mean_stress_ratio", "mu_bar"):
        assert isinstance(s[key], float) and math.isfinite(s[key]), (key, s[key])
    for key in ("mu_bar_err", "drift"):  # None when too few slips to tell; never NaN
        assert s[key] is None or math.isfinite(s[key]), (key, s[key])
    blocks = np.load(tmp_path / "blocks.npy")
    assert blocks["n"].sum() > 10 and np.isfinite(blocks["sigma"]).all()


@pytest.mark.parametrize("changes, needle", [
    ({"dk_d": 0.0}, "dk_d = 0 leaves phi"),
    ({"Lx": 4, "Ly": 1}, "Ly must be an integer >= 3"),
    ({"Lx": 2, "Ly": 2}, "Lx must be an integer >= 3"),
    ({"dk_d": 1.5}, "dk_d must lie in (0, k_d]"),
    # each parameter's physical domain, not just finiteness (docs/model.md)
    ({"V_d": -0.02}, "V_d must be > 0 (the plate moves along +x"),
    ({"V_d": 0.0}, "V_d must be > 0"),
    ({"V_d": 1.0}, "moves the plate 0.0289 lattice units per time step"),
    ({"gamma": -0.2}, "gamma must be >= 0"),
    ({"mass": 0.0}, "mass must be > 0"),
    ({"k_e": 0.0}, "k_e must be > 0"),
    ({"mu_s": -0.2}, "mu_s must be > 0"),
    ({"sigma_n": 0.0}, "sigma_n must be > 0"),
    ({"area": -1.0}, "area must be > 0"),
    ({"bond_limit": 0.5}, "bond_limit must be > 1 (lattice units"),
    ({"slip_threshold": 1.5}, "slip_threshold must be < 1"),
    ({"transient": 1.0}, "transient must lie in [0, 1)"),
    ({"phase_every": 0.0}, "phase_every must be > 0"),
    ({"seed": -1}, "seed must be a non-negative integer"),
])
def test_degenerate_inputs_are_refused_with_the_reason(changes, needle):
    with pytest.raises(SpecError) as exc:
        RunSpec(phi=10.0, **changes)
    assert needle in str(exc.value)


def test_a_time_step_past_the_stability_bound_blows_up_with_a_clear_message(lammps, tmp_path,
                                                                             monkeypatch):
    """What the guard prevents: lifted, C = 2.5 at phi = 1000 blows up within 200 steps and
    the engine says so (not LAMMPS's "bond partner missing")."""
    from bkflow.lammps.engine import RunError
    from bkflow.model import timestep

    monkeypatch.setattr(timestep, "DT_FACTOR_MAX", 10.0)
    spec = RunSpec(phi=1000.0, dt_factor=2.5, t_end=20.0, scene="friction")
    with pytest.raises(RunError, match="blew up.*smaller --dt-factor"):
        run(spec, tmp_path, progress=False)
    assert not (tmp_path / "meta.json").exists()
