"""The event catalogue (bkflow.observables.catalogue): each column on a hand-built case whose answer
is known exactly (a nucleation site and a front of known speed, a rigid block slip whose perimeter
bonds carry the paper's Eq. 2 exactly, a ledger with a known budget), then on a run of the events
scene: its columns, its Parquet copy read back by pyarrow alone, damaged inputs refused (the
first breaks on 1 and 2 ranks: tests/lammps/test_scenes.py)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from bkflow.analysis.summary import analyze
from bkflow.lammps.engine import run
from bkflow.model.lattice import square_lattice
from bkflow.model.params import RunSpec
from bkflow.observables import catalogue
from bkflow.store.rundir import RunDir


def _front(lat, site, speed, dt, step0=1000, reach=6.0):
    """First-break steps of a circular front from lattice site (column, row) at `speed`,
    reaching `reach` lattice units (beyond: no break)."""
    origin = np.array(site) + 0.5
    d = lat.positions - origin
    d -= np.array(lat.box) * np.round(d / np.array(lat.box))
    r = np.hypot(d[:, 0], d[:, 1])
    brk = step0 + np.round(r / speed / dt)
    brk[r > reach] = -1
    return brk


def test_nucleation_site_and_front_speed_of_a_circular_front():
    lat = square_lattice(20, 10)
    dt = 0.001
    brk = _front(lat, (7, 3), speed=2.5, dt=dt)
    x, y, t, v = catalogue.nucleation_and_front(brk, lat.positions, lat.box, dt)
    assert (x, y) == (7.0, 3.0)
    assert t == pytest.approx(1.0)
    assert v == pytest.approx(2.5, rel=2e-3)  # the steps are whole: 1e-3 of a delay of ~1


def test_the_front_is_measured_across_the_periodic_boundary():
    """A front from a corner site reaches the far side first by the boundary."""
    lat = square_lattice(12, 12)
    brk = _front(lat, (0, 11), speed=1.0, dt=0.01, reach=5.0)
    assert brk[lat.Lx - 1] >= 0  # the site's neighbour across x = 0 broke
    x, y, _, v = catalogue.nucleation_and_front(brk, lat.positions, lat.box, 0.01)
    assert (x, y) == (0.0, 11.0) and v == pytest.approx(1.0, rel=1e-2)


def test_nucleation_ties_take_the_lowest_atom_and_no_break_gives_nan():
    lat = square_lattice(6, 4)
    brk = np.full(24, -1.0)
    brk[[9, 5, 17]] = [200, 200, 230]
    x, y, t, v = catalogue.nucleation_and_front(brk, lat.positions, lat.box, 0.1)
    assert (x, y, t) == (5.0, 0.0, 20.0)  # atom 5 = column 5, row 0
    assert np.isfinite(v) and v > 0
    assert np.isnan(catalogue.nucleation_and_front(np.full(24, -1.0), lat.positions, lat.box,
                                                   0.1)).all()
    one = np.full(24, -1.0)
    one[3] = 7
    assert np.isnan(catalogue.nucleation_and_front(one, lat.positions, lat.box, 0.1)[3])


@pytest.mark.parametrize("block, delta", [((slice(0, 20), slice(2, 3)), 0.3),   # a whole row
                                          ((slice(4, 9), slice(1, 4)), 0.2),    # a rectangle
                                          ((slice(6, 7), slice(0, 5)), 0.45),   # a column
                                          ((slice(0, 20), slice(0, 5)), 0.25)])  # everything
def test_a_rigid_block_slip_stores_exactly_eq2_in_its_perimeter(block, delta):
    """From the relaxed lattice, a rectangular block slipping rigidly by delta along x stretches
    its n_y left and right bonds by delta and shears its n_x top and bottom bonds to
    sqrt(1 + delta^2): the bond energy change is the paper's Eq. 2 to rounding, and each size
    and shape column is the block's."""
    k_b = 37.0
    lat = square_lattice(20, 5)
    grid = np.zeros((5, 20), bool)
    grid[block[1], block[0]] = True
    member = grid.ravel()
    x0 = lat.positions.copy()
    x1 = x0.copy()
    x1[member, 0] += delta
    row, per = catalogue.slip_row(x0, x1, lat, 0.01, k_b)
    nx, ny = int(grid.any(axis=0).sum()), int(grid.any(axis=1).sum())
    assert row["n_slipped"] == member.sum() == row["cluster_n"]
    assert row["potency"] == pytest.approx(member.sum() * delta)
    assert row["slip_mean"] == pytest.approx(delta) and row["slip_max"] == pytest.approx(delta)
    assert row["n_clusters"] == 1 and (row["cluster_nx"], row["cluster_ny"]) == (nx, ny)
    want = float(catalogue.eq2_estimate(k_b, nx, ny, delta, 20, 5))
    assert per["eq2_estimate"] == [pytest.approx(want)]
    assert per["bond_change"][0] == pytest.approx(want, rel=1e-9, abs=1e-12)
    if (nx, ny) == (20, 5):
        assert want == 0.0


def test_eq2_and_its_small_slip_limit():
    """Eq. 2 tends to its Eq. 3 (k_b n_y d^2 + k_b n_x d^4 / 4) for d << l, and each
    Theta removes a side as long as the box."""
    d = 1e-3
    assert catalogue.eq2_estimate(2.0, 3, 2, d, 20, 5) == pytest.approx(
        2.0 * 2 * d ** 2 + 2.0 * 3 * d ** 4 / 4, rel=1e-6)
    assert catalogue.eq2_estimate(2.0, 20, 2, 0.5, 20, 5) == pytest.approx(
        2.0 * 20 * (np.sqrt(1.25) - 1) ** 2)
    assert catalogue.eq2_estimate(2.0, 3, 5, 0.5, 20, 5) == pytest.approx(2.0 * 5 * 0.25)


def _ledger(n=6):
    """A ledger whose budget is known: between samples 1 and 4 the plate does 3.0, the bonds
    release 0.5 and the drive 1.0, the contacts take 0.25 more, the kinetic energy gains 0.75,
    breaks dissipate 2.0 and damping 1.5 - 0.1 (a residual of 0.1)."""
    t = np.arange(n, dtype=float)
    L = {"t": t, "breaks": np.array([0, 2, 2, 5, 9, 9.0])}
    L["e_bond"] = np.array([0, 1.0, 1, 1, 0.5, 0.5])
    L["e_drive"] = np.array([0, 2.0, 2, 2, 1.0, 1.0])
    L["e_contact"] = np.array([0, 0.5, 0.5, 0.5, 0.75, 0.75])
    L["e_kinetic"] = np.array([0, 0.25, 0.25, 0.25, 1.0, 1.0])
    L["work"] = np.array([0, 4.0, 5, 6, 7.0, 8.0])
    L["diss_break"] = np.array([0, 0.0, 0, 1, 2.0, 2.0])
    L["diss_damp"] = np.array([0, 0.0, 0, 0, 1.4, 1.4])
    return L


def test_the_energy_columns_of_a_known_budget():
    out = catalogue.energy_rows(_ledger(), [1], [4])
    assert out["breaks"][0] == 7
    assert out["bond_released"][0] == 0.5 and out["drive_released"][0] == 1.0
    assert out["contact_released"][0] == -0.25 and out["kinetic_gain"][0] == 0.75
    assert out["plate_work"][0] == 3.0
    assert out["dissipated_breaks"][0] == 2.0 and out["dissipated_damping"][0] == 1.4
    # residual: 3 + (0.5 + 1 - 0.25) - 0.75 - 3.4 = 0.1, over 3.4 dissipated
    assert out["energy_closure"][0] == pytest.approx(0.1 / 3.4)


def test_the_run_residual_is_taken_over_the_analysed_part():
    L = _ledger()
    # from t = 1 on: work 4, energy change 3.25 - 3.75 = -0.5, dissipated 3.4: (4 + 0.5 - 3.4)/4
    assert catalogue.ledger_residual(L, 1.0) == pytest.approx((4 + 0.5 - 3.4) / 4)
    assert np.isnan(catalogue.ledger_residual(L, 5.0))


def test_typed_counts_and_flags_keep_their_missing_values():
    df = catalogue.typed({"n_slipped": [3.0, np.nan, np.inf], "late": [1, 0, np.nan],
                          "potency": [1.5, np.nan, 2.0]})
    assert str(df["n_slipped"].dtype) == "Int64"
    assert df["n_slipped"].isna().tolist() == [False, True, True]  # inf is no count
    assert str(df["late"].dtype) == "boolean"
    assert df["late"].isna().tolist() == [False, False, True] and df["late"][0]
    assert df["potency"].dtype == float


def test_background_breaks_outside_the_slip_are_left_out():
    """A contact that broke outside the slipping particles (the creeping layer's background)
    before the slip's own first break is not its nucleation site."""
    lat = square_lattice(20, 10)
    brk = _front(lat, (7, 3), speed=2.5, dt=0.001)
    brk[150] = 900  # far away, earlier, not slipping
    within = brk >= 0
    within[150] = False
    x, y, t, v = catalogue.nucleation_and_front(brk, lat.positions, lat.box, 0.001, within)
    assert (x, y, t) == (7.0, 3.0, 1.0) and v == pytest.approx(2.5, rel=2e-3)
    assert catalogue.nucleation_and_front(brk, lat.positions, lat.box, 0.001)[:2] == (10.0, 7.0)


_RUN = {}


@pytest.fixture
def events_run(lammps, tmp_path_factory):
    """One run of the events scene, made once for the tests that read it."""
    if not _RUN:
        d = tmp_path_factory.mktemp("events")
        run(RunSpec(phi=10.0, t_end=600.0, scene="events", seed=2), d, progress=False)
        _RUN["run"] = (d, analyze(d))
    return _RUN["run"]


def test_an_events_run_writes_the_whole_catalogue(events_run):
    d, summary = events_run
    ev = RunDir(d).read_events()
    for c in ("potency", "nucleation_x", "nucleation_y", "front_speed", "breaks", "duration",
              *catalogue.SIZE_COLUMNS, *catalogue.ENERGY_COLUMNS):
        assert c in ev, c
    late = ev[ev.late]
    assert len(late) > 10
    assert late["n_slipped"].notna().all() and (late["potency"] > 0).all()
    assert late["nucleation_x"].between(0, 19).all() and late["nucleation_y"].between(0, 4).all()
    assert (late["front_speed"].dropna() > 0).all() and late["front_speed"].notna().mean() > 0.8
    assert (late["breaks"] > 0).all() and (ev["dissipated_breaks"] >= 0).all()
    # each slip's budget closes to the integrator's error (dt = 0.1 / sqrt(...))
    assert late["energy_closure"].abs().max() < 0.02
    assert abs(summary["energy_residual"]) < 1e-3
    assert summary["potency_power_law"] in ("plausible", "rejected")
    clusters = pd.read_csv(d / "clusters.csv")
    assert {"n_x", "n_y", "slip", "bond_change", "eq2_estimate"} <= set(clusters)


def test_the_parquet_catalogue_reads_back_without_bkflow(events_run):
    """pyarrow alone reads events.parquet, the catalogue's one copy: the rows and values of
    the analysis's table, its counts as integers."""
    import pyarrow.parquet as pq

    from bkflow.analysis.summary import summarize
    from bkflow.store.rundir import RunDir

    d, _ = events_run
    assert not (d / "events.csv").exists()
    table = pq.read_table(d / "events.parquet")
    assert str(table.schema.field("n_slipped").type) == "int64"
    assert str(table.schema.field("late").type) == "bool"
    back = table.to_pandas()
    rd = RunDir(d)
    spec = rd.spec()
    f = rd.read_slip_frames(spec.N)
    made = summarize(spec, rd.read_reduced(spec), None, (f.steps, f.positions),
                     slip_breaks=f.breaks).tables()["events.csv"]
    assert list(back.columns) == list(made) and len(back) == len(made["t_max"])
    for c in made:
        np.testing.assert_array_equal(back[c].astype(float).to_numpy(),
                                      np.asarray(made[c], float), err_msg=c)


def _copy(events_run, tmp_path):
    import shutil

    d, _ = events_run
    out = tmp_path / "copy"
    shutil.copytree(d, out)
    return out


def _rewrite(d, name, text):
    """Replace a run file's text and its size in meta.json (a damage the size check cannot
    see: what the file's own reader must catch)."""
    import json

    if isinstance(text, bytes):
        (d / name).write_bytes(text)
    else:
        (d / name).write_text(text)
    meta = json.loads((d / "meta.json").read_text())
    meta["file_bytes"][name] = (d / name).stat().st_size
    (d / "meta.json").write_text(json.dumps(meta))


def test_another_threshold_never_mixes_two_slips_in_one_row(events_run, tmp_path):
    """Analysed with a slip threshold other than the run's, a slip's frames are used only when
    they are that very slip's (its maximum and its minimum): no row takes its size from a
    shorter slip recorded at the run's threshold."""
    from bkflow.model.settings import AnalysisSettings

    d = _copy(events_run, tmp_path)
    recorded = RunDir(d).read_events()
    analyze(d, AnalysisSettings(slip_threshold=0.03))
    other = RunDir(d).read_events()
    late = other[other.late]
    with_size = late[late.potency.notna()]
    assert len(with_size) and len(with_size) < len(late)  # some slips differ, some do not
    pairs = set(zip(recorded.t_max.round(6), recorded.t_min.round(6)))
    assert set(zip(with_size.t_max.round(6), with_size.t_min.round(6))) <= pairs


@pytest.mark.parametrize("damage", ["garbage", "outside"])
def test_damaged_first_breaks_are_refused(events_run, tmp_path, damage):
    from bkflow.store.errors import DamagedRunError

    d = _copy(events_run, tmp_path)
    lines = (d / "slips.lammpstrj").read_text().splitlines()
    # the second frame (a minimum's): its first atom line
    starts = [k for k, line in enumerate(lines) if line.startswith("ITEM: ATOMS")]
    k = starts[1] + 1
    fields = lines[k].split()
    fields[-1] = "garbage" if damage == "garbage" else "3"
    lines[k] = " ".join(fields)
    _rewrite(d, "slips.lammpstrj", "\n".join(lines) + "\n")
    with pytest.raises(DamagedRunError, match="slips.lammpstrj"):
        analyze(d)


def test_a_damaged_record_is_refused(events_run, tmp_path):
    """A record of the run (extrema.npy) damaged in place, its size kept: refused, naming
    it."""
    from bkflow.store.errors import DamagedRunError

    d = _copy(events_run, tmp_path)
    data = bytearray((d / "extrema.npy").read_bytes())
    data[:6] = b"garble"
    _rewrite(d, "extrema.npy", bytes(data))
    with pytest.raises(DamagedRunError, match="extrema.npy"):
        analyze(d)


def test_a_damaged_catalogue_is_refused_and_analyze_repairs_it(events_run, tmp_path):
    """events.parquet and clusters.csv are one set with summary.json (its record of their
    sizes and digests): either one gone, cut or replaced, and the catalogue is refused with
    the repair named (DamagedRunError), never read half; bkflow analyze makes them again."""
    from bkflow.api import load_run
    from bkflow.store.errors import DamagedRunError

    d = _copy(events_run, tmp_path)
    whole = load_run(d).events
    for damage in (lambda: (d / "events.parquet").unlink(),
                   lambda: (d / "events.parquet").write_bytes(b"not parquet"),
                   lambda: (d / "clusters.csv").write_text("event,t\n0,1")):
        damage()
        with pytest.raises(DamagedRunError, match="bkflow analyze"):
            _ = load_run(d).events
        analyze(d)
        assert load_run(d).events.equals(whole)


def test_a_run_without_slips_has_every_column(lammps, tmp_path):
    run(RunSpec(phi=10.0, t_end=5.0, scene="events"), tmp_path, progress=False)
    analyze(tmp_path)
    header = list(pd.read_parquet(tmp_path / "events.parquet").columns)
    for c in (*catalogue.SIZE_COLUMNS, *catalogue.BREAK_COLUMNS, *catalogue.ENERGY_COLUMNS):
        assert c in header, c


def test_all_slips_at_once_are_each_slip_alone():
    """catalogue.slip_rows (vectorised over the slips) gives slip_row's columns for every slip,
    to rounding: random slips of a 12x5 layer, several clusters each, across the periodic
    edges, unwrapped positions far from the box (a long run's)."""
    from bkflow.model.lattice import square_lattice

    rng = np.random.default_rng(4)
    lat = square_lattice(12, 5)
    S = 60
    base = lat.positions[None] + np.array([3e4, 0.0]) + 0.2 * rng.standard_normal((S, 60, 2))
    moved = rng.random((S, 60)) < rng.uniform(0.1, 0.9, (S, 1))
    step = np.where(moved, rng.uniform(0.02, 0.5, (S, 60)), rng.uniform(-0.01, 0.005, (S, 60)))
    end = base.copy()
    end[..., 0] += step
    end[..., 1] += 0.01 * rng.standard_normal((S, 60))
    rows, per = catalogue.slip_rows(base, end, lat, 0.01, 10.0)
    want = [catalogue.slip_row(base[k], end[k], lat, 0.01, 10.0) for k in range(S)]
    assert per["slip_index"].tolist() == [k for k, (_, p) in enumerate(want) for _ in p["n_c"]]
    assert sum(len(p["n_c"]) for _, p in want) > 2 * S   # several clusters a slip
    for c in catalogue.SIZE_COLUMNS:
        np.testing.assert_allclose(rows[c], [r[c] for r, _ in want], rtol=1e-12, atol=1e-12)
    for c in ("label", "n_c", "l_x", "l_y", "n_x", "n_y", "slip", "bond_change",
              "eq2_estimate"):
        np.testing.assert_allclose(per[c], np.concatenate([p[c] for _, p in want]), rtol=1e-9,
                                   atol=1e-12)
