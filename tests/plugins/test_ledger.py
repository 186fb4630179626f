"""The energy ledger inside the plugin (fix bk/substrate ... energy; docs/model.md "Energy"), on
both integration paths: every term against the NumPy reference integrator (tests/reference.py,
which keeps the same accounting), the trajectory unchanged to the bit by keeping it, the balance
closed on 1 and 2 ranks and across a restart file, and its residual falling as dt^2 where no
contact breaks.
"""

from __future__ import annotations

import subprocess

import numpy as np
import pytest

from bkflow.lammps.deck import SLOTS, DeckOptions, continue_text, data_text, setup_text
from bkflow.lammps.plugin import open_lammps
from bkflow.model.lattice import contact_start
from bkflow.model.params import RunSpec
from bkflow.observables.catalogue import balance
from bkflow.observables.reduced import LEDGER_SLOTS
from tests.reference import Reference
from tests.support import RULE_COVER, global_vector, lively_start, tool, unwrapped_state

pytestmark = pytest.mark.usefixtures("lammps")

STEPS = 2000
PRELOAD = 1.2
PATHS = ("general", "fused")


def _lammps(spec, lattice, v0, workdir, path, energy=True, preload=PRELOAD):
    data = workdir / "data.bk"
    data.write_text(data_text(spec, lattice, v0))
    lmp = open_lammps()
    lmp.commands_string(setup_text(spec, DeckOptions(data=str(data), stress=None, blocks=None,
                                                     psi=None, phase=None,
                                                     thermo_every=10**6, path=path,
                                                     energy=energy)))
    if preload:
        lmp.command(f"displace_atoms all move {-preload!r} 0 0")
    return lmp


def _ledger(lmp) -> dict[str, float]:
    return {k: global_vector(lmp, k) for k in LEDGER_SLOTS}


def _residual(a: dict, b: dict) -> tuple[float, float]:
    """(residual, plate work) of the balance between two ledgers."""
    residual, work, _ = balance(a, b)
    return residual, work


@pytest.mark.parametrize("path", PATHS)
@pytest.mark.parametrize("mode, damping", RULE_COVER)
def test_every_term_matches_the_reference(path, mode, damping, workdir):
    spec = RunSpec(phi=10.0, Lx=8, Ly=3, seed=3, contact_rule=mode, damping=damping)
    lattice, x0, v0 = lively_start(spec)
    lmp = _lammps(spec, lattice, v0, workdir, path)
    lmp.command("run 0")
    start = _ledger(lmp)
    lmp.command(f"run {STEPS}")
    got = _ledger(lmp)
    lmp.close()

    ref = Reference(lattice.box, lattice.bonds, spec.k_b, spec.dt, k_d=lattice.k_d, V_d=spec.V_d,
                    k_e=spec.k_e, f_max=spec.friction_threshold, mode=mode, gamma=spec.gamma,
                    mass=spec.mass, damping=damping)
    s = ref.start(x0 - [PRELOAD, 0.0], v0, anchor=x0)
    want0 = ref.ledger(s)
    ref.step(s, STEPS)
    want = ref.ledger(s)
    assert s.breaks > 0 and want.diss_break > 0 and want.diss_damp > 0 and want.work_plate > 0
    names = {"e_bond": "bond", "e_drive": "drive", "e_contact": "contact",
             "e_kinetic": "kinetic", "work": "work_plate", "diss_break": "diss_break",
             "diss_damp": "diss_damp"}
    for slot, field in names.items():
        assert got[slot] == pytest.approx(getattr(want, field), rel=1e-8, abs=1e-10), slot
        if slot.startswith("e_"):
            assert start[slot] == pytest.approx(getattr(want0, field), rel=1e-12), slot
        else:
            assert start[slot] == 0.0, slot


def test_without_energy_the_running_sums_are_not_kept(workdir):
    """The energies of the step are there on request; the sums only with `energy` (NaN)."""
    spec = RunSpec(phi=10.0, Lx=6, Ly=3, seed=1)
    lattice, _, v0 = lively_start(spec)
    lmp = _lammps(spec, lattice, v0, workdir, "general", energy=False)
    lmp.command("run 100")
    got = _ledger(lmp)
    lmp.close()
    assert all(np.isnan(got[k]) for k in ("work", "diss_break", "diss_damp"))
    assert got["e_kinetic"] > 0 and got["e_drive"] > 0


@pytest.mark.parametrize("path", PATHS)
def test_keeping_the_ledger_changes_no_bit_of_the_trajectory(path, workdir):
    spec = RunSpec(phi=10.0, Lx=8, Ly=3, seed=3, start="random")
    lattice, _, v0 = lively_start(spec)
    runs = []
    for energy in (False, True):
        lmp = _lammps(spec, lattice, v0, workdir, path, energy=energy)
        lmp.command(f"run {STEPS}")
        runs.append(unwrapped_state(lmp))
        runs[-1]["breaks"] = global_vector(lmp, "breaks_total")
        lmp.close()
    off, on = runs
    assert on["breaks"] == off["breaks"] > 0
    for key in ("x", "v", "state"):
        assert np.array_equal(on[key], off[key]), key


def _deck_ledger_line() -> str:
    return "print \"LEDGER " + " ".join(f"${{l{k}}}" for k in LEDGER_SLOTS) + "\"\n"


def _ledger_vars() -> str:
    return "".join(f"variable l{k} equal f_bk[{SLOTS[k] + 1}]\n" for k in LEDGER_SLOTS)


def _read_ledgers(log: str) -> list[dict]:
    rows = [line.split()[1:] for line in log.splitlines() if line.startswith("LEDGER ")]
    return [dict(zip(LEDGER_SLOTS, map(float, r))) for r in rows]


def test_the_balance_closes_on_one_and_two_ranks_and_across_a_restart(workdir):
    """`lmp -in` on 1 and 2 ranks (general path, atoms crossing between the ranks), and the
    same run in two halves joined by a restart file: the sums over ranks and the sums read back
    from the restart file give one ledger, and its residual is the integrator's."""
    spec = RunSpec(phi=10.0, Lx=12, Ly=3, seed=5, start="random")
    lattice, _, v0 = lively_start(spec)
    (workdir / "data.bk").write_text(data_text(spec, lattice, v0))
    opts = DeckOptions(stress=None, blocks=None, psi=None, phase=None, thermo_every=500,
                       path="general", energy=True)
    half = STEPS // 2
    whole = (setup_text(spec, opts) + _ledger_vars() + "displace_atoms all move -1.2 0 0\n"
             + "run 0\n" + _deck_ledger_line() + f"run {STEPS}\n" + _deck_ledger_line())
    first = (setup_text(spec, opts) + _ledger_vars() + "displace_atoms all move -1.2 0 0\n"
             + "run 0\n" + _deck_ledger_line() + f"run {half}\nwrite_restart half.restart\n")
    second = (continue_text(spec, "half.restart", opts) + _ledger_vars()
              + f"run {STEPS - half}\n" + _deck_ledger_line())
    lmp, ledgers = tool("lmp"), {}
    for name, deck, ranks in (("one", whole, 1), ("two", whole, 2), ("first", first, 1),
                              ("second", second, 2)):
        (workdir / f"in.{name}").write_text(deck)
        cmd = [lmp, "-in", f"in.{name}", "-log", f"log.{name}", "-screen", "none"]
        if ranks > 1:
            cmd = [tool("mpirun"), "-np", str(ranks)] + cmd
        subprocess.run(cmd, check=True, cwd=workdir, timeout=300)
        ledgers[name] = _read_ledgers((workdir / f"log.{name}").read_text())
    start, end = ledgers["one"]
    assert end["diss_break"] > 0 and end["work"] > 0
    residual, work = _residual(start, end)
    # the reference's residual on the same trajectory: the scheme's error, not the ledger's
    # (the lively start's fast breaks make it 0.6% of the work here)
    ref = Reference(lattice.box, lattice.bonds, spec.k_b, spec.dt, k_d=lattice.k_d,
                    V_d=spec.V_d, k_e=spec.k_e, f_max=spec.friction_threshold,
                    mode=spec.contact_rule, gamma=spec.gamma, mass=spec.mass)
    x0 = lively_start(spec)[1]  # its unwrapped start positions
    dr0 = np.column_stack([contact_start(spec), np.zeros(spec.N)])
    s = ref.start(x0 - [1.2, 0.0], v0, anchor=x0, dr=dr0)
    a = ref.ledger(s)
    b = ref.ledger(ref.step(s, STEPS))
    assert residual == pytest.approx(b.residual(a), rel=1e-6)
    assert abs(residual) < 1e-2 * work
    for other in (ledgers["two"][1], ledgers["second"][0]):
        for k in LEDGER_SLOTS:
            assert other[k] == pytest.approx(end[k], rel=1e-9, abs=1e-12), k
    assert ledgers["first"][0] == start


@pytest.mark.parametrize("path", PATHS)
def test_the_residual_falls_as_dt_squared_where_no_contact_breaks(path, workdir):
    """Bonds, drive, contacts that never break, implicit damping: halving dt divides the
    residual by 4 (the second-order scheme's energy error), on either path."""
    residuals = []
    for c in (0.1, 0.05):
        spec = RunSpec(phi=10.0, Lx=8, Ly=3, seed=2, dt_factor=c, mu_s=1e6)
        lattice, _, v0 = lively_start(spec)
        lmp = _lammps(spec, lattice, v0, workdir, path)
        lmp.command("run 0")
        a = _ledger(lmp)
        lmp.command(f"run {int(round(40.0 / spec.dt))}")
        b = _ledger(lmp)
        assert global_vector(lmp, "breaks_total") == 0
        lmp.close()
        r, work = _residual(a, b)
        residuals.append(abs(r) / work)
    assert residuals[0] / residuals[1] == pytest.approx(4.0, rel=0.05), residuals


def test_the_fused_ledger_goes_on_across_a_restart_file(workdir):
    """The fused path in two halves joined by a restart file keeps the uninterrupted run's
    ledger: the running sums come back from the file, the energies from the exact state."""
    spec = RunSpec(phi=10.0, Lx=8, Ly=4, seed=5, start="random")
    lattice, _, v0 = lively_start(spec)
    (workdir / "data.bk").write_text(data_text(spec, lattice, v0))
    opts = DeckOptions(stress=None, blocks=None, psi=None, phase=None, thermo_every=500,
                       path="fused", energy=True)
    half = STEPS // 2
    whole = (setup_text(spec, opts) + _ledger_vars() + f"run {STEPS}\n" + _deck_ledger_line())
    first = setup_text(spec, opts) + f"run {half}\nwrite_restart half.restart\n"
    second = (continue_text(spec, "half.restart", opts) + _ledger_vars()
              + f"run {STEPS - half}\n" + _deck_ledger_line())
    ledgers = {}
    for name, deck in (("whole", whole), ("first", first), ("second", second)):
        (workdir / f"in.{name}").write_text(deck)
        subprocess.run([tool("lmp"), "-in", f"in.{name}", "-log", f"log.{name}", "-screen",
                        "none"], check=True, cwd=workdir, timeout=300)
        ledgers[name] = _read_ledgers((workdir / f"log.{name}").read_text())
    (end,), (after,) = ledgers["whole"], ledgers["second"]
    assert end["diss_break"] > 0
    for k in LEDGER_SLOTS:
        assert after[k] == pytest.approx(end[k], rel=1e-12, abs=1e-15), k


def test_fix_bk_stress_header_names_the_ledger_columns():
    """fix bk/stress ``energy`` writes stress.csv's header from its own text (plugins/
    fix_bk_stress.cpp): it names the same columns in the same order as
    bkflow.observables.reduced.LEDGER_COLUMNS, which the readers expect (after t, sigma_x);
    LEDGER_SLOTS are those columns but the breaks."""
    import re
    from pathlib import Path

    from bkflow.observables.reduced import LEDGER_COLUMNS

    source = (Path(__file__).resolve().parents[2] / "plugins" / "fix_bk_stress.cpp").read_text()
    code = re.sub(r"/\*.*?\*/", "", source, flags=re.S)  # the code, not its comment
    # every string of the code, C's adjacent literals joined: the header is the one of t,
    # sigma_x and more
    strings = ["".join(re.findall(r'"([^"]*)"', run))
               for run in re.findall(r'(?:"[^"\n]*"\s*)+', code)]
    headers = [s for s in strings if s.startswith("t,sigma_x,")]
    assert headers == [",".join(("t", "sigma_x", *LEDGER_COLUMNS)) + "\\n"], headers
    assert LEDGER_COLUMNS == ("breaks", *LEDGER_SLOTS)
