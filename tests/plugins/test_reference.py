"""fix bk/substrate against the independent NumPy integrator of tests/reference.py.

docs/model.md's dynamics on 8x3 and 6x6 lattices (8x2 is refused, see RunSpec: its two
y-bonds per particle join the same pair at exactly half the box), from a start that makes
things happen inside the window (pre-loaded plate, random velocities, atoms next to the box
edge), at the default preset's time step (phi = 1000: the stability margin, dt omega_max =
1.5, 15 times the step before the rule): after 2000 steps LAMMPS and the reference agree on
every position to 1e-9, and on the number of contact breaks exactly.
"""

import numpy as np
import pytest

from bkflow.model.params import RunSpec
from tests.reference import Reference, step_watching_the_box
from tests.support import RULE_COVER, global_vector, lammps_with, lively_start, unwrapped_state

pytestmark = pytest.mark.usefixtures("lammps")

STEPS = 2000
PRELOAD = 1.2


def reference_for(spec, lattice):
    return Reference(lattice.box, lattice.bonds, spec.k_b, spec.dt, k_d=lattice.k_d, V_d=spec.V_d,
                     k_e=spec.k_e, f_max=spec.friction_threshold, mode=spec.contact_rule,
                     gamma=spec.gamma, mass=spec.mass, damping=spec.damping)


@pytest.mark.parametrize("mode, damping", RULE_COVER)
@pytest.mark.parametrize("phi", [0.1, 10.0, 1000.0])
@pytest.mark.parametrize("size", [(8, 3), (6, 6)])
def test_plugin_matches_reference_integrator(size, phi, mode, damping, workdir):
    spec = RunSpec(phi=phi, Lx=size[0], Ly=size[1], seed=3, contact_rule=mode, damping=damping)
    lattice, x0, v0 = lively_start(spec)

    lmp = lammps_with(spec, lattice, v0, workdir, preload=PRELOAD)
    lmp.command(f"run {STEPS}")
    got = unwrapped_state(lmp)
    breaks = int(global_vector(lmp, "breaks_total"))
    overshoot = int(global_vector(lmp, "overshoot"))
    sigma_x = global_vector(lmp, "sigma_x")
    lmp.close()

    ref = reference_for(spec, lattice)
    s, crossed = step_watching_the_box(ref, ref.start(x0 - [PRELOAD, 0.0], v0, anchor=x0),
                                       STEPS)
    # the overshoot counter counts what the rule could not bring back, not its rounding:
    # (a counter of the rescaling's rounding would count about half of coulomb's breaks)
    assert overshoot == s.overshoot

    # the window exercised what it is meant to
    assert breaks > 0, "no contact broke inside the test window"
    assert crossed, "no atom crossed the periodic boundary"

    np.testing.assert_allclose(got["x"], s.x, rtol=0, atol=1e-9)
    np.testing.assert_allclose(got["v"], s.v, rtol=0, atol=1e-9)
    np.testing.assert_allclose(got["state"][:, 2:4], s.dr, rtol=0, atol=1e-9)
    assert breaks == s.breaks
    expected_sigma = (lattice.k_d * (s.anchor[:, 0] + spec.V_d * s.t - s.x[:, 0])).sum() / spec.N
    assert sigma_x == pytest.approx(expected_sigma, abs=1e-9)


def test_reference_detects_a_wrong_rule(workdir):
    """The comparison can fail: the other friction rule gives a different trajectory."""
    spec = RunSpec(phi=10.0, Lx=6, Ly=6, seed=3, contact_rule="reset")
    lattice, x0, v0 = lively_start(spec)
    lmp = lammps_with(spec, lattice, v0, workdir, preload=PRELOAD)
    lmp.command(f"run {STEPS}")
    got = unwrapped_state(lmp)
    lmp.close()
    ref = reference_for(spec.replace(contact_rule="coulomb"), lattice)
    s = ref.step(ref.start(x0 - [PRELOAD, 0.0], v0, anchor=x0), STEPS)
    assert np.abs(got["x"] - s.x).max() > 1e-3
