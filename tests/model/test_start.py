"""The starting state of the contacts (the model's "Starting state"): the paper's synchronized
start (every dr_i = 0) and the random start (dr_i = (u_i, 0), u_i uniform in
[0, mu_s sigma_n A / k_e) from a seed stream independent of the k_d^i draw), in the deck, in
the plugin and in the reference integrator."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from bkflow.lammps.deck import data_text, deck_text
from bkflow.model.checks import SpecError
from bkflow.model.lattice import contact_start, lattice_for
from bkflow.model.params import CONTACT_RULES, RunSpec
from tests.reference import Reference
from tests.support import global_vector, lammps_with, lively_start, unwrapped_state


def test_the_synchronized_start_has_every_contact_at_zero():
    spec = RunSpec(phi=10.0)
    assert spec.start == "synchronized"
    np.testing.assert_array_equal(contact_start(spec), np.zeros(spec.N))
    assert "ContactStart" not in data_text(spec) and "start d_dr0" not in deck_text(spec)


def test_the_random_start_is_uniform_below_the_break_and_seeded():
    spec = RunSpec(phi=10.0, Lx=100, Ly=100, start="random", seed=3)
    u = contact_start(spec)
    limit = spec.friction_threshold / spec.k_e
    assert u.shape == (spec.N,) and np.all((u >= 0) & (u < limit))
    assert stats.kstest(u / limit, "uniform").pvalue > 0.01
    np.testing.assert_array_equal(u, contact_start(spec))                  # same seed
    assert not np.array_equal(u, contact_start(spec.replace(seed=4)))      # another seed


def test_the_random_start_leaves_the_drive_draw_alone_and_is_independent_of_it():
    sync = RunSpec(phi=10.0, Lx=100, Ly=100, seed=3)
    rand = sync.replace(start="random")
    k_d = lattice_for(sync).k_d
    np.testing.assert_array_equal(lattice_for(rand).k_d, k_d)  # the k_d^i draw is unchanged
    u = contact_start(rand)
    assert abs(np.corrcoef(u, k_d)[0, 1]) < 4 / np.sqrt(rand.N)
    # nor is it the k_d^i stream rescaled
    assert abs(stats.spearmanr(u, k_d).statistic) < 4 / np.sqrt(rand.N)


def test_the_random_start_is_written_into_data_file_and_deck():
    spec = RunSpec(phi=10.0, Lx=4, Ly=3, start="random", seed=2)
    data = data_text(spec)
    rows = data.split("ContactStart\n\n")[1].strip().splitlines()
    values = np.array([float(r.split()[1]) for r in rows])
    np.testing.assert_array_equal(values, contact_start(spec))
    deck = deck_text(spec)
    assert "fix             dr0 all property/atom d_dr0" in deck
    assert "fix dr0 NULL ContactStart" in deck and "start d_dr0" in deck


def test_an_unknown_start_is_refused():
    with pytest.raises(SpecError, match="start must be one of synchronized, random"):
        RunSpec(phi=1.0, start="hot")


def test_the_plugin_starts_from_the_contact_state_of_the_data_file(lammps, workdir):
    spec = RunSpec(phi=10.0, Lx=8, Ly=3, start="random", seed=6)
    lattice, _, v0 = lively_start(spec)
    lmp = lammps_with(spec, lattice, v0 * 0, workdir)
    lmp.command("run 0")
    state = unwrapped_state(lmp)["state"]
    lmp.close()
    np.testing.assert_array_equal(state[:, 2], contact_start(spec))
    np.testing.assert_array_equal(state[:, 3], 0.0)


@pytest.mark.parametrize("mode", CONTACT_RULES)
@pytest.mark.parametrize("phi", [0.1, 1000.0])
def test_plugin_matches_reference_integrator_from_the_random_start(lammps, phi, mode, workdir):
    spec = RunSpec(phi=phi, Lx=8, Ly=3, seed=3, contact_rule=mode, start="random")
    lattice, x0, v0 = lively_start(spec)
    preload, steps = 1.2, 2000
    lmp = lammps_with(spec, lattice, v0, workdir, preload=preload)
    lmp.command(f"run {steps}")
    got = unwrapped_state(lmp)
    breaks = int(global_vector(lmp, "breaks_total"))
    lmp.close()

    ref = Reference(lattice.box, lattice.bonds, spec.k_b, spec.dt, k_d=lattice.k_d,
                    V_d=spec.V_d, k_e=spec.k_e, f_max=spec.friction_threshold,
                    mode=spec.contact_rule, gamma=spec.gamma, mass=spec.mass,
                    damping=spec.damping)
    dr0 = np.column_stack([contact_start(spec), np.zeros(spec.N)])
    s = ref.start(x0 - [preload, 0.0], v0, anchor=x0, dr=dr0)
    ref.step(s, steps)
    assert breaks > 0
    np.testing.assert_allclose(got["x"], s.x, rtol=0, atol=1e-9)
    np.testing.assert_allclose(got["v"], s.v, rtol=0, atol=1e-9)
    np.testing.assert_allclose(got["state"][:, 2:4], s.dr, rtol=0, atol=1e-9)
    assert breaks == s.breaks


def test_the_reference_integrator_takes_the_contact_state():
    """The start state reaches the reference's forces: a contact pre-loaded by u pulls back
    with -k_e u at once."""
    spec = RunSpec(phi=10.0, Lx=4, Ly=3, start="random", seed=1)
    lat = lattice_for(spec)
    ref = Reference(lat.box, lat.bonds, spec.k_b, spec.dt, k_e=spec.k_e,
                    f_max=spec.friction_threshold)
    u = contact_start(spec)
    s = ref.start(lat.positions, dr=np.column_stack([u, np.zeros(spec.N)]))
    np.testing.assert_allclose(s.f[:, 0], -spec.k_e * u, atol=1e-12)
