"""The energy ledger of docs/model.md ("Energy") on the reference integrator (tests/reference.py):
each term exact where its answer is known, and the closure of plate work = change of elastic
and kinetic energy + dissipation falling with the time step at the scheme's order.

The reference keeps the ledger the way the plugin keeps it: the plate's work by the trapezoid rule
over each step, the damping's dissipation as what the two half kicks take from the kinetic energy
through the damping force, the contact energy a break removes at the break."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from bkflow.model.lattice import lattice_for
from bkflow.model.params import RunSpec
from tests.reference import Reference


def _reference(spec: RunSpec, **kw) -> tuple[Reference, object]:
    lat = lattice_for(spec)
    args = dict(k_d=lat.k_d, V_d=spec.V_d, k_e=spec.k_e, f_max=spec.friction_threshold,
                mode=spec.contact_rule, gamma=spec.gamma, mass=spec.mass, damping=spec.damping)
    args.update(kw)
    return Reference(lat.box, lat.bonds, spec.k_b, spec.dt, **args), lat


def _closure(spec: RunSpec, t_end: float, **kw) -> tuple[float, int]:
    """|residual| / plate work over [0, t_end] from the random start (contacts part-way
    through their cycles, so that breaks come early), and the number of breaks."""
    ref, lat = _reference(spec, **kw)
    rng = np.random.default_rng(spec.seed)
    dr = None
    if ref.k_e is not None:
        u = rng.uniform(0, spec.friction_threshold / spec.k_e, spec.N)
        dr = np.stack([u, np.zeros_like(u)], axis=1)
    s = ref.start(lat.positions, dr=dr)
    start = ref.ledger(s)
    ref.step(s, int(round(t_end / spec.dt)))
    end = ref.ledger(s)
    return abs(end.residual(start)) / abs(end.work_plate - start.work_plate), s.breaks


def test_damping_alone_dissipates_exactly_what_the_kinetic_energy_loses():
    """A moving layer with no bonds' stretch, no drive, no contacts: the implicit damping's
    ledger term is the kinetic energy's loss to rounding, step by step."""
    spec = RunSpec(phi=1.0, Lx=4, Ly=3, seed=1)
    ref, lat = _reference(spec, k_d=None, k_e=None, V_d=0.0)
    v0 = np.random.default_rng(2).normal(size=(spec.N, 2))
    s = ref.start(lat.positions, v=np.tile(v0.mean(axis=0), (spec.N, 1)))  # rigid: no stretch
    start = ref.ledger(s)
    ref.step(s, 500)
    end = ref.ledger(s)
    assert end.kinetic < 0.9 * start.kinetic
    assert end.diss_damp == pytest.approx(start.kinetic - end.kinetic, rel=1e-12)
    assert end.bond == pytest.approx(0.0, abs=1e-20) and end.work_plate == 0.0


def test_a_located_reset_removes_the_threshold_energy_per_break():
    """Under the located reset each break takes f_max^2 / (2 k_e) out of its contact: the
    contact had exactly the threshold's energy where it broke."""
    spec = RunSpec(phi=10.0, Lx=8, Ly=3, seed=1)
    ref, lat = _reference(spec)
    s = ref.start(lat.positions)
    ref.step(s, int(round(60.0 / spec.dt)))
    assert s.breaks > 10
    assert s.diss_break == pytest.approx(s.breaks * spec.friction_threshold ** 2
                                         / (2 * spec.k_e), rel=1e-9)


@pytest.mark.parametrize("case", [dict(k_e=None), dict(f_max=1e9)],
                         ids=["no contacts", "contacts that never break"])
def test_without_breaks_the_ledger_closes_at_second_order(case):
    """Bonds, drive, damping (and contacts that never break): the residual falls 4x when dt
    halves, on each seed (the trajectories do not diverge without breaks)."""
    for seed in (1, 2):
        spec = RunSpec(phi=10.0, Lx=8, Ly=3, seed=seed)
        coarse, _ = _closure(dataclasses.replace(spec, dt_factor=0.1), 40.0, **case)
        fine, _ = _closure(dataclasses.replace(spec, dt_factor=0.05), 40.0, **case)
        assert coarse / fine == pytest.approx(4.0, rel=0.05)


@pytest.mark.slow
def test_breaks_make_the_closure_first_order_and_the_located_break_keeps_it_small():
    """With breaks the trajectories are chaotic, so residuals are compared in the mean over
    seeds. Both resets are first order (the mean falls about 2x when dt halves): the kicks
    apply the re-formed contact's force over the whole step in which it broke, an error of
    order f_max v dt per break. Locating the break inside the step keeps that error many times
    smaller than resetting at the end of the step (benchmarks/measure/energy_order.py: 12-23x)."""
    means = {}
    for mode in ("reset", "reset/step"):
        for c in (0.1, 0.05):
            means[mode, c] = np.mean([
                _closure(RunSpec(phi=10.0, Lx=8, Ly=3, seed=seed, dt_factor=c,
                                 contact_rule=mode), 40.0)[0] for seed in range(1, 7)])
    assert 1.6 <= means["reset/step", 0.1] / means["reset/step", 0.05] <= 2.6, means
    assert means["reset", 0.1] / means["reset", 0.05] < 2.6, means
    for c in (0.1, 0.05):
        assert means["reset/step", c] > 8 * means["reset", c], means
