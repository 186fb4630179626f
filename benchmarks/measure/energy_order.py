"""The energy ledger's closure against the time step, on the NumPy reference integrator
(tests/reference.py): which part of the scheme limits its order; and the plugin's own ledger
(fix bk/substrate ... energy) on both paths.

    python -m benchmarks.measure.energy_order [--t 40] [--size 8x3] [--phi 10] [--no-plugin]

For each case (no contacts; contacts that never break; each contact rule with breaks) and
C = 0.2, 0.1, 0.05, 0.025: the residual of plate work = change of elastic + kinetic energy +
dissipation over the window, relative to the plate's work, and the order between successive C.
Then the same for the plugin from the random start (RunSpec start "random"), on the general
and the fused path, one seed.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from benchmarks.harness import parser
from bkflow.model.lattice import lattice_for
from bkflow.model.params import RunSpec
from tests.reference import Reference

CS = (0.2, 0.1, 0.05, 0.025)


def residual(spec: RunSpec, t_end: float, *, friction=True, f_max=None, mode=None,
             damping=None, start_dr=True) -> tuple[float, float, int]:
    lat = lattice_for(spec)
    ref = Reference(lat.box, lat.bonds, spec.k_b, spec.dt, k_d=lat.k_d, V_d=spec.V_d,
                    k_e=spec.k_e if friction else None,
                    f_max=spec.friction_threshold if f_max is None else f_max,
                    mode=mode or spec.contact_rule, gamma=spec.gamma, mass=spec.mass,
                    damping=damping or spec.damping)
    rng = np.random.default_rng(spec.seed)
    dr = None
    if friction and start_dr:
        u = rng.uniform(0, spec.friction_threshold / spec.k_e, spec.N)
        dr = np.stack([u, np.zeros_like(u)], axis=1)
    s = ref.start(lat.positions, dr=dr)
    l0 = ref.ledger(s)
    steps = int(round(t_end / spec.dt))
    ref.step(s, steps)
    l1 = ref.ledger(s)
    w = l1.work_plate - l0.work_plate
    return l1.residual(l0), w, s.breaks


def main(argv=None) -> int:
    p = parser(__doc__)
    p.add_argument("--t", type=float, default=40.0)
    p.add_argument("--size", default="8x3")
    p.add_argument("--phi", type=float, default=10.0)
    p.add_argument("--seeds", type=int, default=6,
                   help="trajectories per case and C: the residual's mean over them (a "
                        "trajectory with breaks is chaotic, so one seed's residual is noisy)")
    p.add_argument("--no-plugin", action="store_true", help="the reference integrator only")
    a = p.parse_args(argv)
    lx, ly = (int(v) for v in a.size.split("x"))
    base = RunSpec(phi=a.phi, Lx=lx, Ly=ly, seed=1)
    seeds = range(1, a.seeds + 1)
    cases = {
        "no contacts (bonds, drive, damping)": dict(friction=False),
        "contacts that never break": dict(f_max=1e9),
        "reset (located break)": dict(mode="reset"),
        "reset/step": dict(mode="reset/step"),
        "coulomb": dict(mode="coulomb"),
        "reset, damping half": dict(mode="reset", damping="half"),
    }
    print(f"{a.size}, phi = {a.phi:g}, t = {a.t:g}, {a.seeds} seeds: mean |residual| / plate "
          "work (order against the C before) [contact breaks]")
    for name, kw in cases.items():
        row, prev = [], None
        for c in CS:
            rels, nb = [], 0
            for seed in seeds:
                spec = dataclasses.replace(base, dt_factor=c, seed=seed)
                r, w, b = residual(spec, a.t, **kw)
                rels.append(abs(r) / abs(w))
                nb += b
            rel = float(np.mean(rels))
            order = "" if prev is None or rel == 0 else f" ({math.log2(prev / rel):.2f})"
            row.append(f"{rel:.2e}{order} [{nb}]")
            prev = rel
        print(f"  {name:38s} " + "  ".join(row))
    if a.no_plugin:
        return 0
    print(f"\nthe plugin's ledger, {a.size}, phi = {a.phi:g}, t = {a.t:g}, the random start "
          "(contacts that never break: synchronized), seed 1: |residual| / plate work (order) "
          "[contact breaks], general | fused")
    # (the random start scales the contacts' displacements with the threshold: contacts that
    # never break start synchronized)
    plugin_cases = {"contacts that never break": dict(mu_s=1e6, start="synchronized"),
                    "reset (located break)": {}, "reset/step": dict(contact_rule="reset/step"),
                    "coulomb": dict(contact_rule="coulomb")}
    for name, kw in plugin_cases.items():
        row, prev = [], None
        for c in CS:
            spec = dataclasses.replace(base, **{"dt_factor": c, "start": "random",
                                                "scene": "friction", **kw})
            got = [plugin_residual(spec, a.t, path) for path in ("general", "fused")]
            rel = got[0][0]
            order = "" if prev is None or rel == 0 else f" ({math.log2(prev / rel):.2f})"
            row.append(f"{rel:.2e}{order} [{got[0][1]}] | {got[1][0]:.2e}")
            prev = rel
        print(f"  {name:28s} " + "  ".join(row))
    return 0


def plugin_residual(spec: RunSpec, t_end: float, path: str) -> tuple[float, int]:
    """|residual| / plate work of the plugin's ledger over [0, t_end], and the breaks."""
    import tempfile

    from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR

    from bkflow.lammps.deck import SLOTS, SUBSTRATE_FIX, DeckOptions, data_text, setup_text
    from bkflow.lammps.plugin import open_lammps
    from bkflow.observables.catalogue import balance
    from bkflow.observables.reduced import LEDGER_SLOTS

    with tempfile.TemporaryDirectory() as tmp:
        data = Path(tmp) / "data.bk"
        data.write_text(data_text(spec))
        lmp = open_lammps()
        lmp.commands_string(setup_text(spec, DeckOptions(
            data=str(data), stress=None, blocks=None, psi=None, phase=None, thermo_every=10**7,
            path=path,
            energy=True)))

        def ledger():
            return {k: lmp.extract_fix(SUBSTRATE_FIX, LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR,
                                       SLOTS[k]) for k in (*LEDGER_SLOTS, "breaks_total")}
        lmp.command("run 0")
        a = ledger()
        lmp.command(f"run {int(round(t_end / spec.dt))}")
        b = ledger()
        lmp.close()
    res, work, _ = balance(a, b)
    return abs(res) / work, int(b["breaks_total"])


if __name__ == "__main__":
    raise SystemExit(main())
