"""The failure classes of faults.py's attacks: one test per class, each failing before its fix."""

from __future__ import annotations

import re
import shlex
import subprocess
from pathlib import Path

import pytest

from bkflow.cli.assignments import parse_aspect, parse_sizes, parse_where
from bkflow.figures.data import SweepData
from bkflow.model.checks import SpecError
from tests.support import tool


def bk(*args, cwd=None, timeout=300):
    return subprocess.run([tool("bkflow"), *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=timeout)


def one_line(proc, needle: str) -> str:
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], proc.stderr
    assert "Traceback" not in proc.stderr
    return lines[0]


@pytest.fixture(scope="module")
def three_phi(lammps, tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("sweep") / "s"
    p = bk("sweep", "--phi", "1,3,10", "--seeds", "1", "--t-end", "200", "--scene", "friction",
           "--protocol", "paper", "--jobs", "1", "--quiet", "--out", d)
    assert p.returncode == 0, p.stderr
    return d


# ---------------------------------------------------------------- class 18: --where repeated
def test_a_repeated_where_keeps_the_runs_of_any_of_its_values(three_phi, tmp_path):
    """``--where phi=1 --where phi=10`` plots both (it plotted phi = 10 only, silently)."""
    assert parse_where(["phi=1", "phi=10", "phi=1"]) == {"phi": [1.0, 10.0]}
    data = SweepData(three_phi, parse_where(["phi=1", "phi=10"]))
    assert sorted(data.runs.phi) == [1.0, 10.0]
    p = bk("plot", three_phi, "--out", tmp_path / "f", "--where", "phi=1", "--where", "phi=10")
    assert p.returncode == 0, p.stderr
    none = bk("plot", three_phi, "--out", tmp_path / "g", "--where", "phi=2",
              "--where", "phi=5")
    assert none.returncode == 2
    one_line(none, "no finished run has phi = 2.0 or 5.0")


# ---------------------------------------------------------- class 15: circular --aspect advice
@pytest.mark.parametrize("size", ["7x3", "10x3", "8x4"])
def test_the_aspect_advised_for_a_size_is_accepted_for_it(size, tmp_path):
    """The refusal of a size names an --aspect that, passed as printed, takes that size
    (it printed 2.33333 for 7x3 and then refused 2.33333 as "not 2.33333")."""
    with pytest.raises(SpecError) as err:
        parse_sizes(size)
    advised = re.search(r"pass --aspect (\S+) ", str(err.value)).group(1)
    assert parse_sizes(size, parse_aspect(advised)) == [tuple(map(int, size.split("x")))]
    p = bk("sweep", "--phi", "1", "--sizes", size, "--seeds", "1", "--t-end", "100",
           "--init", "--out", tmp_path / "a")
    line = one_line(p, "--aspect")
    cmd = shlex.split(line.split("pass ", 1)[1].split(" or ")[0])
    q = bk("sweep", "--phi", "1", "--sizes", size, "--seeds", "1", "--t-end", "100",
           *cmd, "--init", "--out", tmp_path / "b")
    assert q.returncode == 0, q.stderr
    assert parse_aspect("7/3") == pytest.approx(7 / 3)
    for bad in ("1/0", "a/b", "0/3"):
        with pytest.raises(SpecError):
            parse_aspect(bad)


# ------------------------------------------------------------ class 14: n_blocks unbounded
def test_the_number_of_blocks_is_bounded(three_phi):
    run = next((three_phi / "workspace").iterdir())
    for n in ("101", "1000000", "100000000"):
        p = bk("analyze", run, "--analysis", f"n_blocks={n}")
        assert p.returncode == 2
        one_line(p, "n_blocks must be an integer from 3 to 100")
    assert bk("analyze", run, "--analysis", "n_blocks=100").returncode == 0


# ------------------------------------------------------------ class 13: extreme finite inputs
def test_no_finite_input_makes_an_internal_error():
    """Every float parameter at the ends of the float range: a RunSpec is either refused with
    a SpecError or made with finite derived quantities (an infinite omega_max, dt = 0 or an
    infinite step count gave ZeroDivisionError and OverflowError: exit 70)."""
    import dataclasses
    import math
    import sys

    from bkflow.model.params import RunSpec

    derived = ("n_steps", "dt", "stress_nevery", "phase_nevery", "snapshot_nevery",
               "block_nevery", "friction_threshold", "slip_threshold_stress",
               "extrema_threshold_stress", "transient_step", "slips_start_step", "omega_max",
               "omega_contact")
    made = 0
    for field in dataclasses.fields(RunSpec):
        if not (isinstance(field.default, float) or field.type in ("float", "float | None")):
            continue
        for value in (5e-324, 1e-320, 1e-300, 1e300, 1e308, sys.float_info.max):
            try:
                spec = RunSpec(**{"phi": 10.0, field.name: value})
            except SpecError:
                continue
            made += 1
            for name in derived:
                x = getattr(spec, name)
                assert math.isfinite(x), (field.name, value, name, x)
    assert made > 10   # the grid is not all refused


@pytest.mark.parametrize("args, says", [
    (["--phi", "1e308"], "omega_max = sqrt(stiffness / mass) overflows to inf: choose smaller"),
    (["--phi", "10", "--set", "mass=1e-320"], "choose smaller stiffnesses (phi, k_e, k_d) or "
                                              "a larger mass"),
    (["--phi", "10", "--dt-factor", "1e-320"], "underflows to 1.39e-321: choose a larger "
                                               "--dt-factor"),
    (["--phi", "10", "--set", "mu_s=1e-200", "--set", "sigma_n=1e-200"],
     "mu_s sigma_n A underflows to 0: choose larger mu_s, sigma_n or area"),
    (["--phi", "1e20"], "snapshot_every = 20 (the default) is 2.67e+11 time steps of dt = "),
])
def test_extreme_inputs_are_refused_in_one_line_that_points_the_right_way(args, says, tmp_path):
    p = bk("run", *args, "--t-end", "100", "--out", tmp_path / "r")
    assert p.returncode == 2
    one_line(p, says)
    assert not (tmp_path / "r").exists()


# ------------------------------------------------------ class 8: phase_every and the verdict
def test_the_phase_sampling_is_bounded_and_does_not_change_the_verdict(lammps, tmp_path):
    """phase_every above a tenth of a block is refused (500 made the same trajectory
    "DRIFTING" with another mean); within the bound the state and the mean stress agree."""
    import json

    for name, value in (("phase_every", "500"), ("phase_every", "2.5"),
                        ("stress_every", "3")):
        p = bk("run", "--phi", "10", "--set", f"{name}={value}", "--t-end", "100",
               "--out", tmp_path / "no")
        assert p.returncode == 2
        one_line(p, f"choose {name} <= 2")
    # a run made before the bound is still read, with its companion: the bound is a request's
    from bkflow.model.params import RunSpec

    old = {**RunSpec(phi=10.0, start="random", companion="partial").to_dict(),
           "phase_every": 5.0}
    spec = RunSpec.from_dict(old)
    assert spec.phase_every == 5.0 and spec.companion_spec.phase_every == 5.0
    with pytest.raises(SpecError, match="choose phase_every <= 2"):
        spec.replace(phase_every=4.0)
    got = {}
    for every in ("0.5", "2"):
        out = tmp_path / every
        p = bk("run", "--phi", "10", "--set", f"phase_every={every}", "--t-end", "8000",
               "--quiet", "--out", out)
        assert p.returncode == 0, p.stderr
        got[every] = json.loads((out / "summary.json").read_text())
    a, b = got["0.5"], got["2"]
    assert a["state"] == b["state"]
    assert abs(a["mean_stress_ratio"] - b["mean_stress_ratio"]) < 0.1 * a["mean_stress_ratio_err"]
    assert a["mu_bar"] == b["mu_bar"]


# ------------------------------------------------------ class 1: --contact-rule coulomb
@pytest.mark.parametrize("path", ["general", "fused"])
def test_the_coulomb_rule_runs_on_both_paths(lammps, path, tmp_path):
    """Every coulomb run exited 1, "contacts moved past their whole range", even at
    dt omega_max = 0.02: the overshoot counter counted the rescaling's rounding."""
    import json

    p = bk("run", "--phi", "10", "--contact-rule", "coulomb", "--path", path,
           "--t-end", "2000", "--quiet", "--out", tmp_path / "c")
    assert p.returncode == 0, p.stderr
    meta = json.loads((tmp_path / "c" / "meta.json").read_text())
    assert meta["contact_overshoots"] == 0


# ------------------------------------------- class 4: a slip that forms no cluster, on 3x3
def test_a_slip_without_a_cluster_is_a_record_not_damage(lammps, tmp_path):
    """On 3x3 some slips' slipped particles form no cluster: the run writes their extents as
    NaN (n_clusters 0), which the analysis read as damage, "run the run again", for ever."""
    import numpy as np

    out = tmp_path / "small"
    p = bk("run", "--phi", "10", "--size", "3x3", "--t-end", "30000", "--scene", "figures",
           "--quiet", "--out", out)
    assert p.returncode == 0, p.stderr
    slips = np.load(out / "slips.npy")
    none = slips["n_clusters"] == 0
    assert none.any() and np.isnan(slips["cluster_lx"][none]).all()
    assert np.isfinite(slips["cluster_lx"][~none]).all()
    (out / "summary.json").unlink()
    assert bk("analyze", out).returncode == 0


def _slip_record(n_clusters, lx):
    import numpy as np

    from bkflow.observables.reduced import SLIP_FIELDS

    r = np.zeros(2, [(f, "<i8" if f in ("step_max", "step_min", "n_slipped", "n_clusters",
                                        "cluster_n", "cluster_nx", "cluster_ny") else "<f8")
                     for f in SLIP_FIELDS])
    r["step_min"] = 10
    r["n_slipped"] = 4
    r["n_clusters"] = n_clusters
    r["cluster_lx"] = lx
    return r


def test_nan_extents_are_allowed_only_where_no_cluster_formed():
    import numpy as np

    from bkflow.observables.reduced import SLIP_FIELDS, checked

    checked(_slip_record(0, np.nan), SLIP_FIELDS, "slips.npy")
    with pytest.raises(ValueError, match="cluster_lx holds NaN"):
        checked(_slip_record(1, np.nan), SLIP_FIELDS, "slips.npy")
    # a slip that moved no particle past S_x (a threshold small against it) has no slip mean
    # or largest slip: NaN there, as the plugin writes it, and only there
    r = _slip_record(0, np.nan)
    r["n_slipped"][0] = 0
    r["slip_mean"][0] = r["slip_max"][0] = np.nan
    checked(r, SLIP_FIELDS, "slips.npy")
    r["slip_mean"][1] = np.nan
    with pytest.raises(ValueError, match="slip_mean holds NaN"):
        checked(r, SLIP_FIELDS, "slips.npy")


# ------------------------------------------------ class 11: impossible values in records
@pytest.fixture(scope="module")
def figures_run(lammps, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("fig") / "r"
    p = bk("run", "--phi", "10", "--t-end", "3000", "--scene", "figures", "--quiet",
           "--out", out)
    assert p.returncode == 0, p.stderr
    return out


def _mutate_in_place(path, field, how) -> None:
    """Change one value of ``field`` in the record file ``path`` (or, ``how`` "float", its
    type in the header), its size unchanged: what a run's size check cannot see."""
    import numpy as np

    if how == "float":      # the header's type swapped: the step read as a float
        raw = path.read_bytes()
        old = f"('{field}', '<i8')".encode()
        assert old in raw[:4096]
        path.write_bytes(raw.replace(old, f"('{field}', '<f8')".encode(), 1))
        return
    r = np.load(path, mmap_mode="r+")
    r[field][len(r) // 2] = how(r[field][len(r) // 2])
    r.flush()
    del r


@pytest.mark.parametrize("name, field, how, says", [
    ("psi.npy", "psi", lambda v: 5.0, "psi lies outside [0, 1]"),
    ("blocks.npy", "R", lambda v: 1e6, "R lies outside [0, 1] per sample"),
    ("blocks.npy", "u_std", lambda v: -1.0, "u_std lies outside"),
    ("slips.npy", "n_slipped", lambda v: -3, "n_slipped is negative"),
    ("slips.npy", "cluster_lx", lambda v: 1e300, "cluster_lx exceeds 40"),
    ("slips.npy", "n_slipped", lambda v: 10 ** 6, "exceeds the lattice's 100 particles"),
    ("clusters.npy", "n_x", lambda v: 10 ** 4, "n_x exceeds"),
    ("slips.npy", "step_max", "float", "field step_max is <f8, not <i8"),
    ("extrema.npy", "step", "float", "field step is <f8, not <i8"),
])
def test_a_record_with_an_impossible_value_is_refused(figures_run, tmp_path, name, field, how,
                                                      says):
    """Psi = 5, R = 10^6, negative counts, l_x = 10^300, a step read as a float: each was
    analysed with exit 0. The reader checks every field's type and the model's bounds."""
    import json
    import shutil


    run = tmp_path / "r"
    shutil.copytree(figures_run, run)
    _mutate_in_place(run / name, field, how)
    (run / "summary.json").unlink()
    # as a run recorded before the files' digests (or a deck run standalone, which has no
    # record): the values themselves are checked, not only that the file is the run's
    meta = json.loads((run / "meta.json").read_text())
    del meta["file_sha256"]
    (run / "meta.json").write_text(json.dumps(meta))
    p = bk("analyze", run)
    assert p.returncode != 0
    line = one_line(p, says)
    assert name in line and "damaged" in line


# ------------------------- classes 2, 3, 5: whose records and restart files a run reads
def _digests(d: Path) -> dict:
    import hashlib

    return {str(p.relative_to(d)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(d.rglob("*")) if p.is_file() and not p.name.endswith(".lock")}


@pytest.fixture(scope="module")
def two_seeds(lammps, tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("seeds")
    for seed in (1, 2):
        p = bk("run", "--phi", "10", "--seed", seed, "--t-end", "1000", "--quiet",
               "--out", d / f"s{seed}")
        assert p.returncode == 0, p.stderr
    return d


@pytest.mark.parametrize("where", ["", "companion"])
def test_another_runs_restart_file_is_refused(two_seeds, tmp_path, where):
    """seed 1's restart file copied into seed 2's run (or the run's own into its companion):
    a longer --t-end carried on seed 1's trajectory as "seed 2", bit for bit, with exit 0."""
    import shutil

    shutil.copytree(two_seeds, tmp_path / "d")
    s1, s2 = tmp_path / "d" / "s1", tmp_path / "d" / "s2"
    src = s1 if where == "" else s2
    (restart,) = src.glob("restart.*.bk")
    shutil.copy(restart, s2 / where / restart.name)
    before = _digests(s2)
    p = bk("run", "--phi", "10", "--seed", "2", "--t-end", "2000", "--quiet", "--out", s2)
    assert p.returncode == 2
    one_line(p, f"{restart.name} is not the file the run wrote")
    assert _digests(s2) == before


@pytest.mark.parametrize("name", ["blocks.npy", "psi.npy"])
def test_another_runs_record_of_the_same_size_is_refused(two_seeds, tmp_path, name):
    """blocks.npy and psi.npy of another seed of the same length have the same size: the
    analysis mixed the two runs with exit 0."""
    import shutil

    shutil.copytree(two_seeds, tmp_path / "d")
    s1, s2 = tmp_path / "d" / "s1", tmp_path / "d" / "s2"
    assert (s1 / name).stat().st_size == (s2 / name).stat().st_size
    shutil.copy(s1 / name, s2 / name)
    p = bk("analyze", s2)
    assert p.returncode != 0
    one_line(p, f"{name} is not the file the run wrote")


def test_a_sweep_redoes_a_run_damaged_in_place(lammps, tmp_path):
    """A NaN written into a run's records in place (its size unchanged) counted as finished
    for the sweep and as damaged for the analysis: the sweep failed for ever, and a longer
    --t-end continued from it. Now the sweep sees it and redoes the run."""
    import numpy as np

    out = tmp_path / "s"
    args = ["sweep", "--phi", "10", "--seeds", "1", "--t-end", "1000", "--jobs", "1",
            "--quiet", "--out", out]
    assert bk(*args).returncode == 0
    (blocks,) = out.glob("workspace/*/blocks.npy")
    clean = blocks.read_bytes()
    r = np.load(blocks, mmap_mode="r+")
    r["sigma"][3] = np.nan
    r.flush()
    del r
    p = bk(*args)
    assert p.returncode == 0, p.stderr
    assert "1 run(s) done" in p.stdout or "1 run(s) done" in p.stderr
    assert blocks.read_bytes() == clean   # redone, to the bit


# ------------------------------ class 9: advice that would throw away a finished run
def test_an_interrupted_continuation_is_not_called_damage(lammps, tmp_path):
    """After a continuation killed mid-way, load_run(...).summary called the run damaged and
    advised --overwrite; the finished run is intact, and the advice now given restores it."""
    import json
    import signal
    import time

    from bkflow import load_run
    from bkflow.store.errors import DamagedRunError

    out = tmp_path / "r"
    assert bk("run", "--phi", "10", "--t-end", "1000", "--quiet", "--out", out).returncode == 0
    before = json.loads((out / "summary.json").read_text())["mu_bar"]
    size = (out / "blocks.npy").stat().st_size
    p = subprocess.Popen([tool("bkflow"), "run", "--phi", "10", "--t-end", "400000", "--quiet",
                          "--out", str(out)], stdout=subprocess.DEVNULL,
                         stderr=subprocess.DEVNULL)
    deadline = time.time() + 120
    while time.time() < deadline and not (
            (out / ".bkflow-continuing").exists() and (out / "blocks.npy").stat().st_size > size):
        time.sleep(0.05)
    p.send_signal(signal.SIGKILL)
    p.wait(timeout=60)
    assert (out / ".bkflow-continuing").exists()
    with pytest.raises(DamagedRunError) as err:
        _ = load_run(out).summary
    advice = str(err.value)
    assert "--overwrite" not in advice and "interrupted" in advice
    command = shlex.split(advice.split("is intact: ", 1)[1].split(", or the same")[0])
    assert command[:2] == ["bkflow", "analyze"]
    assert bk(*command[1:]).returncode == 0
    assert load_run(out).summary["mu_bar"] == before
    # killed later, after the decks were written for the longer run and before the commit:
    # the decks come back too (their digests are recorded)
    from bkflow.store.rundir import RunDir

    RunDir(out).begin_continuation()
    deck = (out / "in.bk").read_text()
    (out / "in.bk").write_text(deck.replace("\nrun ", "\nrun  ", 1) + "# longer\n")
    assert bk("analyze", out).returncode == 0
    assert (out / "in.bk").read_text() == deck
    assert load_run(out).summary["mu_bar"] == before


# ---------------------------------------------- class 6: the disk estimate, scene by scene
@pytest.mark.slow
def test_every_scenes_disk_estimate_is_within_2x_of_what_it_writes(lammps, tmp_path):
    """The estimate left out fronts.bin: a --scene fronts sweep estimated 240 kB and wrote
    13.4 MB, and was not refused up front on a small disk. Every scene at phi = 10, and the
    fronts at the stiff end, where slips are short."""
    import json

    from bkflow.lammps.limits import cost
    from bkflow.model.params import RunSpec
    from bkflow.model.scenes import SCENES

    for scene, phi in [(scene, 10.0) for scene in SCENES] + [("fronts", 1000.0)]:
        out = tmp_path / f"{scene}{phi:g}"
        p = bk("run", "--phi", phi, "--t-end", "2000", "--protocol", "paper", "--scene", scene,
               "--quiet", "--out", out)
        assert p.returncode == 0, p.stderr
        meta = json.loads((out / "meta.json").read_text())
        wrote = meta["bytes_written"]
        estimate = cost(RunSpec.from_dict(meta["params"])).disk_bytes
        assert wrote / 2 <= estimate <= 2 * wrote, (scene, estimate, wrote)


def test_a_fronts_run_too_large_for_the_disk_is_refused_up_front(monkeypatch, tmp_path):
    from bkflow.lammps import limits
    from bkflow.model.params import RunSpec

    spec = RunSpec(phi=10.0, t_end=4000.0, scene="fronts", start="random")
    monkeypatch.setattr(limits, "_free_disk", lambda path: 4e6)   # 4 MB free: 2 MB allowed
    with pytest.raises(limits.CostError, match="would write about"):
        limits.check(limits.cost(spec), tmp_path, "the run")


# ------------------------------------------ class 7: the contact area in every stress ratio
def test_every_stress_ratio_is_per_contact_load(lammps, tmp_path):
    """--set area=2 gave mu_bar = 0.2465, above mu_s = 0.2: the stress was divided by sigma_n,
    not by the contact's load sigma_n A. The same contacts (mu_s sigma_n A = 2) reached by
    A = 2, sigma_n = 5 and by A = 1, sigma_n = 10 are the same model: every key the registry
    gives in units of sigma_n is the same, and mu_bar lies below mu_s."""
    import json

    from bkflow.analysis.summary_keys import keys

    got = []
    for sets in (["area=2", "sigma_n=5"], ["sigma_n=10"]):
        out = tmp_path / sets[0]
        p = bk("run", "--phi", "10", *[a for s in sets for a in ("--set", s)], "--t-end",
               "2000", "--quiet", "--out", out)
        assert p.returncode == 0, p.stderr
        got.append(json.loads((out / "summary.json").read_text()))
    ratios = [k for k, key in keys().items() if key.unit == "sigma_n" and k in got[0]]
    assert len(ratios) > 10
    for k in ratios:
        assert got[0][k] == got[1][k], k
    assert got[0]["mu_bar"] < 0.2 and got[0]["mean_stress_ratio"] < 0.2


def test_a_stress_ratio_above_what_contacts_hold_fails_loudly(tmp_path):
    from bkflow.analysis.summary import _check_bounds
    from bkflow.model.params import RunSpec
    from bkflow.store.errors import AnalysisError
    from bkflow.store.rundir import RunDir

    spec = RunSpec(phi=10.0)
    _check_bounds(RunDir(tmp_path), spec, {"mu_bar": 0.2, "mean_stress_ratio": 0.11})
    with pytest.raises(AnalysisError, match=r"mu_bar = 0.2465 is above mu_s = 0.2"):
        _check_bounds(RunDir(tmp_path), spec, {"mu_bar": 0.2465})


# ------------------------------------------------------------------ a newcomer's first steps
@pytest.mark.parametrize("n, size", [(90, "18x5"), (144, "24x6")])
def test_a_size_not_the_papers_points_to_size(lammps, n, size, tmp_path):
    p = bk("run", "--phi", "10", "--n", n, "--out", tmp_path / "r")
    assert p.returncode == 2
    one_line(p, f"--size {size}")
    q = bk("run", "--phi", "10", "--size", size, "--t-end", "50", "--protocol", "paper",
           "--scene", "friction", "--quiet", "--out", tmp_path / "r")
    assert q.returncode == 0, q.stderr


def test_analyze_help_says_what_an_unset_setting_means():
    p = bk("analyze", "--help")
    assert "slip_threshold=None" not in p.stdout and "slip_threshold=the run's" in p.stdout


def test_a_run_command_keeps_the_settings_of_the_runs_last_analysis(lammps, tmp_path):
    """bkflow run again on a run re-analysed at another threshold went back to the default
    one silently: it keeps them, and says so and how to go back."""
    import json

    out = tmp_path / "r"
    assert bk("run", "--phi", "10", "--t-end", "1000", "--quiet", "--out", out).returncode == 0
    assert bk("analyze", out, "--analysis", "slip_threshold=0.03").returncode == 0
    p = bk("run", "--phi", "10", "--t-end", "2000", "--quiet", "--out", out)
    assert p.returncode == 0, p.stderr
    assert "analysed under the settings of its last analysis (slip_threshold=0.03)" in p.stdout
    assert json.loads((out / "summary.json").read_text())["settings"]["slip_threshold"] == 0.03
    assert bk("analyze", out).returncode == 0
    assert json.loads((out / "summary.json").read_text())["settings"]["slip_threshold"] == 0.01


def test_the_mpirun_refusal_gives_whole_commands():
    """It ended mid-command ("... run that with mpirun -np K lmp -in")."""
    from bkflow.lammps.limits import mpi_refusal

    why = mpi_refusal({"OMPI_COMM_WORLD_SIZE": "2"})
    assert "bkflow deck ... --out DIR, then cd DIR && mpirun -np K lmp -in in.bk" in why
    assert (Path(__file__).parents[2] / "docs" / "slurm.md").exists()


def test_a_run_can_be_looked_at_from_the_command_line(lammps, tmp_path):
    """bkflow plot RUN_DIR was refused ("no runs.csv"), and Run.figure() of a long run was a
    solid band of slip markers: it draws the block means of the stress and R, the quiet blocks
    marked, and the drops' distribution; never over a user's file; gone with --overwrite."""
    from io import BytesIO

    from PIL import Image

    from bkflow import load_run

    out = tmp_path / "r"
    assert bk("run", "--phi", "10", "--t-end", "3000", "--quiet", "--out", out).returncode == 0
    p = bk("plot", out)
    assert p.returncode == 0, p.stderr
    assert {f.name for f in out.glob("run.*")} == {"run.png", "run.pdf"}
    Image.open(BytesIO((out / "run.png").read_bytes())).load()
    fig = load_run(out).figure()
    labels = {ax.get_ylabel() for ax in fig.axes}
    assert {"R (block)", "fraction of drops above"} <= labels
    assert bk("plot", out, "--where", "phi=10").returncode == 2
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "run.png").write_bytes(b"my own figure")
    q = bk("plot", out, "--out", mine)
    assert q.returncode == 2 and (mine / "run.png").read_bytes() == b"my own figure"
    assert bk("run", "--phi", "10", "--t-end", "3000", "--quiet", "--overwrite",
              "--out", out).returncode == 0
    assert not list(out.glob("run.*"))


def test_a_sweep_beside_a_busy_run_runs_the_others(lammps, tmp_path):
    """A run another process holds: the sweep runs the rest and says that one is busy (exit
    3); the length check of a sweep asked again stopped the whole sweep at the busy run."""
    import sys

    d = tmp_path / "s"
    args = ["sweep", "--phi", "1,10", "--seeds", "1", "--t-end", "100", "--scene", "friction",
            "--jobs", "1", "--quiet", "--out", d]
    assert bk(*args, "--init").returncode == 0
    job = sorted((d / "workspace").iterdir())[0]
    holder = subprocess.Popen([sys.executable, "-c", (
        "import fcntl, os, time\n"
        f"fd = os.open({str(job / '.bkflow.lock')!r}, os.O_RDWR | os.O_CREAT)\n"
        "fcntl.flock(fd, fcntl.LOCK_EX)\nprint('held', flush=True)\ntime.sleep(60)")],
        stdout=subprocess.PIPE, text=True)
    try:
        holder.stdout.readline()
        p = bk(*args)
    finally:
        holder.kill()
    assert p.returncode == 3
    assert "1 run(s) done" in p.stdout and "written by another process" in p.stdout
