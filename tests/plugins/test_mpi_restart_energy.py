"""Per-atom state across MPI ranks, restart files and run chunks; energy conservation."""

import subprocess

import numpy as np
import pytest

from bkflow.lammps.deck import DeckOptions, continue_text, data_text, setup_text
from bkflow.lammps.plugin import open_lammps
from bkflow.model.params import RunSpec
from tests.support import global_vector, lammps_with, lively_start, tool, unwrapped_state

pytestmark = pytest.mark.usefixtures("lammps")

STEPS = 2000


def _state_after(lmp, steps, chunks=1):
    per = steps // chunks
    for k in range(chunks):
        lmp.command(f"run {per} pre {'yes' if k == 0 else 'no'} post no")
    out = unwrapped_state(lmp)
    out["breaks"] = global_vector(lmp, "breaks_total")
    lmp.close()
    return out


@pytest.mark.parametrize("start", ["synchronized", "random"])
def test_two_ranks_follow_the_one_rank_trajectory(workdir, start):
    """mpirun -np 2 lmp -in deck (plugin auto-loaded by the wheel's lmp) == lmp -in deck, the
    contact state included (with the random start, each atom's initial dr travels with it)."""
    spec = RunSpec(phi=10.0, Lx=12, Ly=3, seed=5, start=start)
    lattice, _, v0 = lively_start(spec)
    (workdir / "data.bk").write_text(data_text(spec, lattice, v0))
    deck = setup_text(spec, DeckOptions(stress=None, blocks=None, psi=None, thermo_every=500,
                                        path="general"))
    deck += (f"displace_atoms all move -1.2 0 0\nrun {STEPS}\n"
             "write_dump all custom final.txt id xu yu vx vy ix f_bk[3] f_bk[4] "
             "modify sort id format float %.17g\n")
    (workdir / "in.bk").write_text(deck)
    lmp = tool("lmp")
    runs = {}
    for np_ in (1, 2):
        cmd = [lmp, "-in", "in.bk", "-log", f"log.{np_}", "-screen", "none"]
        if np_ > 1:
            cmd = [tool("mpirun"), "-np", str(np_)] + cmd
        subprocess.run(cmd, check=True, cwd=workdir, timeout=300)
        runs[np_] = np.loadtxt(workdir / "final.txt", skiprows=9)
        log = (workdir / f"log.{np_}").read_text()
        assert f"on {np_} procs" in log
    one, two = runs[1], runs[2]
    assert np.any(one[:, 5] != 0), "no atom crossed the x boundary between the two ranks"
    np.testing.assert_allclose(two[:, 1:5], one[:, 1:5], rtol=0, atol=1e-9)
    np.testing.assert_allclose(two[:, 6:8], one[:, 6:8], rtol=0, atol=1e-9)


@pytest.mark.parametrize("start", ["synchronized", "random"])
def test_restart_continues_the_uninterrupted_run(workdir, start):
    spec = RunSpec(phi=10.0, Lx=6, Ly=6, seed=2, start=start)
    lattice, _, v0 = lively_start(spec)
    whole = _state_after(lammps_with(spec, lattice, v0, workdir, preload=1.2), STEPS)

    lmp = lammps_with(spec, lattice, v0, workdir, preload=1.2)
    lmp.command(f"run {STEPS // 2}")
    lmp.command(f"write_restart {workdir / 'half.restart'}")
    lmp.close()
    lmp = open_lammps()
    lmp.commands_string(continue_text(spec, str(workdir / "half.restart"), DeckOptions(
                                                                                       thermo_every=10**6,
                                                                                       path="general")))
    resumed = _state_after(lmp, STEPS // 2)

    assert whole["breaks"] > 0
    assert resumed["breaks"] == whole["breaks"]
    for key in ("x", "v", "state"):  # state: anchors, contact history, half-step velocities
        np.testing.assert_allclose(resumed[key], whole[key], rtol=0, atol=1e-12)


def test_run_in_chunks_follows_one_run(workdir):
    """The engine runs in chunks (run N pre no): setup must not perturb the trajectory, to
    the last bit (the plate's clock counts whole steps, not LAMMPS's per-run sum)."""
    spec = RunSpec(phi=1.0, Lx=6, Ly=6, seed=2)
    lattice, _, v0 = lively_start(spec)
    one = _state_after(lammps_with(spec, lattice, v0, workdir, preload=1.2), STEPS)
    many = _state_after(lammps_with(spec, lattice, v0, workdir, preload=1.2), STEPS, chunks=10)
    assert one["breaks"] == many["breaks"] > 0
    np.testing.assert_array_equal(many["x"], one["x"])
    np.testing.assert_array_equal(many["v"], one["v"])


def _energy_series(spec, lattice, x_perturbed, steps, every, workdir):
    from bkflow.model.lattice import Lattice

    lat = Lattice(lattice.Lx, lattice.Ly, x_perturbed, lattice.bonds, lattice.k_d)
    data = workdir / "data.bk"
    data.write_text(data_text(spec, lat))
    lmp = open_lammps()
    lmp.commands_string(setup_text(spec, DeckOptions(data=str(data), stress=None, blocks=None,
                                                     psi=None,
                                                     thermo_every=10**6, drive=False, contact=False,
                                                     damp=False, path="general")))
    lmp.commands_string("fix_modify bk energy yes\ncompute ke all ke\n"
                        f"fix e all ave/time {every} 1 {every} c_ke f_bk file energy.txt "
                        "format ' %.17g'\n")
    lmp.command(f"run {steps}")
    lmp.close()
    ke, pe = np.loadtxt(workdir / "energy.txt", usecols=(1, 2)).T
    return ke + pe


@pytest.mark.slow
def test_energy_is_conserved_to_second_order(workdir):
    """gamma = 0, no drive, no friction, phi = 1000: bounded energy error, O(dt^2)."""
    spec = RunSpec(phi=1000.0, Lx=6, Ly=6, seed=1, gamma=0.0, dt_factor=0.1)
    from bkflow.model.lattice import lattice_for

    lattice = lattice_for(spec)
    rng = np.random.default_rng(11)
    x = np.mod(lattice.positions + 0.05 * rng.standard_normal(lattice.positions.shape),
               np.array(lattice.box))
    n, every = 100_000, 10
    e1 = _energy_series(spec, lattice, x, n, every, workdir)
    e2 = _energy_series(spec.replace(dt_factor=spec.dt_factor / 2), lattice, x, 2 * n,
                        2 * every, workdir)
    window = 10_000 // every
    spread = lambda e: e.max() - e.min()  # noqa: E731
    first, last = spread(e1[:window]), spread(e1[-window:])
    assert first > 0
    assert last <= 1.5 * first, f"energy drifts: spread {first:.3g} -> {last:.3g}"
    err1, err2 = np.abs(e1 - e1[0]).max(), np.abs(e2 - e2[0]).max()
    ratio = err1 / err2
    assert 3.0 < ratio < 5.0, f"halving dt shrank the energy error {ratio:.2f}x, expected ~4x"
