"""The contacts' load phases (docs/model.md "Contact phase") as the plugin records them: fix
bk/phase writes phase.csv, t,R,Z_re,Z_im,R2,u_mean,u_std, from fix bk/substrate's contact
displacements. Checked against the reference integrator on both integration paths and from
every start, on one and two ranks, and across a restart."""

import math
import subprocess

import numpy as np
import pandas as pd
import pytest

from bkflow.lammps.deck import DeckOptions, continue_text, data_text, setup_text
from bkflow.lammps.plugin import open_lammps
from bkflow.model.lattice import contact_start
from bkflow.model.params import CONTACT_RULES, STARTS, RunSpec
from tests.reference import Reference, phase_statistics
from tests.support import INTEGRATION_PATHS, lively_start, tool

STEPS, EVERY, PRELOAD = 2000, 10, 1.2
COLUMNS = ["R", "Z_re", "Z_im", "R2", "u_mean", "u_std"]


def _spec(**kw):
    spec = RunSpec(**{"phi": 10.0, "Lx": 8, "Ly": 3, "seed": 3, "scene": "series", **kw})
    # a phase sample every EVERY steps (the deck rounds phase_every to stress samples)
    return spec.replace(stress_every=EVERY * spec.dt * 1.0000001, phase_every=1e-9)


def _plugin_phases(spec, workdir, path, lattice, v0, steps=STEPS):
    data = workdir / "data.bk"
    data.write_text(data_text(spec, lattice, v0))
    lmp = open_lammps()
    try:
        lmp.commands_string(setup_text(spec, DeckOptions(data=str(data), stress=None,
                                                         blocks=None, psi=None,
                                                         phase="phase.csv", thermo_every=10**6,
                                                         path=path)))
        lmp.command(f"displace_atoms all move {-PRELOAD!r} 0 0")
        lmp.command(f"run {steps}")
    finally:
        lmp.close()
    return pd.read_csv(workdir / "phase.csv")


def _reference_phases(spec, lattice, x0, v0, steps=STEPS):
    ref = Reference(lattice.box, lattice.bonds, spec.k_b, spec.dt, k_d=lattice.k_d,
                    V_d=spec.V_d, k_e=spec.k_e, f_max=spec.friction_threshold,
                    mode=spec.contact_rule, gamma=spec.gamma, mass=spec.mass,
                    damping=spec.damping)
    dr0 = np.column_stack([contact_start(spec), np.zeros(spec.N)])
    s = ref.start(x0 - [PRELOAD, 0.0], v0, anchor=x0, dr=dr0)
    rows = [phase_statistics(s.dr, spec.k_e, spec.friction_threshold)]
    for _ in range(steps // EVERY):
        ref.step(s, EVERY)
        rows.append(phase_statistics(s.dr, spec.k_e, spec.friction_threshold))
    return pd.DataFrame(rows), s.breaks


@pytest.mark.parametrize("path", INTEGRATION_PATHS)
@pytest.mark.parametrize("start", STARTS)
@pytest.mark.parametrize("phi, mode", list(zip([0.1, 1000.0, 10.0], CONTACT_RULES)))
def test_phases_match_the_reference_integrator(lammps, path, start, phi, mode, workdir):
    spec = _spec(phi=phi, start=start, contact_rule=mode)
    assert spec.phase_nevery == EVERY
    lattice, x0, v0 = lively_start(spec)
    got = _plugin_phases(spec, workdir, path, lattice, v0)
    want, breaks = _reference_phases(spec, lattice, x0, v0)
    assert breaks > 0 and len(got) == len(want) == STEPS // EVERY + 1
    np.testing.assert_allclose(got["t"], np.arange(len(got)) * EVERY * spec.dt, rtol=1e-9)
    for col in COLUMNS:
        if col == "u_std":  # from one-pass sums: the variance is exact to rounding, so the
            # spread of contacts that all sit at one phase (coulomb: at u = 1) is ~sqrt(eps)
            np.testing.assert_allclose(got[col] ** 2, want[col] ** 2, rtol=0, atol=1e-9)
            continue
        np.testing.assert_allclose(got[col], want[col], rtol=0, atol=1e-9, err_msg=col)
    assert got["R"].std() > 0.01  # the phases moved


def test_the_phasor_is_libms_to_rounding():
    """bk_model.h's branch-free exp(2 pi i u) against libm's, here through the plugin's
    phase.csv of a stratified start: R = |sum exp(2 pi i (k + 1/2)/N)| / N = 0 to rounding, and
    through the reference on random phases (test above); this checks the polynomial directly,
    transcribed, on u in [-1, 2]."""
    u = np.linspace(-1.0, 2.0, 300_001)
    h = np.pi * (u - np.floor(u + 0.5))
    h2 = h * h
    sn = h * np.polynomial.polynomial.polyval(h2, [1 / math.factorial(2 * k + 1) * (-1) ** k
                                                   for k in range(11)])
    cs = np.polynomial.polynomial.polyval(h2, [1 / math.factorial(2 * k) * (-1) ** k
                                               for k in range(11)])
    np.testing.assert_allclose(cs * cs - sn * sn, np.cos(2 * np.pi * u), rtol=0, atol=2e-15)
    np.testing.assert_allclose(2 * sn * cs, np.sin(2 * np.pi * u), rtol=0, atol=2e-15)


def test_the_starts_have_their_coherence():
    """R = 1 for the synchronized start, R = 0 for the stratified one (the phases evenly
    spread), about 1/sqrt(N) for the random one; u's spread as the start puts it."""
    n = 30 * 30
    stats = {}
    for start in STARTS:
        spec = RunSpec(phi=10.0, Lx=30, Ly=30, seed=5, start=start)
        dr = np.column_stack([contact_start(spec), np.zeros(spec.N)])
        stats[start] = phase_statistics(dr, spec.k_e, spec.friction_threshold)
    assert stats["synchronized"]["R"] == 1.0 and stats["synchronized"]["u_std"] == 0.0
    assert stats["stratified"]["R"] < 1e-12 and stats["stratified"]["R2"] < 1e-12
    assert stats["stratified"]["u_std"] == pytest.approx(np.sqrt((n * n - 1) / 12) / n, rel=1e-12)
    assert 0.2 / np.sqrt(n) < stats["random"]["R"] < 3 / np.sqrt(n)


def _standalone(workdir, deck, ranks, tag):
    (workdir / "in.bk").write_text(deck)
    cmd = [tool("lmp"), "-in", "in.bk", "-log", f"log.{tag}", "-screen", "none"]
    if ranks > 1:
        cmd = [tool("mpirun"), "-np", str(ranks)] + cmd
    subprocess.run(cmd, check=True, cwd=workdir, timeout=300)
    return pd.read_csv(workdir / f"phase.{tag}.csv")


@pytest.mark.parametrize("path", ["auto", "general"])
@pytest.mark.parametrize("start", ["synchronized", "stratified"])
def test_two_ranks_record_the_phases_of_one_rank(lammps, start, path, workdir):
    """The fused path on 2 ranks (each sums its rows, the rows gathered exactly and added in
    order) against the fused path on one rank: the same bits; the general path on 2 ranks
    (each sums its own contacts, then the sums are reduced): to the rounding of the order."""
    spec = _spec(phi=10.0, Lx=12, Ly=3, seed=5, start=start)
    # rows at their sites, half a row from the fused path's cuts between ranks
    lattice, _, v0 = lively_start(spec, offset=(0.495, 0.0), drift=(0.2, 0.0))
    (workdir / "data.bk").write_text(data_text(spec, lattice, v0))
    runs = {}
    for ranks in (1, 2):
        deck = setup_text(spec, DeckOptions(stress=None, blocks=None, psi=None,
                                            phase=f"phase.{ranks}.csv",
                                            thermo_every=10**6,
                                            path="auto" if ranks == 1 else path))
        deck += f"displace_atoms all move {-PRELOAD!r} 0 0\nrun {STEPS}\n"
        runs[ranks] = _standalone(workdir, deck, ranks, str(ranks))
        log = (workdir / f"log.{ranks}").read_text()
        assert f"on {ranks} procs" in log
        assert ("bk/substrate fused:" in log) == (ranks == 1 or path == "auto")
    assert len(runs[1]) == len(runs[2]) == STEPS // EVERY + 1
    if path == "auto":
        assert (workdir / "phase.2.csv").read_text() == (workdir / "phase.1.csv").read_text()
    for col in COLUMNS:
        np.testing.assert_allclose(runs[2][col], runs[1][col], rtol=0, atol=1e-10, err_msg=col)


@pytest.mark.parametrize("path", INTEGRATION_PATHS)
def test_a_restart_continues_the_phase_series(lammps, path, workdir):
    spec = _spec(phi=100.0, Lx=6, Ly=6, seed=2, start="random")
    lattice, _, v0 = lively_start(spec)
    data = workdir / "data.bk"
    data.write_text(data_text(spec, lattice, v0))
    whole = _plugin_phases(spec, workdir, path, lattice, v0)

    lmp = open_lammps()
    lmp.commands_string(setup_text(spec, DeckOptions(data=str(data), stress=None, blocks=None,
                                                     psi=None,
                                                     phase="first.csv", thermo_every=10**6,
                                                     path=path)))
    lmp.command(f"displace_atoms all move {-PRELOAD!r} 0 0")
    lmp.command(f"run {STEPS // 2}")
    lmp.command("write_restart half.restart")
    lmp.close()
    lmp = open_lammps()
    lmp.commands_string(continue_text(spec, "half.restart",
                                      DeckOptions(data="", stress=None, blocks=None, psi=None,
                                                  phase="second.csv",
                                                  thermo_every=10**6, path=path)))
    lmp.command(f"run {STEPS // 2}")
    lmp.close()
    first, second = pd.read_csv("first.csv"), pd.read_csv("second.csv")
    # the continued run samples the restart step again at its setup
    resumed = pd.concat([first, second.iloc[1:]], ignore_index=True)
    assert len(resumed) == len(whole)
    for col in ["t"] + COLUMNS:
        np.testing.assert_allclose(resumed[col], whole[col], rtol=0, atol=1e-12, err_msg=col)
