"""The time step (docs/model.md "Integration"): the presets' rule, the same in bkflow, in the
independent reference integrator and on both integration paths; the stability bound checked on
a run's own parameters; a run whose step is too long for its friction law stopped."""

import pytest

from bkflow.lammps.deck import DeckOptions, data_text, setup_text
from bkflow.lammps.engine import RunError, run
from bkflow.lammps.plugin import open_lammps
from bkflow.model.checks import SpecError
from bkflow.model.params import RunSpec
from bkflow.model.timestep import ACCURACY, DT_FACTOR_MAX
from tests import reference
from tests.support import INTEGRATION_PATHS

PHIS = (0.1, 1.0, 10.0, 46.4, 100.0, 296.0, 1000.0, 1e4)


@pytest.mark.parametrize("preset", sorted(ACCURACY))
@pytest.mark.parametrize("phi", PHIS)
def test_the_rule_is_the_reference_integrators(preset, phi):
    for changes in ({}, {"k_e": 1000.0}, {"k_d": 2.0, "dk_d": 0.5, "mass": 3.0}):
        spec = RunSpec(phi=phi, accuracy=preset, **changes)
        want = reference.time_step(preset, spec.k_b, spec.k_e, spec.k_d, spec.dk_d, spec.mass)
        assert spec.dt == pytest.approx(want, rel=1e-15), (preset, phi, changes)
        assert preset in spec.dt_rule


def test_the_rule_takes_the_contacts_step_for_soft_layers_and_the_margin_for_stiff_ones():
    soft, stiff = RunSpec(phi=0.1), RunSpec(phi=1000.0)
    c_contact, c_stable = ACCURACY["default"].c_contact, ACCURACY["default"].c_stable
    assert soft.dt * soft.omega_contact == pytest.approx(c_contact)
    assert stiff.dt * stiff.omega_max == pytest.approx(c_stable)
    assert "contacts' cycle" in soft.dt_rule and "stability margin" in stiff.dt_rule
    # an explicit C is C / omega_max, as before the rule
    assert RunSpec(phi=10.0, dt_factor=0.1).dt == 0.1 / RunSpec(phi=10.0).omega_max


def test_every_preset_stays_inside_the_stability_bound():
    for preset in ACCURACY:
        for phi in PHIS:
            for k_e in (0.1, 10.0, 1e4):
                spec = RunSpec(phi=phi, accuracy=preset, k_e=k_e)
                assert spec.dt * spec.omega_max <= DT_FACTOR_MAX


def test_the_stability_bound_is_the_runs_own():
    """C is over the run's own fastest mode: a stiffer contact shortens the step, and a C
    above the bound is refused whatever the parameters."""
    assert RunSpec(phi=10.0, k_e=1000.0).dt < RunSpec(phi=10.0).dt / 5
    with pytest.raises(SpecError, match="stability bound"):
        RunSpec(phi=10.0, k_e=1000.0, dt_factor=DT_FACTOR_MAX * 1.01)


@pytest.mark.parametrize("path", INTEGRATION_PATHS)
@pytest.mark.parametrize("phi", [0.1, 1000.0])
def test_both_paths_run_the_rules_step(path, phi, workdir, lammps):
    spec = RunSpec(phi=phi, Lx=6, Ly=3, seed=2)
    (workdir / "data.bk").write_text(data_text(spec))
    lmp = open_lammps()
    lmp.commands_string(setup_text(spec, DeckOptions(data="data.bk", stress=None, blocks=None,
                                                     psi=None, phase=None,
                                                     thermo_every=10**6, path=path)))
    lmp.command("run 10")
    assert lmp.extract_global("dt") == spec.dt
    lmp.close()


def test_a_step_too_long_for_the_friction_law_stops_the_run(workdir, lammps):
    """A contact 100 times stiffer at C = 1.9: inside the linear stability bound, yet each step
    carries contacts past their whole range (the friction force passes mu_s sigma_n A): the run
    stops and says so, rather than finish with a mean stress up to 1.8 mu_s sigma_n."""
    spec = RunSpec(phi=10.0, dt_factor=1.9, k_e=1000.0, t_end=500.0, scene="friction")
    with pytest.raises(RunError, match="past their whole range"):
        run(spec, workdir / "r", progress=False)
    assert not (workdir / "r" / "meta.json").exists()
    # the rule's own step for these parameters runs
    ok = run(spec.replace(dt_factor=None, t_end=100.0), workdir / "ok", progress=False)
    assert ok.meta["contact_overshoots"] < 0.01 * ok.meta["contact_breaks"]
