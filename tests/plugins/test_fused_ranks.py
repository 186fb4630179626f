"""The fused path on several MPI ranks (plugins/fix_bk_fused.cpp, "Ranks"): each rank holds a
block of lattice rows and trades its boundary rows with its neighbours every step.

One fused rank and K fused ranks (K = 2, 3, 4; 3 is oversubscribed here, for correctness only)
give the same bits: the trajectory, the per-atom state, the global outputs and the stress
series, on every contact rule, damping scheme and start, in chunks and across a restart
written on one number of ranks and read on another. The log says the decomposition, meta.json
the ranks; what the path cannot do on several ranks is refused or falls back, and says why.
"""

import re
import subprocess

import pytest

from bkflow.lammps.deck import PROCESSORS, DeckOptions, continue_text, data_text, setup_text
from bkflow.lammps.plugin import block_rows
from bkflow.model.params import RunSpec
from tests.support import lively_start, tool

pytestmark = pytest.mark.usefixtures("lammps")

# 8 x 7: blocks of 7 rows on 2, 3, 4 ranks are uneven (3+4, 2+2+3, 1+2+2+2), and on 4 ranks a
# block is one row; on 2 ranks the rank below is the rank above (test_paths.py: a 12 x 3
# lattice on 2 ranks, a block of one row with the same rank on both sides)
SIZE = (8, 7)
STEPS = 600
PRELOAD = 1.2
# f_bk[1..6]: the per-atom state (anchor, contact displacement, half-step velocity)
FINAL = ("write_dump all custom final.txt id x y xu yu vx vy ix iy f_bk[1] f_bk[2] f_bk[3] "
         "f_bk[4] f_bk[5] f_bk[6] modify sort id format float %.17g\n")
OUTPUTS = ("thermo_style custom step f_bk[1] f_bk[2] f_bk[3] f_bk[5] f_bk[7] f_bk[8] f_bk[9] "
           "f_bk[10] f_bk[11] f_bk[12] f_bk[13] pe\nthermo_modify format float %.17g\n")


def _mpirun(workdir, ranks, deck="in.bk", log="log.lammps"):
    cmd = [tool("lmp"), "-in", deck, "-log", log, "-screen", "none"]
    if ranks > 1:
        cmd = [tool("mpirun"), "-np", str(ranks)] + cmd
    return subprocess.run(cmd, cwd=workdir, capture_output=True, text=True, timeout=300)


def _spec(**kw):
    size = kw.pop("size", SIZE)
    kw.setdefault("scene", "series")   # the raw stress series, compared bit for bit
    return RunSpec(phi=kw.pop("phi", 10.0), Lx=size[0], Ly=size[1], seed=kw.pop("seed", 3), **kw)


def _deck(spec, workdir, steps=STEPS, chunks=3, tail=FINAL):
    """a lively start on the default path (integrate), in chunks as the engine runs: rows at
    their sites (y = iy + 1/2, half a row from the ranks' cuts) and every particle near the x
    edge, drifting across it"""
    lattice, _, v0 = lively_start(spec, offset=(0.495, 0.0), drift=(0.2, 0.0))
    (workdir / "data.bk").write_text(data_text(spec, lattice, v0))
    deck = setup_text(spec, DeckOptions(thermo_every=steps // chunks // 2, path="auto",
                                        stress="stress.csv",
                                        energy=True, phase=None))
    deck = deck.replace("\nrun ", "\n# run ")
    deck += f"\ndisplace_atoms all move {-PRELOAD!r} 0 0\n" + OUTPUTS
    for k in range(chunks):
        deck += f"run {steps // chunks} pre {'yes' if k == 0 else 'no'} post no\n"
    return deck + tail


def _unwrapped(final: str) -> list[list[str]]:
    """The rows of FINAL's dump without the wrapped positions and image flags (x y, ix iy)."""
    rows = [line.split() for line in final.splitlines()[9:]]
    return [[c for k, c in enumerate(r) if k not in (1, 2, 7, 8)] for r in rows]


def _run(workdir, ranks, deck):
    """(final dump, stress.csv, the thermo rows of the log) of ``deck`` on ``ranks`` ranks"""
    (workdir / "in.bk").write_text(deck)
    for name in ("final.txt", "stress.csv"):
        (workdir / name).unlink(missing_ok=True)
    proc = _mpirun(workdir, ranks, log=f"log.{ranks}")
    log = (workdir / f"log.{ranks}").read_text()
    assert proc.returncode == 0, log[-2000:]
    assert "bk/substrate fused:" in log and "general path" not in log
    thermo = [line for line in log.splitlines()
              if len(line.split()) == 13 and line.split()[0].isdigit()]
    stress = (workdir / "stress.csv").read_text() if (workdir / "stress.csv").exists() else ""
    return (workdir / "final.txt").read_text(), stress, thermo, log


#: stress.csv's columns that are the same bits on any number of ranks: all but the ledger's
#: running sums (work, dissipation), which each rank keeps for its atoms and are summed
SAME_BITS = ("t", "sigma_x", "breaks", "e_bond", "e_drive", "e_contact", "e_kinetic")


def _same_stress(got, want):
    """stress.csv: t, sigma_x, the breaks and the step's energies the same bits; the ledger's
    running sums, summed over ranks, to rounding"""
    rows_got = [r.split(",") for r in got.splitlines()]
    rows_want = [r.split(",") for r in want.splitlines()]
    assert len(rows_got) == len(rows_want) > 10 and rows_got[0] == rows_want[0]
    exact = [i for i, name in enumerate(rows_want[0]) if name in SAME_BITS]
    assert len(exact) == len(SAME_BITS), rows_want[0]
    for a, b in zip(rows_got[1:], rows_want[1:]):
        assert [a[i] for i in exact] == [b[i] for i in exact]
        assert [float(x) for x in a] == pytest.approx([float(x) for x in b], rel=1e-12,
                                                      abs=1e-12)


# every contact rule with both damping schemes, and every start
RULES = [("reset", "implicit", "synchronized"), ("reset", "half", "random"),
         ("reset/step", "implicit", "stratified"), ("reset/step", "half", "partial"),
         ("coulomb", "implicit", "random"), ("coulomb", "half", "synchronized")]


@pytest.mark.parametrize("mode, damping, start", RULES)
def test_three_ranks_give_the_bits_of_one(mode, damping, start, workdir):
    spec = _spec(contact_rule=mode, damping=damping, start=start)
    deck = _deck(spec, workdir)
    one = _run(workdir, 1, deck)
    three = _run(workdir, 3, deck)
    assert "3 ranks, blocks of rows 0-1 | 2-3 | 4-6" in three[3]
    assert three[0] == one[0]          # every column of every particle, to the last digit
    _same_stress(three[1], one[1])
    # the global outputs: the same bits (f_bk[1..10]: sigma_x, the breaks, the step's energies)
    # but the ledger's running sums, which each rank keeps for its atoms: to rounding
    rows1 = [r.split() for r in one[2]]
    rows3 = [r.split() for r in three[2]]
    assert len(rows1) == len(rows3) > 3
    for a, b in zip(rows1, rows3):
        assert a[:9] == b[:9]
        assert [float(x) for x in b[5:]] == pytest.approx([float(x) for x in a[5:]],
                                                          rel=1e-12, abs=1e-12)
    breaks = float(rows1[-1][3])    # f_bk[3]: breaks since the fix was defined
    assert breaks > 0, "no contact broke: the test would not see the contact rule"


@pytest.mark.parametrize("ranks", [2, 4])
def test_two_and_four_ranks_give_the_bits_of_one(ranks, workdir):
    spec = _spec(seed=7, start="random")
    deck = _deck(spec, workdir)
    one = _run(workdir, 1, deck)
    many = _run(workdir, ranks, deck)
    assert many[0] == one[0]
    _same_stress(many[1], one[1])
    assert f"{ranks} ranks, blocks of rows " + " | ".join(
        f"{a}-{b}" for a, b in block_rows(SIZE[1], ranks)) in many[3]


def test_a_wide_lattice_with_several_row_blocks_per_rank(workdir):
    """64 x 21 on 3 ranks: 7 rows a rank, the interior rows in the pipeline's blocks of 4 rows
    (256 particles), so the step advances rows block after block between the halo's start and
    its wait"""
    spec = _spec(size=(64, 21), seed=13, start="random", contact_rule="coulomb")
    deck = _deck(spec, workdir, steps=300)
    one = _run(workdir, 1, deck)
    three = _run(workdir, 3, deck)
    assert "3 ranks, blocks of rows 0-6 | 7-13 | 14-20" in three[3]
    assert three[0] == one[0]
    _same_stress(three[1], one[1])


@pytest.mark.parametrize("first, then", [(1, 3), (4, 2), (3, 1)])
def test_a_restart_read_on_other_ranks_follows_one_run(first, then, workdir):
    """written on ``first`` ranks half-way, continued on ``then``: the uninterrupted run's bits"""
    spec = _spec(seed=11, start="random", contact_rule="reset/step")
    whole = _run(workdir, 1, _deck(spec, workdir, chunks=2))
    half = _deck(spec, workdir, steps=STEPS // 2, chunks=1, tail="write_restart half.restart\n")
    _run_ok = _mpirun
    (workdir / "in.bk").write_text(half)
    assert _run_ok(workdir, first).returncode == 0
    cont = continue_text(spec, "half.restart", DeckOptions(data="", thermo_every=50,
                                                            path="auto", energy=True,
                                                            phase=None, stress="stress.csv"))
    cont = cont.replace("\nrun ", "\n# run ") + "\n" + OUTPUTS
    cont += f"run {STEPS // 2} pre yes post no\n" + FINAL
    (workdir / "stress.csv").unlink(missing_ok=True)
    resumed = _run(workdir, then, cont)
    # every column but the wrapped positions and image flags, to the last digit: the restart's
    # setup wraps an atom on the box's edge (x and its flag) a few steps before the
    # uninterrupted run's next neighbour check does, the same unwrapped position
    assert _unwrapped(resumed[0]) == _unwrapped(whole[0])


@pytest.mark.parametrize("how", ["moved", "kicked"])
def test_a_particle_that_strays_to_another_rank_stops_the_run(how, workdir):
    """particle 17 (row 2, the top row of rank 0's block 0-2) moved past the cut at y = 3
    before the run (found when the run starts), or kicked across it during the run (found at
    the next reneighbouring; at the step the test was made for, so that particle 17 is the
    first to cross)"""
    spec = _spec(dt_factor=0.1)
    deck = _deck(spec, workdir, tail="")
    move = ("displace_atoms stray move 0 0.7 0" if how == "moved"
            else "velocity stray set 0.0 8.0 0.0")
    deck = deck.replace("\ndisplace_atoms", f"\ngroup stray id 17\n{move}\ndisplace_atoms", 1)
    (workdir / "in.bk").write_text(deck)
    proc = _mpirun(workdir, 2)
    assert proc.returncode != 0
    out = (workdir / "log.lammps").read_text()
    if how == "moved":
        assert ("fused on 2 ranks needs every particle within a quarter row of its row's line "
                "y = ylo + (iy + 1/2) yprd / Ly" in out)
        assert "particle 17 (row 2) is 0.70 rows off it" in out
    else:
        assert "particle 17 (lattice row 2) left the sub-domain of its rank's rows" in out
        assert "run it on one rank, or on the general path" in out
    assert "terminate called" not in proc.stderr


def test_a_balance_before_run_pre_no_is_refused(workdir):
    """`balance` moves atoms between ranks; `run ... pre no` (no setup, no exchange) must not
    go on with the fix writing into other atoms: it stops, saying to run with `pre yes`; with
    `pre yes` the run goes on with one rank's bits"""
    spec = _spec(seed=5)
    head = _deck(spec, workdir, steps=200, chunks=1, tail="balance 1.0 y uniform\n")
    for pre, ok in (("no", False), ("yes", True)):
        (workdir / "in.bk").write_text(head + f"run 30 pre {pre}\n" + FINAL)
        proc = _mpirun(workdir, 2)
        log = (workdir / "log.lammps").read_text()
        assert (proc.returncode == 0) == ok, log[-1500:]
        if not ok:
            assert ("is not where the fix holds it (a command between runs moved atoms between "
                    "ranks, e.g. `balance`, and `run ... pre no` skipped the exchange that puts "
                    "them back): run with `pre yes`") in log
    two = (workdir / "final.txt").read_text()
    (workdir / "in.bk").write_text(head.replace("balance 1.0 y uniform\n", "")
                                   + "run 30 pre yes\n" + FINAL)
    assert _mpirun(workdir, 1).returncode == 0
    assert (workdir / "final.txt").read_text() == two


def test_what_several_ranks_cannot_do_is_refused_or_falls_back(workdir):
    spec = RunSpec(phi=10.0, Lx=12, Ly=3, seed=5)
    (workdir / "data.bk").write_text(data_text(spec))
    column = setup_text(spec, DeckOptions(stress=None, blocks=None, psi=None, phase=None,
                                          path="fused"))
    row = column.replace(PROCESSORS, "processors      2 1 1")
    for deck, ranks, why in [
            (row, 2, "on 2 ranks needs them in one column, each holding a block of lattice "
                     "rows: add `processors 1 * 1` before read_data (the grid is 2x1x1)"),
            (column, 4, "on 4 ranks needs at least one lattice row per rank (the lattice has 3)"
                        ": run on at most 3 ranks")]:
        (workdir / "in.bk").write_text(deck.replace("\nrun ", "\n# run ") + "\nrun 10\n")
        proc = _mpirun(workdir, ranks)
        assert proc.returncode != 0 and why in (workdir / "log.lammps").read_text()
        assert "terminate called" not in proc.stderr
        # integrate: the general path, with the same reason in the log
        (workdir / "in.bk").write_text(deck.replace(" fused", " integrate")
                                       .replace("\nrun ", "\n# run ") + "\nrun 10\n")
        proc = _mpirun(workdir, ranks)
        log = (workdir / "log.lammps").read_text()
        assert proc.returncode == 0, log[-1500:]
        assert f"the general path on {ranks} rank(s) (the fused path {why})" in log


def test_after_unfix_the_general_path_runs_on_the_same_ranks(workdir):
    """The fused fix lowers the ghost cutoff to 0.1 (it trades its rows itself); unfix gives
    the deck's cutoff back, so the general path defined next finds its bond partners as ghosts
    (it stopped with its partner-missing error before)"""
    spec = RunSpec(phi=10.0, Lx=12, Ly=4, seed=5)
    (workdir / "data.bk").write_text(data_text(spec))
    deck = setup_text(spec, DeckOptions(stress=None, blocks=None, psi=None, phase=None,
                                        path="fused"))
    keep = [ln for ln in deck.splitlines()
            if not ln.startswith(("fix             slips", "fix             fronts", "dump",
                                  "run "))]
    fused = next(ln for ln in keep if ln.startswith("fix ") and " bk/substrate " in ln)
    general = fused.replace("fix             bk ", "fix             bk2 ").replace(" fused", "")
    deck = "\n".join(keep) + (f"\nrun 50\ncomm_modify cutoff 12.5\nrun 10\nunfix bk\n"
                               f"info communication out log\nfix nve all nve\n{general}\n"
                               "fix 2d all enforce2d\nthermo_style custom step f_bk2[1]\n"
                               "run 50\n")
    (workdir / "in.bk").write_text(deck)
    proc = _mpirun(workdir, 2)
    log = (workdir / "log.lammps").read_text()
    assert proc.returncode == 0, log[-1500:]
    assert "2 ranks, blocks of rows 0-1 | 2-3" in log
    assert "comm_modify cutoff 11 -> 0.1" in log
    # the deck's latest cutoff is the one given back (set between the runs)
    assert "comm_modify cutoff 12.5 -> 0.1" in log
    assert re.search(r"Communication cutoff .*= 12\.5\b", log), log
    assert log.count("Loop time") == 3


def test_a_layer_moved_after_integrate_chose_is_told_to_take_the_general_path(workdir):
    """`integrate` chooses the path when the fix is defined; a layer moved off its rows' lines
    before the first run then fails the fused path's check on two ranks, and the message says
    why the path was the fused one and what runs the same trajectory: the general path (the
    fix keeps the positions at its definition, so defining it after the move is another run)"""
    spec = RunSpec(phi=10.0, Lx=12, Ly=4, seed=5)
    (workdir / "data.bk").write_text(data_text(spec))
    deck = setup_text(spec, DeckOptions(stress=None, blocks=None, psi=None, phase=None,
                                        path="auto"))
    deck = deck.replace("\nrun ", "\n# run ") + "\ndisplace_atoms all move 0 0.3 0\n"
    deck += "thermo_style custom step f_bk[1]\nthermo_modify format float %.17g\nrun 20\n"
    (workdir / "in.bk").write_text(deck)
    proc = _mpirun(workdir, 2)
    log = (workdir / "log.lammps").read_text()
    assert proc.returncode != 0
    assert "is 0.30 rows off it; `integrate` chose the fused path when the fix was defined" \
        in log
    assert "use the general path, the same trajectory (drop `integrate`, add fix nve and fix " \
        "enforce2d), or run it on one rank" in log

    def last_row(text):
        return [ln for ln in text.splitlines() if ln.split()[:1] == ["20"]][-1]

    # what the message says: one rank, and the general path on two, run the same steps
    assert _mpirun(workdir, 1).returncode == 0
    one = last_row((workdir / "log.lammps").read_text())
    fix = next(ln for ln in deck.splitlines() if ln.startswith("fix ") and " bk/substrate " in ln)
    general = deck.replace(fix, "fix nve all nve\n" + fix.replace(" integrate", "")
                           + "\nfix 2d all enforce2d")
    (workdir / "in.bk").write_text(general)
    proc = _mpirun(workdir, 2)
    log = (workdir / "log.lammps").read_text()
    assert proc.returncode == 0, log[-1500:]
    assert "fused" not in log.split("displace_atoms")[-1]
    got = last_row(log).split()
    assert float(got[1]) == pytest.approx(float(one.split()[1]), rel=1e-9)  # a sum over ranks


def test_block_rows_is_the_plugins_division():
    assert block_rows(7, 1) == [(0, 6)]
    assert block_rows(7, 3) == [(0, 1), (2, 3), (4, 6)]
    assert block_rows(60, 4) == [(0, 14), (15, 29), (30, 44), (45, 59)]
    with pytest.raises(ValueError):
        block_rows(3, 4)


def test_the_scaling_model_fit_recovers_known_parameters():
    """benchmarks/report/scaling_model.py: two-rank times made from a known model give its
    parameters back (exactly without noise; with 1% noise, a 64-rank prediction within 10%), and
    its predictions follow from it"""
    import numpy as np

    from benchmarks.report.scaling_model import Model, fit, stops, strong

    sizes = [(60, 900), (120, 3600), (240, 14400), (480, 57600), (960, 230400)]
    n = tuple(float(N) for _, N in sizes)
    c = (7e-9, 7.5e-9, 7e-9, 9.5e-9, 15e-9)    # per atom-step: caches, then memory
    true = Model(n=n, c=c, kappa=0.08, lam=1.5e-6, bw=4e9)
    assert true.compute(900) == pytest.approx(900 * 7e-9)
    assert true.compute(10**7) == pytest.approx(10**7 * 15e-9)    # held beyond the range
    exact = [(lx, N, true.step(N, lx, 1), true.step(N, lx, 2), true.halo(lx))
             for lx, N in sizes]
    got = fit(exact)
    assert got.c == pytest.approx(c, rel=1e-12)
    for name in ("kappa", "lam", "bw"):
        assert getattr(got, name) == pytest.approx(getattr(true, name), rel=1e-6), name
    rng = np.random.default_rng(1)
    noisy = [(lx, N, t1, t2 * (1 + 0.01 * rng.standard_normal()), h)
             for lx, N, t1, t2, h in exact]
    got = fit(noisy)
    assert got.step(10**6, 2000, 64) == pytest.approx(true.step(10**6, 2000, 64), rel=0.1)
    rows = strong(true, 10**6, 2000, [1, 2, 64])
    assert rows[0][2] == pytest.approx(1.0)
    assert rows[1][1] == pytest.approx(true.compute(5e5) * 1.08 + 2 * 1.5e-6 + 32 * 2000 / 4e9)
    P = stops(true, 10**6, 2000, 256)
    assert P == 256 or true.step(10**6, 2000, P) / true.step(10**6, 2000, 2 * P) <= 1.1
