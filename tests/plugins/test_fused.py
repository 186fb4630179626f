"""The fused path, ``fix bk/substrate ... fused`` (plugins/fix_bk_fused.cpp): one rank, the whole
velocity-Verlet step in one fix on arrays in lattice order.

Against the NumPy reference integrator (tests/reference.py) to 1e-9 for every contact rule and
both damping schemes, from the lively start of test_reference.py and from the random start;
against fix bk/substrate (fix nve + bk/substrate + enforce2d) to ~1e-12; a run in chunks and a
run continued from a restart file equal one run bit for bit; both builds of the kernel (AVX2 and
baseline) give the same bits; the outputs (stress series, slip frames, per-atom output) work
with the settings the fused deck uses; what the fused path cannot do is refused clearly. On
several ranks: tests/plugins/test_fused_ranks.py.
"""

import itertools
import subprocess

import numpy as np
import pytest

from bkflow.lammps.deck import DeckOptions, continue_text, data_text, setup_text
from bkflow.lammps.plugin import open_lammps
from bkflow.model.lattice import Lattice, contact_start
from bkflow.model.params import CONTACT_RULES, DAMPING_MODES, RunSpec
from tests.reference import Reference, step_watching_the_box
from tests.support import global_vector, lammps_with, lively_start, tool, unwrapped_state

pytestmark = pytest.mark.usefixtures("lammps")

STEPS = 2000
PRELOAD = 1.2
def lammps_fused(spec, lattice, velocities, workdir, preload=0.0, fast=False,
                 parts=(True, True, True)):
    """tests.support.lammps_with on the fused path."""
    data = workdir / "data.bk"
    data.write_text(data_text(spec, lattice, velocities))
    lmp = open_lammps()
    lmp.commands_string(setup_text(spec, DeckOptions(data=str(data), stress=None, blocks=None,
                                                     psi=None,
                                                     thermo_every=10**6, drive=parts[0],
                                                     contact=parts[1], damp=parts[2], path="fused",
                                                     fast=fast)))
    if preload:
        lmp.command(f"displace_atoms all move {-preload!r} 0 0")
    return lmp


def finish(lmp, steps=STEPS, chunks=1):
    per = steps // chunks
    for k in range(chunks):
        lmp.command(f"run {per} pre {'yes' if k == 0 else 'no'} post no")
    out = unwrapped_state(lmp)
    out["breaks"] = int(global_vector(lmp, "breaks_total"))
    out["sigma"] = global_vector(lmp, "sigma_x")
    out["rmax"] = global_vector(lmp, "bond_max")
    out["path"] = global_vector(lmp, "path")
    lmp.close()
    return out


def reference_for(spec, lattice):
    return Reference(lattice.box, lattice.bonds, spec.k_b, spec.dt, k_d=lattice.k_d, V_d=spec.V_d,
                     k_e=spec.k_e, f_max=spec.friction_threshold, mode=spec.contact_rule,
                     gamma=spec.gamma, mass=spec.mass, damping=spec.damping)


RULES = list(itertools.product(CONTACT_RULES, DAMPING_MODES))


@pytest.mark.parametrize("mode, damping", RULES)
@pytest.mark.parametrize("phi", [0.1, 10.0, 1000.0])
@pytest.mark.parametrize("size", [(8, 3), (6, 6)])
def test_fused_matches_reference_integrator(size, phi, mode, damping, workdir):
    spec = RunSpec(phi=phi, Lx=size[0], Ly=size[1], seed=3, contact_rule=mode, damping=damping)
    lattice, x0, v0 = lively_start(spec)
    got = finish(lammps_fused(spec, lattice, v0, workdir, preload=PRELOAD))

    ref = reference_for(spec, lattice)
    s, crossed = step_watching_the_box(ref, ref.start(x0 - [PRELOAD, 0.0], v0, anchor=x0),
                                       STEPS)
    assert got["breaks"] > 0
    assert crossed, "no atom crossed the box"
    np.testing.assert_allclose(got["x"], s.x, rtol=0, atol=1e-9)
    np.testing.assert_allclose(got["v"], s.v, rtol=0, atol=1e-9)
    np.testing.assert_allclose(got["state"][:, 2:4], s.dr, rtol=0, atol=1e-9)
    assert got["breaks"] == s.breaks
    expected_sigma = (lattice.k_d * (s.anchor[:, 0] + spec.V_d * s.t - s.x[:, 0])).sum() / spec.N
    assert got["sigma"] == pytest.approx(expected_sigma, abs=1e-9)


@pytest.mark.parametrize("mode", CONTACT_RULES)
@pytest.mark.parametrize("phi", [0.1, 1000.0])
def test_fused_matches_reference_from_the_random_start(phi, mode, workdir):
    spec = RunSpec(phi=phi, Lx=8, Ly=3, seed=3, contact_rule=mode, start="random")
    lattice, x0, v0 = lively_start(spec)
    got = finish(lammps_fused(spec, lattice, v0, workdir, preload=PRELOAD))
    ref = reference_for(spec, lattice)
    dr0 = np.column_stack([contact_start(spec), np.zeros(spec.N)])
    s = ref.step(ref.start(x0 - [PRELOAD, 0.0], v0, anchor=x0, dr=dr0), STEPS)
    assert got["breaks"] == s.breaks > 0
    np.testing.assert_allclose(got["x"], s.x, rtol=0, atol=1e-9)
    np.testing.assert_allclose(got["state"][:, 2:4], s.dr, rtol=0, atol=1e-9)


@pytest.mark.parametrize("parts", [(True, True, True), (False, True, True), (True, False, False),
                                   (False, False, False)])
def test_fused_without_drive_contact_or_damping(parts, workdir):
    """Each part may be left out, as with fix bk/substrate."""
    spec = RunSpec(phi=10.0, Lx=6, Ly=6, seed=2)
    lattice, _, v0 = lively_start(spec)
    a = finish(lammps_with(spec, lattice, v0, workdir, preload=PRELOAD, parts=parts), 500)
    b = finish(lammps_fused(spec, lattice, v0, workdir, preload=PRELOAD, parts=parts), 500)
    np.testing.assert_allclose(b["x"], a["x"], rtol=0, atol=1e-11)
    np.testing.assert_allclose(b["v"], a["v"], rtol=0, atol=1e-11)


@pytest.mark.parametrize("mode, damping", RULES)
@pytest.mark.parametrize("start", ["synchronized", "random"])
def test_fused_follows_fix_bk_substrate(mode, damping, start, workdir):
    """The same trajectory as fix nve + fix bk/substrate + fix enforce2d, to the rounding of the
    order in which the bond forces are summed, with every output of the fix."""
    spec = RunSpec(phi=100.0, Lx=8, Ly=3, seed=4, contact_rule=mode, damping=damping,
                   start=start)
    lattice, _, v0 = lively_start(spec)
    a = finish(lammps_with(spec, lattice, v0, workdir, preload=PRELOAD))
    b = finish(lammps_fused(spec, lattice, v0, workdir, preload=PRELOAD, fast=True))
    assert a["breaks"] == b["breaks"] > 0
    assert a["path"] == 0 and b["path"] in (1, 2, 3)
    for key in ("x", "v", "state"):
        np.testing.assert_allclose(b[key], a[key], rtol=0, atol=1e-11)
    assert b["sigma"] == pytest.approx(a["sigma"], abs=1e-12)
    assert b["rmax"] == pytest.approx(a["rmax"], abs=1e-12)


def test_bond_energy_matches(workdir):
    spec = RunSpec(phi=10.0, Lx=6, Ly=6, seed=2)
    lattice, _, v0 = lively_start(spec)
    energies = []
    for make in (lammps_with, lammps_fused):
        lmp = make(spec, lattice, v0, workdir, preload=PRELOAD)
        lmp.command("run 300")
        energies.append(lmp.numpy.extract_fix("bk", 0, 0))
        lmp.close()
    assert energies[1] == pytest.approx(energies[0], rel=1e-12)


def test_chunks_follow_one_run_bit_for_bit(workdir):
    spec = RunSpec(phi=1.0, Lx=6, Ly=6, seed=2, start="random")
    lattice, _, v0 = lively_start(spec)
    one = finish(lammps_fused(spec, lattice, v0, workdir, preload=PRELOAD, fast=True))
    many = finish(lammps_fused(spec, lattice, v0, workdir, preload=PRELOAD, fast=True),
                  chunks=10)
    assert one["breaks"] == many["breaks"] > 0
    for key in ("x", "v", "state"):
        np.testing.assert_array_equal(many[key], one[key])
    assert many["sigma"] == one["sigma"]


def test_sorted_atoms_follow_the_same_trajectory(workdir):
    """LAMMPS may reorder local atoms (atom_modify sort, with a bin size: without one and no
    pair style it does not sort): the fix keeps its lattice order and writes through the map."""
    spec = RunSpec(phi=10.0, Lx=8, Ly=3, seed=2)
    lattice, _, v0 = lively_start(spec)
    a = finish(lammps_fused(spec, lattice, v0, workdir, preload=PRELOAD, fast=True))
    lmp = lammps_fused(spec, lattice, v0, workdir, preload=PRELOAD, fast=True)
    lmp.command("atom_modify sort 50 1.3")
    lmp.command("run 1000")
    ids = lmp.numpy.extract_atom("id")[:spec.N]
    assert np.any(ids != np.arange(1, spec.N + 1)), "LAMMPS did not sort the atoms"
    b = finish(lmp, STEPS - 1000)
    for key in ("v", "state"):
        np.testing.assert_array_equal(b[key], a[key])
    np.testing.assert_allclose(b["x"], a["x"], rtol=0, atol=1e-12)


def test_settings_do_not_change_the_trajectory(workdir):
    """Positions are mirrored into LAMMPS only when something reads them (fast settings: a
    neighbour check every 50 steps): the state, sigma_x and the breaks are those of the deck
    that mirrors every step, bit for bit."""
    spec = RunSpec(phi=10.0, Lx=8, Ly=3, seed=2)
    lattice, _, v0 = lively_start(spec)
    a = finish(lammps_fused(spec, lattice, v0, workdir, preload=PRELOAD))
    b = finish(lammps_fused(spec, lattice, v0, workdir, preload=PRELOAD, fast=True))
    assert a["breaks"] == b["breaks"] > 0
    for key in ("v", "state"):
        np.testing.assert_array_equal(b[key], a[key])
    np.testing.assert_allclose(b["x"], a["x"], rtol=0, atol=1e-12)  # x + image L: rounding
    assert a["sigma"] == b["sigma"]


@pytest.mark.parametrize("start", ["synchronized", "random"])
def test_restart_continues_bit_for_bit(workdir, start):
    spec = RunSpec(phi=10.0, Lx=6, Ly=6, seed=2, start=start)
    lattice, _, v0 = lively_start(spec)
    whole = finish(lammps_fused(spec, lattice, v0, workdir, preload=PRELOAD, fast=True))

    lmp = lammps_fused(spec, lattice, v0, workdir, preload=PRELOAD, fast=True)
    lmp.command(f"run {STEPS // 2}")
    lmp.command(f"write_restart {workdir / 'half.restart'}")
    lmp.close()
    lmp = open_lammps()
    lmp.commands_string(continue_text(spec, str(workdir / "half.restart"), DeckOptions(
                                                                                       thermo_every=10**6,
                                                                                       path="fused",
                                                                                       fast=True)))
    resumed = finish(lmp, STEPS // 2)
    assert resumed["breaks"] == whole["breaks"] > 0
    for key in ("x", "v", "state"):
        np.testing.assert_array_equal(resumed[key], whole[key])
    assert resumed["sigma"] == whole["sigma"]


@pytest.mark.parametrize("first, then", [("fused", "general"), ("general", "fused")])
def test_restart_files_cross_between_paths(workdir, first, then):
    """Both paths are fix bk/substrate: a restart file of one continues on the other (to the
    rounding of the positions, which only the fused path's restart state holds exactly)."""
    spec = RunSpec(phi=10.0, Lx=6, Ly=6, seed=2)
    lattice, _, v0 = lively_start(spec)
    whole = finish(lammps_with(spec, lattice, v0, workdir, preload=PRELOAD))
    make = lammps_fused if first == "fused" else lammps_with
    lmp = make(spec, lattice, v0, workdir, preload=PRELOAD)
    lmp.command(f"run {STEPS // 2}")
    lmp.command(f"write_restart {workdir / 'half.restart'}")
    lmp.close()
    path = "fused" if then == "fused" else "general"
    deck = continue_text(spec, str(workdir / "half.restart"),
                         DeckOptions(thermo_every=10**6, path=path))
    lmp = open_lammps()
    lmp.commands_string(deck)
    resumed = finish(lmp, STEPS // 2)
    assert resumed["breaks"] == whole["breaks"] > 0
    for key in ("x", "v", "state"):
        np.testing.assert_allclose(resumed[key], whole[key], rtol=0, atol=1e-11)


def _cpu_flags():
    with open("/proc/cpuinfo") as f:
        return set(next(ln for ln in f if ln.startswith("flags")).split(":", 1)[1].split())


#: what BKFLOW_FUSED_ISA caps the kernel at, and f_bk[6] of each build
ISA_CODES = {"baseline": 1, "avx2": 2, "avx512": 3}


def test_every_kernel_build_gives_the_same_bits(workdir, monkeypatch):
    """BKFLOW_FUSED_ISA=baseline runs the kernel built for any x86-64 (what a CPU without AVX2
    runs), =avx2 caps it at AVX2; unset, the best build for the CPU (AVX-512 where it has
    AVX-512F): the same trajectory to the bit, and the log names the build that ran."""
    spec = RunSpec(phi=10.0, Lx=8, Ly=3, seed=2, start="random")
    lattice, _, v0 = lively_start(spec)
    runs, logs = {}, {}
    for isa in ("baseline", "avx2", "auto"):
        if isa == "auto":
            monkeypatch.delenv("BKFLOW_FUSED_ISA", raising=False)
        else:
            monkeypatch.setenv("BKFLOW_FUSED_ISA", isa)
        data = workdir / "data.bk"
        data.write_text(data_text(spec, lattice, v0))
        log = workdir / f"log.{isa}"
        lmp = open_lammps(log=log)
        lmp.commands_string(setup_text(spec, DeckOptions(data=str(data), stress=None,
                                                         blocks=None, psi=None,
                                                         thermo_every=10**6, path="fused",
                                                         fast=True)))
        lmp.command(f"displace_atoms all move {-PRELOAD!r} 0 0")
        runs[isa] = finish(lmp)
        logs[isa] = log.read_text()
    flags = _cpu_flags()
    best = "avx512" if "avx512f" in flags else "avx2" if "avx2" in flags else "baseline"
    capped = "avx2" if "avx2" in flags else "baseline"
    assert "kernel baseline" in logs["baseline"] and runs["baseline"]["path"] == 1
    assert f"kernel {capped}" in logs["avx2"] and runs["avx2"]["path"] == ISA_CODES[capped]
    assert f"kernel {best}" in logs["auto"] and runs["auto"]["path"] == ISA_CODES[best]
    for isa in ("avx2", "auto"):
        for key in ("x", "v", "state"):
            np.testing.assert_array_equal(runs["baseline"][key], runs[isa][key])


def _scene_deck(spec, workdir, fast_path):
    deck = setup_text(spec, DeckOptions(data="data.bk", stress="stress.csv",
                                        snapshots="snap.lammpstrj", slips="slips.lammpstrj",
                                        path="fused" if fast_path else "general"))
    (workdir / "data.bk").write_text(data_text(spec))
    return deck + f"\nrun {spec.n_steps}\n"


def test_scene_outputs_match_the_general_path(workdir):
    """stress.csv, the slip frames of bk/slips and the snapshots, written by lmp -in from the
    fused deck with its settings, are those of the general path (events at the same steps;
    positions to the %.9g of the dump)."""
    from bkflow.store.formats import read_frames

    spec = RunSpec(phi=10.0, Lx=12, Ly=3, t_end=150, scene="full", seed=3,
                   snapshot_every=5.0)
    out = {}
    for name in ("general", "fused"):
        d = workdir / name
        d.mkdir()
        (d / "in.bk").write_text(_scene_deck(spec, d, name == "fused"))
        proc = subprocess.run([tool("lmp"), "-in", "in.bk", "-screen", "none"], cwd=d,
                              capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
        stress = np.loadtxt(d / "stress.csv", delimiter=",", skiprows=1)
        out[name] = (stress, read_frames(d / "slips.lammpstrj", spec.N),
                     read_frames(d / "snap.lammpstrj", spec.N))
    (sg, slg, sng), (sf, slf, snf) = out["general"], out["fused"]
    np.testing.assert_array_equal(sf[:, 0], sg[:, 0])
    np.testing.assert_allclose(sf[:, 1], sg[:, 1], rtol=0, atol=1e-12)
    assert len(slg) >= 4
    np.testing.assert_array_equal(slf.steps, slg.steps)
    np.testing.assert_allclose(slf.positions, slg.positions, atol=1e-6)
    np.testing.assert_array_equal(snf.steps, sng.steps)
    np.testing.assert_allclose(snf.positions, sng.positions, atol=1e-6)


def _dump_rows(path, ncol):
    rows = [ln.split() for ln in path.read_text().splitlines()]
    return np.array([[float(v) for v in r] for r in rows if len(r) == ncol])


def test_per_atom_output_is_current_when_dumped(workdir):
    """A dump of the fix's per-atom array every 37 steps, with positions mirrored lazily, holds
    what the general path's dump holds."""
    spec = RunSpec(phi=10.0, Lx=8, Ly=3, seed=2)
    lattice, _, v0 = lively_start(spec)
    dumps = {}
    for name, make in (("general", lammps_with), ("fused", lammps_fused)):
        kw = {"fast": True} if name == "fused" else {}
        lmp = make(spec, lattice, v0, workdir, preload=PRELOAD, **kw)
        lmp.command(f"dump d all custom 37 {name}.dump id xu yu vx vy f_bk[3] f_bk[4] f_bk[5] "
                    "f_bk[6]")
        lmp.command("dump_modify d sort id format float %.17g")
        lmp.command("run 740")
        lmp.close()
        dumps[name] = _dump_rows(workdir / f"{name}.dump", 9)
    g, f = dumps["general"], dumps["fused"]
    assert g.shape == f.shape and len(g) == 21 * spec.N
    np.testing.assert_allclose(f, g, rtol=0, atol=1e-11)


def _refusal(workdir, spec, deck, lattice=None):
    (workdir / "data.bk").write_text(data_text(spec, lattice))
    lmp = open_lammps()
    try:
        with pytest.raises(Exception) as err:
            lmp.commands_string(deck + "run 1\n")
    finally:
        lmp.close()
    return str(err.value)


def test_what_the_fused_path_cannot_do_is_refused(workdir):
    spec = RunSpec(phi=10.0, Lx=6, Ly=4, seed=1)
    base = setup_text(spec, DeckOptions(data=str(workdir / "data.bk"), stress=None, blocks=None,
                                        psi=None, path="general"))
    with_nve = "\n".join(ln + " fused" if " bk/substrate " in ln else ln
                          for ln in base.splitlines()) + "\n"
    assert "remove fix nve (nve)" in _refusal(workdir, spec, with_nve)
    from bkflow.model.lattice import lattice_for

    lat = lattice_for(spec)
    only_x = Lattice(lat.Lx, lat.Ly, lat.positions, lat.bonds[0::2], lat.k_d)
    fused_base = setup_text(spec, DeckOptions(data=str(workdir / "data.bk"), stress=None,
                                              blocks=None, psi=None,
                                              path="fused"))
    assert "not a periodic square lattice" in _refusal(workdir, spec, fused_base,
                                                        lattice=only_x)
