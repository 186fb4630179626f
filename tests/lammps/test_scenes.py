"""Scenes write only what their observables need, and the analysis reads them back."""

import json
import subprocess

import numpy as np
import pandas as pd
import pytest

from bkflow.analysis.summary import analyze
from bkflow.cli.commands import main
from bkflow.lammps.deckfiles import write_deck
from bkflow.lammps.engine import run
from bkflow.model.params import RunSpec
from bkflow.observables.stress import slip_events
from bkflow.store.formats import read_frames
from bkflow.store.rundir import RunDir
from tests.support import tool

REQUIRED = ("mu_bar", "mu_bar_err", "n_slips", "mean_stress_ratio", "mu_bar_by_threshold",
            "psi_inf", "lx_mean_over_Lx", "ly_mean_over_Ly", "lx_over_ly", "regime",
            "drop_exponent", "slip_threshold_stress", "drop_x_min")
#: the analysis settings, recorded (resolved for the run) in every summary
REQUIRED_SETTINGS = ("slip_threshold", "transient", "s_x", "span_fraction", "psi_crystal",
                     "psi_late_fraction")


def _files(d):
    return {p.name for p in d.iterdir()}


def test_friction_scene_writes_no_per_atom_output(lammps, tmp_path):
    spec = RunSpec(phi=30.0, t_end=200, scene="friction")
    run(spec, tmp_path, progress=False)
    deck = (tmp_path / "in.bk").read_text()
    assert "dump" not in deck and "bk/slips" not in deck
    assert not any(n.endswith(".lammpstrj") for n in _files(tmp_path))
    # the stress and the phases reduced in the run, no raw series (scene series keeps them)
    assert {"extrema.npy", "blocks.npy"} <= _files(tmp_path)
    assert not {"stress.csv", "phase.csv", "psi.npy"} & _files(tmp_path)
    s = analyze(tmp_path)
    assert s["n_slips"] > 0 and s["psi_inf"] is None and s["regime"] is None
    assert not (tmp_path / "psi.csv").exists() and not (tmp_path / "clusters.csv").exists()


def test_slip_frames_hold_the_positions_at_each_slips_maximum_and_minimum(lammps, tmp_path):
    """With snapshots at every stress sample (never done in practice), the frames fix bk/slips
    keeps must be exactly the snapshots at the steps of each event's maximum and minimum, and
    its events must be those slip_events finds in the raw stress series after the
    transient."""
    spec = RunSpec(phi=30.0, t_end=200, scene="full", snapshot_every=0.1)
    assert spec.snapshot_nevery == spec.stress_nevery
    run(spec, tmp_path, progress=False)
    t, sigma = RunDir(tmp_path).read_stress()
    events = slip_events(t, sigma, spec.slip_threshold_stress).after(spec.transient_step * spec.dt)
    assert len(events) >= 3
    slips = read_frames(tmp_path / "slips.lammpstrj", spec.N)
    snaps = read_frames(tmp_path / "snapshots.lammpstrj", spec.N)
    ev_steps = np.column_stack([events.i_max, events.i_min]).ravel() * spec.stress_nevery
    np.testing.assert_array_equal(slips.steps, ev_steps)
    at = {int(s): k for k, s in enumerate(snaps.steps)}
    for k, step in enumerate(slips.steps):
        np.testing.assert_allclose(slips.positions[k], snaps.positions[at[int(step)]], atol=1e-5)
    s = analyze(tmp_path)
    assert s["n_cluster_events"] == len(events) and s["n_slips_without_snapshots"] == 0
    clusters = pd.read_csv(tmp_path / "clusters.csv")
    assert list(clusters.columns) == ["event", "t", "n_c", "l_x", "l_y", "n_x", "n_y", "slip",
                                      "bond_change", "eq2_estimate"]
    assert (clusters["n_c"] >= 2).all() and (clusters["n_c"] <= spec.N).all()


def test_order_scene_computes_psi_in_the_run(lammps, tmp_path):
    spec = RunSpec(phi=1000.0, t_end=100, scene="order", snapshot_every=10)
    run(spec, tmp_path, progress=False)
    # Psi(t) computed in the run (fix bk/psi), no frames, no second copy by the analysis
    assert not {"slips.lammpstrj", "snapshots.lammpstrj"} & _files(tmp_path)
    s = analyze(tmp_path)
    assert not (tmp_path / "psi.csv").exists()
    psi = RunDir(tmp_path).read_psi_table()
    assert list(psi.columns) == ["t", "psi"] and len(psi) == 11  # t = 0, 10, ..., 100
    assert psi["psi"].iloc[0] == pytest.approx(1.0, abs=1e-6)  # starts on the lattice
    assert 0.9 < s["psi_inf"] <= 1.0  # stiff layer stays crystalline
    assert s["regime"] is None and not (tmp_path / "clusters.csv").exists()


def test_run_analyses_unless_told_not_to(lammps, tmp_path, capsys):
    out = tmp_path / "r"
    args = ["run", "--phi", "30", "--t-end", "150", "--out", str(out), "--quiet"]
    assert main(args + ["--no-analyze"]) == 0
    assert not (out / "summary.json").exists()
    assert main(["analyze", str(out)]) == 0
    assert "summary.json written" in capsys.readouterr().out
    s = json.loads((out / "summary.json").read_text())
    missing = [k for k in REQUIRED if k not in s] + [
        k for k in REQUIRED_SETTINGS if k not in s["settings"]]
    assert not missing
    assert set(s["mu_bar_by_threshold"]) == {"0.001", "0.01", "0.03", "0.1"}
    assert s["mu_bar_by_threshold"]["0.01"] == s["mu_bar"]
    assert main(args + ["--overwrite"]) == 0  # analyses by default
    assert (out / "summary.json").exists() and "mu_bar =" in capsys.readouterr().out


def test_analyze_refuses_a_directory_without_a_finished_run(tmp_path, capsys):
    write_deck(RunSpec(phi=1.0), tmp_path)
    assert main(["analyze", str(tmp_path)]) == 2
    assert "holds no finished run" in capsys.readouterr().err
    # a standalone run cut off half-way
    (tmp_path / "stress.csv").write_text("t,sigma_x\n0,0\n0.1,0.001\n")
    assert main(["analyze", str(tmp_path)]) == 2
    assert "did not finish" in capsys.readouterr().err
    assert main(["analyze", str(tmp_path / "nowhere")]) == 2


def test_truncated_slip_file_is_reported(lammps, tmp_path, capsys):
    spec = RunSpec(phi=30.0, t_end=200, scene="clusters")
    run(spec, tmp_path, progress=False)
    text = (tmp_path / "slips.lammpstrj").read_text()
    frames = text.split("ITEM: TIMESTEP")
    (tmp_path / "slips.lammpstrj").write_text("ITEM: TIMESTEP".join(frames[:-1]))
    assert main(["analyze", str(tmp_path)]) == 2
    assert "truncated" in capsys.readouterr().err


@pytest.mark.parametrize("path", ["auto", "general"])
def test_slip_frames_are_the_same_on_two_ranks(lammps, tmp_path, path):
    """The frames of fix bk/slips, and with `breaks` (scene events) each contact's first break
    in the slip: the same on 1 and 2 ranks, on the fused path (each rank its rows) and on the
    general one (the first break travels with its atom between ranks)."""
    from bkflow.lammps.deck import DeckOptions

    spec = RunSpec(phi=10.0, Lx=12, Ly=3, t_end=150, scene="events", seed=3)
    write_deck(spec, tmp_path, DeckOptions(path=path))
    got = {}
    for np_ in (1, 2):
        d = tmp_path / f"np{np_}"
        d.mkdir()
        for f in ("in.bk", "data.bk"):
            (d / f).write_text((tmp_path / f).read_text())
        cmd = [tool("lmp"), "-in", "in.bk", "-screen", "none"]
        if np_ > 1:
            cmd = [tool("mpirun"), "-np", str(np_)] + cmd
        proc = subprocess.run(cmd, cwd=d, capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
        got[np_] = read_frames(d / "slips.lammpstrj", spec.N)
    assert len(got[1]) >= 4
    np.testing.assert_array_equal(got[1].steps, got[2].steps)
    np.testing.assert_allclose(got[1].positions, got[2].positions, atol=1e-6)
    one = got[1]
    assert one.breaks is not None and (one.breaks[1::2] >= 0).any()
    assert (one.breaks[0::2] == -1).all()  # the maximum's frame: nothing broke yet
    np.testing.assert_array_equal(one.breaks, got[2].breaks)
    # a first break lies inside its slip: after the maximum, at or before the minimum
    for k in range(0, len(one), 2):
        b = one.breaks[k + 1]
        assert ((b == -1) | ((b > one.steps[k]) & (b <= one.steps[k + 1]))).all()


@pytest.mark.slow
def test_full_scene_of_the_largest_paper_lattice_stays_small(lammps, tmp_path):
    """60x15 for the default preset's run with every observable: under 50 MB on disk besides
    the raw series' energy ledger, which has its own budget (64 bytes a sample: eight
    doubles, binary, beside step and sigma_x)."""
    spec = RunSpec(phi=10.0, Lx=60, Ly=15, scene="full")
    res = run(spec, tmp_path, progress=False)
    samples = np.load(tmp_path / "stress.npy")
    assert samples.dtype.itemsize == 80 and len(samples) > 1000
    assert res.meta["bytes_written"] - 64 * len(samples) < 50e6
    assert res.meta["slip_snapshots"]["written"] > 50


def test_the_fast_dump_reader_agrees_with_mdanalysis(lammps, tmp_path):
    """bkflow.store.formats.read_regular_frames (bkflow's own reader, for speed) gives the frames
    MDAnalysis gives, to MDAnalysis's single precision; a file it does not recognise in full
    (cut, frames of another size, columns missing) is left to MDAnalysis (None)."""
    from bkflow.store.formats import read_frames_mdanalysis, read_regular_frames

    spec = RunSpec(phi=30.0, t_end=300, scene="full")
    run(spec, tmp_path, progress=False)
    for name in ("slips.lammpstrj", "snapshots.lammpstrj"):
        fast = read_regular_frames(tmp_path / name)
        lib = read_frames_mdanalysis(tmp_path / name, spec.N)
        assert len(fast) == len(lib) > 2
        np.testing.assert_array_equal(fast.steps, lib.steps)
        scale = np.abs(lib.positions).max()
        np.testing.assert_allclose(fast.positions, lib.positions, rtol=0, atol=3e-7 * scale)
    text = (tmp_path / "snapshots.lammpstrj").read_text()
    lines = text.splitlines()
    per = spec.N + 9
    bad = tmp_path / "bad.lammpstrj"
    variants = {
        "cut inside a frame": "\n".join(lines[:per + 20]) + "\n",
        "a frame of another size": "\n".join(
            lines[:per] + [ln if k != 3 else str(spec.N - 1) for k, ln in
                           enumerate(lines[per:2 * per - 1])]) + "\n",
        "no image flags": "\n".join(
            ln.replace(" ix iy iz", "") if ln.startswith("ITEM: ATOMS") else
            " ".join(ln.split()[:5]) if k % per >= 9 else ln
            for k, ln in enumerate(lines)) + "\n",
        "not a number": text.replace(lines[12], lines[12].replace(" 0 0 0", " 0 x 0"), 1),
    }
    for what, content in variants.items():
        bad.write_text(content)
        assert read_regular_frames(bad) is None, what
    # and the reader used by the analysis reads a regular file with it
    fast = read_frames(tmp_path / "snapshots.lammpstrj", spec.N)
    np.testing.assert_array_equal(fast.positions,
                                  read_regular_frames(tmp_path / "snapshots.lammpstrj").positions)


# ------------------------------------------------------------------------ rupture fronts
def _fronts_against_a_velocity_dump(spec, workdir, ranks, path="auto"):
    """Run the deck of ``spec`` standalone (``ranks`` MPI ranks) with a dump of every
    particle's v_x at every stress sample beside fix bk/fronts; (fronts, {step: v_x by id},
    stress series)."""
    from bkflow.lammps.deck import DeckOptions, data_text, setup_text
    from bkflow.store.formats import read_fronts

    (workdir / "data.bk").write_text(data_text(spec))
    deck = setup_text(spec, DeckOptions(thermo_every=10**6, path=path))
    deck += (f"\ndump v all custom {spec.stress_nevery} v.dump id vx\n"
             "dump_modify v sort id format float %.17g\n"
             f"run {spec.n_steps}\n")
    (workdir / "in.bk").write_text(deck)
    cmd = [tool("lmp"), "-in", "in.bk", "-log", "log.lammps", "-screen", "none"]
    if ranks == 1:
        cmd += ["-var", "comm_cutoff", "0.1"]
    else:
        cmd = [tool("mpirun"), "-np", str(ranks)] + cmd
    subprocess.run(cmd, check=True, cwd=workdir, timeout=600)
    lines = (workdir / "v.dump").read_text().splitlines()
    per = spec.N + 9
    vel = {int(lines[k + 1]): np.array([float(ln.split()[1]) for ln in lines[k + 9:k + per]])
           for k in range(0, len(lines), per)}
    return read_fronts(workdir / "fronts.bin"), vel, RunDir(workdir).read_reduced(spec)


@pytest.mark.parametrize("ranks, path", [(1, "auto"), (2, "auto"), (2, "general")])
def test_fronts_are_the_slip_rate_of_every_particle_through_each_slip(lammps, tmp_path, ranks,
                                                                      path):
    """fix bk/fronts (scene fronts): one record per slip after the transient, the very slips
    of the stress (the zigzag rule), sampled at every stress sample from the slip's maximum to
    its minimum, holding every particle's v_x (float32) at those steps; on the fused path (one
    rank, two) and the general one (two)."""
    spec = RunSpec(phi=30.0, Lx=12, Ly=4, t_end=300, scene="fronts", seed=2)
    assert "bk/fronts" in deck_line(spec) and "bk/slips" not in deck_line(spec)
    fronts, vel, red = _fronts_against_a_velocity_dump(spec, tmp_path, ranks, path)
    # the slips of the run's records (bkflow.observables.reduced: exactly those of the whole series)
    events = red.events(spec.slip_threshold_stress).after(spec.slips_start_step * spec.dt)
    assert len(fronts) == len(events) >= 3
    for f, i_max, i_min in zip(fronts, events.i_max, events.i_min):
        first = int(i_max) * spec.stress_nevery
        last = int(i_min) * spec.stress_nevery
        assert (f.step_max, f.step_min) == (first, last)
        np.testing.assert_array_equal(f.steps, np.arange(first, last + 1, spec.stress_nevery))
        assert f.vx.shape == (len(f.steps), spec.N) and f.vx.dtype == np.float32
        assert not f.truncated
        for k, step in enumerate(f.steps):
            np.testing.assert_array_equal(f.vx[k], vel[int(step)].astype(np.float32))


def test_an_adaptive_runs_fronts_start_after_the_transient_of_the_length_it_ran(lammps,
                                                                               tmp_path):
    """An adaptive run records fronts from the transient of its shortest length (its end is
    not known in advance); Run.fronts, and so bkflow movie's --slip 0, start after the
    transient of the length it ran, as its help says."""
    import bkflow
    from bkflow.model.protocols import protocol_fields

    spec = RunSpec(phi=30.0, Lx=12, Ly=4, scene="fronts", seed=2,
                   **{**protocol_fields("steady", t_end=3000.0), "target_error": 1e-7})
    from bkflow.analysis.summary import analyze

    run(spec, tmp_path / "r", progress=False)
    analyze(tmp_path / "r")
    r = bkflow.load_run(tmp_path / "r")
    t0 = r.summary["t_transient"]
    raw = RunDir(tmp_path / "r").read_fronts()
    assert t0 > spec.slips_start_step * spec.dt
    early = [f for f in raw if f.step_max * spec.dt < t0]
    assert early and len(r.fronts) == len(raw) - len(early) > 0
    assert all(f.step_max * spec.dt >= t0 for f in r.fronts)
    assert r.fronts[0].step_max == raw[len(early)].step_max


def deck_line(spec):
    from bkflow.lammps.deck import deck_text

    return deck_text(spec)


def test_the_full_scene_keeps_the_first_fronts_and_a_movie_is_made(lammps, tmp_path, capsys):
    from PIL import Image

    from bkflow.model.scenes import FRONTS_IN_FULL
    from bkflow.store.errors import DamagedRunError

    spec = RunSpec(phi=30.0, Lx=12, Ly=4, t_end=1500, scene="full", seed=2)
    meta = run(spec, tmp_path / "r", progress=False).meta
    assert meta["fronts"]["events"] > FRONTS_IN_FULL
    assert meta["fronts"]["written"] == FRONTS_IN_FULL
    fronts = RunDir(tmp_path / "r").read_fronts()
    assert len(fronts) == FRONTS_IN_FULL
    assert main(["movie", str(tmp_path / "r"), "--slip", "2", "--fps", "10"]) == 0
    gif = tmp_path / "r" / "movie_slip2.gif"
    with Image.open(gif) as im:
        assert im.n_frames == len(fronts[2].steps) > 3
        cell = max(2, min(24, -(-840 // spec.Lx)))  # pixels per particle: ~840 px across
        # the layer inside a frame with axes, colour bar and title around it
        assert im.size[0] > cell * spec.Lx and im.size[1] > cell * spec.Ly + 100
    # both pictures say which run this is: its start and protocol under the slip's times
    import bkflow
    from bkflow.figures.fronts import run_description

    r = bkflow.load_run(tmp_path / "r")
    title = r.front_figure(2).get_suptitle()
    assert "slip 2 (t = " in title and title.endswith("\n" + run_description(spec))
    assert run_description(spec).startswith(f"{spec.start} start")
    frame_texts = [t.get_text() for t in r.front_frame(2, 1).texts]
    assert run_description(spec) in frame_texts and any("frame 2 of" in t for t in frame_texts)
    assert (tmp_path / "r" / "fronts_slip2.png").stat().st_size > 1000
    assert "frames" in capsys.readouterr().out
    # a run without fronts, a slip not recorded, a cut file: one line each, exit 2
    plain = RunSpec(phi=30.0, Lx=12, Ly=4, t_end=100, scene="friction")
    run(plain, tmp_path / "plain", progress=False)
    assert main(["movie", str(tmp_path / "plain")]) == 2
    assert main(["movie", str(tmp_path / "r"), "--slip", str(FRONTS_IN_FULL)]) == 2
    assert main(["movie", str(tmp_path / "r"), "--slip", "-1"]) == 2
    assert main(["movie", str(tmp_path / "nothing")]) == 2
    err = capsys.readouterr().err
    assert "no rupture fronts recorded" in err and f"0..{FRONTS_IN_FULL - 1}" in err
    assert "--slip must be >= 0" in err and "holds no finished run" in err
    data = (tmp_path / "r" / "fronts.bin").read_bytes()
    (tmp_path / "r" / "fronts.bin").write_bytes(data[:len(data) - 100])
    with pytest.raises(DamagedRunError, match="cut"):
        RunDir(tmp_path / "r").read_fronts()


def _front(lx=6, ly=3, samples=5, seed=1):
    from bkflow.store.formats import Front

    vx = np.random.default_rng(seed).normal(size=(samples, lx * ly)).astype(np.float32)
    return Front(100, 100 + 10 * (samples - 1), np.arange(100, 100 + 10 * samples, 10), vx,
                 False)


def test_a_movie_frame_has_axes_a_colour_bar_with_units_and_each_particle_in_its_cell(tmp_path):
    """Every frame of the GIF is the frame figure (axes in lattice units, a colour bar labelled
    with the slip rate's units, the title's lines) with the layer pasted where the figure's
    axes are: each particle's cell has the colour of its v_x on the colour bar's scale, row 0
    at the bottom, through every frame."""
    import matplotlib
    from matplotlib.colors import Normalize
    from PIL import Image

    from bkflow.figures.fronts import CMAP, front_frame_figure, front_movie
    from bkflow.figures.style import PlotError

    lx, ly, dt = 6, 3, 0.01
    front = _front(lx, ly)
    title = "line one\nline two"
    fig, (left, top), _ = front_frame_figure(front, lx, ly, dt, title, 2, cell=10)
    layer, bar = fig.axes
    assert layer.get_xlabel().startswith("x / l") and layer.get_ylabel().startswith("y / l")
    assert "slip rate" in bar.get_xlabel() and r"$l\sqrt{k_d/m}$" in bar.get_xlabel()
    texts = [t.get_text() for t in fig.texts]
    assert "line one" in texts and "line two" in texts
    assert any(t.startswith("t \u2212 t_max = 0.20 sqrt(m/k_d)") for t in texts), texts
    with pytest.raises(PlotError, match="frame 5 not recorded"):
        front_frame_figure(front, lx, ly, dt, title, 5)

    gif = tmp_path / "m.gif"
    assert front_movie(front, lx, ly, dt, gif, title=title, cell=10) == 5
    vmax = float(np.percentile(np.abs(front.vx), 99.5))
    colours = matplotlib.colormaps[CMAP](Normalize(-vmax, vmax)(front.vx))[..., :3] * 255
    with Image.open(gif) as im:
        assert im.size == (round(fig.get_figwidth() * 100), round(fig.get_figheight() * 100))
        for k in range(im.n_frames):
            im.seek(k)
            rgb = np.asarray(im.convert("RGB"), dtype=float)
            for j in range(ly):
                for i in range(lx):
                    pixel = rgb[top + (ly - 1 - j) * 10 + 5, left + i * 10 + 5]
                    # one palette of 224 colours along the map: within its step
                    assert np.abs(pixel - colours[k, j * lx + i]).max() < 12, (k, i, j)


def test_the_pictures_of_a_slip_name_the_runs_start_and_protocol():
    """run_description says of a run what a reader of its front pictures needs: the start,
    and the paper's fixed length or the steady protocol's rule with its cap."""
    from bkflow.figures.fronts import front_figure, run_description
    from bkflow.model.protocols import protocol_fields

    paper = RunSpec(phi=100.0, **protocol_fields("paper", t_end=1000.0))
    steady = RunSpec(phi=100.0, **protocol_fields("steady", t_end=1000.0))
    sync = RunSpec(phi=100.0, **protocol_fields("steady", start="synchronized"))
    fixed = RunSpec(phi=100.0, start="random", t_end=500.0)
    assert run_description(paper) == "synchronized start, paper's protocol (t_end = 1000)"
    assert run_description(steady) == ("random start, steady protocol (until steady, at most "
                                       "t = 1000)")
    assert run_description(sync).startswith("synchronized start beside a partial companion, "
                                            "until steady")
    assert run_description(fixed) == "random start, a fixed length (t_end = 500)"
    fig = front_figure(_front(), 6, 3, 0.01, title="slip\n" + run_description(steady))
    assert fig.get_suptitle().endswith(run_description(steady))


def test_overwriting_a_run_removes_its_movies_and_bad_requests_are_refused(
        lammps, tmp_path, capsys):
    import bkflow
    from bkflow.model.checks import SpecError

    spec = RunSpec(phi=30.0, Lx=12, Ly=4, t_end=300, scene="fronts", seed=2)
    run(spec, tmp_path / "r", progress=False)
    assert main(["movie", str(tmp_path / "r")]) == 0
    assert (tmp_path / "r" / "movie_slip0.gif").exists()
    for fps in ("0", "100", "inf"):
        assert main(["movie", str(tmp_path / "r"), "--fps", fps]) == 2
    run(spec.replace(scene="friction"), tmp_path / "r", progress=False, overwrite=True)
    left = _files(tmp_path / "r")
    assert not {n for n in left if n.startswith(("movie_slip", "fronts_slip", "fronts.bin"))}
    (tmp_path / "r2").mkdir()
    with pytest.raises(SpecError, match="friction threshold"):
        RunSpec(phi=1.0, mu_s=1e308)
    with pytest.raises(SpecError, match="stress_every"):
        RunSpec(phi=1.0, stress_every=1e9)
    r = bkflow.load_run(tmp_path / "r")
    with pytest.raises(Exception, match="no rupture fronts recorded"):
        r.front_figure(0)
    assert "load_sweep" in dir(bkflow)
