"""The automatic choice of the integration path (``fix bk/substrate ... integrate``, the default
deck of bkflow.lammps.deck and of the engine) and what meta.json says of it.

- one rank and bkflow's lattice: the fused path, the very bits of ``fused``;
- anything else (several ranks, a lattice the fused path cannot take): the general path
  integrating by itself, the very bits of fix nve + fix bk/substrate + fix enforce2d;
- the engine records the path that ran, ``--path general`` runs the old deck, both follow the
  same trajectory to rounding, and a short run is one ``run`` command.
"""

import json
import subprocess

import numpy as np
import pytest

from bkflow.lammps.deck import PROCESSORS, DeckOptions, data_text, deck_text, setup_text
from bkflow.lammps.plugin import open_lammps
from bkflow.model.lattice import Lattice, lattice_for
from bkflow.model.params import RunSpec
from bkflow.store.rundir import RunDir
from tests.support import RULE_COVER, global_vector, lively_start, tool, unwrapped_state

STEPS = 1500
PRELOAD = 1.2


def _run(spec, workdir, path, fast=None, lattice=None, velocities=None, steps=STEPS):
    data = workdir / "data.bk"
    data.write_text(data_text(spec, lattice, velocities))
    lmp = open_lammps()
    try:
        lmp.commands_string(setup_text(spec, DeckOptions(data=str(data), stress=None,
                                                         blocks=None, psi=None,
                                                         thermo_every=10**6, path=path, fast=fast)))
        lmp.command(f"displace_atoms all move {-PRELOAD!r} 0 0")
        lmp.command(f"run {steps} post no")
        out = unwrapped_state(lmp)
        out["breaks"] = int(global_vector(lmp, "breaks_total"))
        out["path"] = int(global_vector(lmp, "path"))
    finally:
        lmp.close()
    return out


def _same(a, b):
    assert a["breaks"] == b["breaks"] > 0
    for key in ("x", "v", "state"):
        np.testing.assert_array_equal(a[key], b[key])


@pytest.mark.parametrize("start", ["synchronized", "random"])
def test_integrate_takes_the_fused_path_on_one_rank(lammps, start, workdir):
    spec = RunSpec(phi=100.0, Lx=8, Ly=4, seed=4, start=start)
    lattice, _, v0 = lively_start(spec)
    auto = _run(spec, workdir, "auto", lattice=lattice, velocities=v0)
    fused = _run(spec, workdir, "fused", lattice=lattice, velocities=v0)
    assert auto["path"] in (1, 2, 3) and auto["path"] == fused["path"]
    _same(auto, fused)


@pytest.mark.parametrize("mode, damping", RULE_COVER)
def test_integrate_on_a_lattice_the_fused_path_cannot_take_is_the_general_path(
        lammps, mode, damping, workdir):
    """Bonds along x only: not bkflow's square lattice, so ``integrate`` falls back to the
    general path, which integrates exactly as fix nve + fix enforce2d (the same bits)."""
    spec = RunSpec(phi=10.0, Lx=6, Ly=4, seed=1, contact_rule=mode, damping=damping)
    lat = lattice_for(spec)
    only_x = Lattice(lat.Lx, lat.Ly, lat.positions, lat.bonds[0::2], lat.k_d)
    v0 = 0.3 * np.random.default_rng(3).standard_normal((spec.N, 2))
    auto = _run(spec, workdir, "auto", fast=False, lattice=only_x, velocities=v0)
    general = _run(spec, workdir, "general", lattice=only_x, velocities=v0)
    assert auto["path"] == general["path"] == 0
    _same(auto, general)


def _standalone(workdir, deck: str, ranks: int, tag: str):
    (workdir / "in.bk").write_text(deck)
    cmd = [tool("lmp"), "-in", "in.bk", "-log", f"log.{tag}", "-screen", "none"]
    if ranks > 1:
        cmd = [tool("mpirun"), "-np", str(ranks)] + cmd
    subprocess.run(cmd, check=True, cwd=workdir, timeout=300)
    return np.loadtxt(workdir / "final.txt", skiprows=9), (workdir / f"log.{tag}").read_text()


@pytest.mark.parametrize("rows_at", [0.0, 0.6])
def test_integrate_on_two_ranks(rows_at, lammps, workdir):
    """mpirun -np 2 of the default deck: the fused path with the very bits of one rank's when
    the rows sit between the cuts of its blocks (bkflow's lattices); else (rows moved 0.6 of a
    row) the general path, the very bits of the fix nve deck with the same LAMMPS settings,
    saying why. Either follows the other path to rounding."""
    spec = RunSpec(phi=10.0, Lx=12, Ly=3, seed=5, start="random")
    lattice, _, v0 = lively_start(spec, offset=(0.495, rows_at), drift=(0.2, 0.0))
    (workdir / "data.bk").write_text(data_text(spec, lattice, v0))
    tail = ("displace_atoms all move -1.2 0 0\nrun 2000\n"
            "write_dump all custom final.txt id xu yu vx vy f_bk[3] f_bk[4] "
            "modify sort id format float %.17g\n"
            'print "PATH $(f_bk[6])"\n')
    files = DeckOptions(stress=None, blocks=None, psi=None)
    runs = {}
    for name, path, fast, ranks in (("auto2", "auto", False, 2), ("general2", "general", False, 2),
                                    ("auto1", "auto", None, 1)):
        deck = setup_text(spec, files.replace(thermo_every=500, path=path, fast=fast)) + "\n" + tail
        if path == "general":    # the same process grid as the auto deck's
            deck = deck.replace("atom_modify     map array\n",
                                f"atom_modify     map array\n{PROCESSORS}\n")
        runs[name] = _standalone(workdir, deck, ranks, name)
    assert "on 2 procs" in runs["auto2"][1]
    assert any(f"PATH {k}" in runs["auto1"][1] for k in (1, 2, 3))
    if rows_at == 0.0:
        assert any(f"PATH {k}" in runs["auto2"][1] for k in (1, 2, 3))
        assert "2 ranks, blocks of rows 0-0 | 1-2" in runs["auto2"][1]
        np.testing.assert_array_equal(runs["auto2"][0], runs["auto1"][0])
        np.testing.assert_allclose(runs["general2"][0], runs["auto2"][0], rtol=0, atol=1e-9)
    else:
        assert "PATH 0" in runs["auto2"][1]
        assert ("the general path on 2 rank(s) (the fused path on 2 ranks needs every particle "
                "within a quarter row of its row's line" in runs["auto2"][1])
        np.testing.assert_array_equal(runs["auto2"][0], runs["general2"][0])
        np.testing.assert_allclose(runs["auto1"][0], runs["auto2"][0], rtol=0, atol=1e-9)


def test_the_default_deck_integrates_by_itself():
    spec = RunSpec(phi=10.0)
    deck = deck_text(spec)
    assert " integrate" in deck and "fix             nve" not in deck
    assert "enforce2d" not in deck
    general = deck_text(spec, DeckOptions(path="general"))
    assert "integrate" not in general and "fix             nve all nve" in general
    with pytest.raises(ValueError, match="path must be one of"):
        deck_text(spec, DeckOptions(path="fast"))


def _engine_run(tmp_path, name, path, **kw):
    from bkflow.lammps.engine import run

    spec = RunSpec(phi=100.0, Lx=8, Ly=3, t_end=40.0, scene="series", **kw)
    res = run(spec, tmp_path / name, progress=False, path=path)
    return res.meta, np.column_stack(RunDir(tmp_path / name).read_stress())


def test_engine_records_the_path_and_both_paths_agree(lammps, tmp_path):
    auto_meta, auto = _engine_run(tmp_path, "auto", "auto")
    gen_meta, gen = _engine_run(tmp_path, "general", "general")
    assert auto_meta["engine"]["path"] == "fused"
    assert auto_meta["engine"]["kernel"] in ("avx512", "avx2", "baseline")
    assert auto_meta["engine"]["requested"] == "auto" and auto_meta["engine"]["ranks"] == 1
    assert auto_meta["engine"]["rows_per_rank"] == [[0, 2]]
    assert gen_meta["engine"] == {"requested": "general", "path": "general", "kernel": None,
                                  "ranks": 1, "rows_per_rank": None}
    assert auto_meta["params"] == gen_meta["params"]
    assert " integrate" in (tmp_path / "auto" / "in.bk").read_text()
    assert "fix             nve all nve" in (tmp_path / "general" / "in.bk").read_text()
    # the same equations, summed in another order: equal to rounding over a short run
    assert auto.shape == gen.shape
    np.testing.assert_allclose(auto, gen, rtol=0, atol=1e-9)
    meta = json.loads((tmp_path / "auto" / "meta.json").read_text())
    assert meta["engine"] == auto_meta["engine"]


def test_meta_records_provenance(lammps, tmp_path):
    """The git commit and dirty flag of the checkout bkflow runs from (None from a wheel),
    Python's and the libraries' versions."""
    import platform
    import subprocess

    import numpy
    import scipy

    meta, _ = _engine_run(tmp_path, "p", "auto")
    prov = meta["provenance"]
    assert prov["python"] == platform.python_version()
    assert prov["libraries"]["numpy"] == numpy.__version__
    assert prov["libraries"]["scipy"] == scipy.__version__
    import importlib.metadata as md

    from bkflow.store.provenance import LIBRARIES

    for name in LIBRARIES:  # the fast reading of dist-info names against importlib.metadata
        assert prov["libraries"][name] == md.version(name), name
    from tests.support import ROOT

    head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True,
                          text=True)
    if head.returncode == 0:  # tests run from a checkout (CI's clean clone)
        assert prov["git_commit"] == head.stdout.strip()
        assert isinstance(prov["git_dirty"], bool)
    else:
        assert prov["git_commit"] is None


def test_a_short_run_is_one_run_command(lammps, tmp_path):
    """A fixed-length run shorter than a piece (PIECE_WALL_S) pays for no chunking: one
    ``run`` command; an adaptive run stops at fixed steps whatever the pieces."""
    _engine_run(tmp_path, "short", "auto")
    log = (tmp_path / "short" / "log.lammps").read_text()
    assert sum(1 for ln in log.splitlines() if ln.startswith("run ")) == 1


def test_the_fused_engine_path_can_be_forced_and_refuses_nothing_it_can_do(lammps, tmp_path):
    meta, _ = _engine_run(tmp_path, "fused", "fused", start="random")
    assert meta["engine"]["path"] == "fused"
    with pytest.raises(ValueError, match="path must be one of"):
        _engine_run(tmp_path, "bad", "fastest")
    assert not (tmp_path / "bad").exists()
