"""The run's records of its stress and phases, reduced in the run (fix bk/reduce,
bkflow.observables.reduced): the slips at every threshold at or above the recorded one are exactly
those of the whole series; the records are the reduction of the raw series, bit for bit, on both
paths, on two ranks and across a continuation; an analysis from the records is the analysis
from the raw series; block means give the verdicts the raw series gives."""

from __future__ import annotations

import math
import subprocess

import numpy as np
import pytest

from bkflow.analysis.summary import summarize
from bkflow.lammps.deck import DeckOptions, data_text, setup_text
from bkflow.lammps.engine import run
from bkflow.model.lattice import square_lattice
from bkflow.model.params import RunSpec
from bkflow.model.protocols import protocol_fields
from bkflow.observables import reduced, stationarity
from bkflow.observables.reduced import LEDGER_COLUMNS
from bkflow.observables.stress import slip_events
from bkflow.store.rundir import RunDir
from tests.support import tool


def _series(rng, kind: int, n: int) -> np.ndarray:
    if kind == 0:   # a random walk
        return np.cumsum(rng.normal(size=n))
    if kind == 1:   # with ties
        return np.round(np.cumsum(rng.normal(size=n)), 1)
    if kind == 2:   # a sawtooth with noise: loading and drops, as sigma_x
        return np.mod(np.arange(n) * rng.uniform(0.01, 0.2), 1.0) + rng.normal(0, 0.02, n)
    return np.sin(np.arange(n) * rng.uniform(0.05, 1)) + rng.normal(0, 0.1, n)


def test_extrema_give_the_slips_of_every_larger_threshold_exactly():
    rng = np.random.default_rng(5)
    for trial in range(400):
        n = int(rng.integers(1, 500))
        s = _series(rng, trial % 4, n)
        th0 = float(rng.uniform(0.005, 0.5))
        red = reduced.from_series(s, 3, 30, 0.1, th0)
        t = np.arange(n) * 3 * 0.1
        for th in (th0, th0 * (1 + 1e-9), th0 * 1.7, th0 * 3, th0 * 10, th0 * 1e3):
            whole, recs = slip_events(t, s, th), red.events(th)
            for name in ("i_max", "i_min", "t_max", "t_min", "sigma_fail", "drop"):
                assert np.array_equal(getattr(whole, name), getattr(recs, name)), (trial, th)
        # fewer records than samples: a series of n samples has at most n turning points
        assert len(red.extrema) <= max(n, 1)


def test_a_threshold_below_the_recorded_one_is_refused_naming_the_scene_that_keeps_it():
    red = reduced.from_series(np.sin(np.arange(100) * 0.3), 1, 10, 0.1, 0.05)
    with pytest.raises(reduced.ReducedError, match="scene series"):
        red.events(0.01)


def test_block_means_give_the_verdict_of_the_raw_series():
    """The trend test on block means (what the analysis reads) against the raw series: the same
    verdict on flat series and on drifting ones, with the same drift to a few percent."""
    rng = np.random.default_rng(11)
    dt, nevery, block = 0.01, 10, 200          # samples every 0.1, blocks of 2 time units
    agree = 0
    for k in range(40):
        n = 20000
        noise = np.zeros(n)
        e = rng.normal(0, 0.01, n)
        for i in range(1, n):               # AR(1), correlation time ~10 samples
            noise[i] = 0.9 * noise[i - 1] + e[i]
        drift = 0.0 if k % 2 == 0 else 0.02
        s = 1.0 + drift * np.arange(n) / n + noise
        t = np.arange(n) * nevery * dt
        raw = stationarity.stationarity(t, s, 200.0)
        tb, sb, _ = reduced.from_series(s, nevery, block, dt, 0.05).series()
        blk = stationarity.stationarity(tb, sb, 200.0)
        agree += raw.stationary == blk.stationary
        assert blk.stationary == (drift == 0.0) or raw.stationary == blk.stationary
        assert abs(raw.drift - blk.drift) < 0.1 * max(abs(raw.drift), 2 * raw.drift_err)
    assert agree >= 38


def test_batch_means_error_covers_the_mean_like_the_raw_error():
    """The mean's error from block means (batch means) against the raw series' (statistical
    inefficiency): the same to 20% on correlated noise whose correlation time is shorter than a
    block."""
    rng = np.random.default_rng(3)
    ratios = []
    for _ in range(20):
        n = 50000
        x = np.zeros(n)
        e = rng.normal(size=n)
        for i in range(1, n):
            x[i] = 0.8 * x[i - 1] + e[i]
        raw = stationarity.mean_error(x).error
        _, xb, _ = reduced.from_series(x, 1, 100, 1.0, 1.0).series()
        ratios.append(stationarity.mean_error(xb).error / raw)
    assert 0.8 < np.median(ratios) < 1.2


# ------------------------------------------------------------------------------- the plugin
def _spec(**kw):
    return RunSpec(**{"phi": 1000.0, "Lx": 8, "Ly": 4, "seed": 3, "scene": "series",
                      "t_end": 300.0, "stress_every": 0.05, **kw})


def _lmp(workdir, ranks: int = 1) -> None:
    """``lmp -in in.bk`` in ``workdir`` on ``ranks`` ranks; the test fails with its log."""
    cmd = [tool("lmp"), "-in", "in.bk", "-log", "log.lammps", "-screen", "none"]
    if ranks > 1:
        cmd = [tool("mpirun"), "-np", str(ranks)] + cmd
    proc = subprocess.run(cmd, cwd=workdir, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, (workdir / "log.lammps").read_text()[-2000:]


def _records_and_series(workdir, spec, path="auto", ranks=1):
    lattice = square_lattice(spec.Lx, spec.Ly)
    workdir.mkdir(parents=True, exist_ok=True)
    (workdir / "data.bk").write_text(data_text(spec, lattice))
    deck = setup_text(spec, DeckOptions(path=path, energy=True))
    deck += f"\nrun {spec.n_steps // 2} post no\nrun {spec.n_steps - spec.n_steps // 2}\n"
    (workdir / "in.bk").write_text(deck)
    _lmp(workdir, ranks)
    rd = RunDir(workdir)
    recs = reduced.Reduced(
        reduced.checked_extrema(np.load(workdir / "extrema.npy"), "extrema.npy"),
        reduced.checked_blocks(np.load(workdir / "blocks.npy"), "blocks.npy"),
        spec.stress_nevery, spec.block_nevery, spec.dt, float(spec.extrema_threshold_stress))
    _, sigma = rd.read_stress(spec)
    series = reduced.from_series(sigma, spec.stress_nevery, spec.block_nevery, spec.dt,
                                 spec.extrema_threshold_stress, rd.read_phase(spec),
                                 spec.phase_nevery, rd.read_ledger(spec))
    return recs, series


#: the ledger's running sums, which each rank accumulates for its atoms: the same to rounding
#: on any number of ranks, not to the bit (tests/plugins/test_fused_ranks.py)
RUNNING_SUMS = ("work", "diss_break", "diss_damp")


def _same_records(a: reduced.Reduced, b: reduced.Reduced, exact=True):
    for x, y in ((a.extrema, b.extrema), (a.blocks, b.blocks)):
        assert x.dtype == y.dtype and len(x) == len(y)
        for name in x.dtype.names:
            if exact and name not in RUNNING_SUMS:
                assert np.array_equal(x[name], y[name]), name
            else:
                # u_std: the root of a variance that cancels (E[u^2] - E[u]^2), so that a
                # rounding of 1e-16 in it is 1e-8 in the root (summed over a block)
                atol = 1e-6 if name == "u_std" else 1e-10
                assert np.allclose(x[name], y[name], rtol=1e-10, atol=atol), name


@pytest.mark.usefixtures("lammps")
@pytest.mark.parametrize("path,ranks", [("auto", 1), ("general", 1), ("auto", 2)])
def test_the_records_are_the_reduction_of_the_raw_series(tmp_path, path, ranks):
    spec = _spec()
    recs, series = _records_and_series(tmp_path, spec, path, ranks)
    assert len(recs.extrema) > 10 and len(recs.blocks) == math.ceil(
        (spec.n_steps // spec.stress_nevery * spec.stress_nevery + 1) / spec.block_nevery)
    assert recs.has_phase and recs.has_ledger
    assert set(LEDGER_COLUMNS) <= set(recs.extrema.dtype.names)
    _same_records(recs, series)


@pytest.mark.usefixtures("lammps")
def test_both_paths_and_two_ranks_record_the_same_run(tmp_path):
    spec = _spec()
    one, _ = _records_and_series(tmp_path / "one", spec)
    two, _ = _records_and_series(tmp_path / "two", spec, ranks=2)
    general, _ = _records_and_series(tmp_path / "general", spec, path="general")
    _same_records(one, two)                    # the fused path: the same bits on any ranks
    # the general path sums the forces in another order: the same run to rounding, the same
    # slips
    assert np.array_equal(one.extrema["step"], general.extrema["step"])
    _same_records(one, general, exact=False)


@pytest.mark.usefixtures("lammps")
def test_a_continued_run_records_what_the_uninterrupted_run_records(tmp_path):
    base = _spec(**{**protocol_fields("paper"), "scene": "events", "t_end": 400.0})
    run(base, tmp_path / "c", progress=False)
    longer = base.replace(t_end=900.0)
    run(longer, tmp_path / "c", progress=False)
    run(longer, tmp_path / "fresh", progress=False)
    for name in ("extrema.npy", "blocks.npy"):
        assert (tmp_path / "c" / name).read_bytes() == (tmp_path / "fresh" / name).read_bytes()
    assert RunDir(tmp_path / "c").problem() is None


@pytest.mark.usefixtures("lammps")
def test_the_analysis_of_the_records_is_the_analysis_of_the_raw_series(tmp_path):
    spec = _spec(**{**protocol_fields("paper"), "t_end": 1500.0})
    run(spec, tmp_path / "r", progress=False)
    rd = RunDir(tmp_path / "r")
    _, sigma = rd.read_stress()
    series = reduced.from_series(sigma, spec.stress_nevery, spec.block_nevery, spec.dt,
                                 spec.extrema_threshold_stress, rd.read_phase(),
                                 spec.phase_nevery)
    a = summarize(spec, rd.read_reduced(spec)).summary()
    b = summarize(spec, series).summary()
    assert a.keys() == b.keys()
    for k, v in a.items():
        if isinstance(v, float) and math.isfinite(v):
            assert v == pytest.approx(b[k], rel=1e-9, abs=1e-12), k
        else:
            assert v == b[k] or (isinstance(v, float) and math.isnan(b[k])), k
    assert a["state"] == b["state"] and a["n_slips"] == b["n_slips"] > 0


@pytest.mark.usefixtures("lammps")
@pytest.mark.parametrize("path,ranks", [("auto", 1), ("general", 1), ("auto", 2)])
def test_psi_in_the_run_is_the_psi_of_the_positions(tmp_path, path, ranks):
    """fix bk/psi against bkflow.observables.order.psi of full-precision frames of the same steps
    (the frames of scene full are written to 9 digits: Psi from them differs by ~1e-8)."""
    from bkflow.analysis.summary import order_result
    from bkflow.model.settings import AnalysisSettings
    from bkflow.store import formats

    spec = _spec(scene="order", snapshot_every=10.0, start="random")
    lattice = square_lattice(spec.Lx, spec.Ly)
    (tmp_path / "data.bk").write_text(data_text(spec, lattice))
    deck = setup_text(spec, DeckOptions(path=path)) + (
        f"\ndump exact all custom {spec.snapshot_nevery} exact.lammpstrj id type x y z ix iy iz"
        f"\ndump_modify exact sort id format float %.17g\nrun {spec.n_steps}\n")
    (tmp_path / "in.bk").write_text(deck)
    _lmp(tmp_path, ranks)
    steps, psi = RunDir(tmp_path).read_psi_record(spec)
    frames = formats.read_frames(tmp_path / "exact.lammpstrj", spec.N)
    offline = order_result(spec, AnalysisSettings().resolved(spec), frames.steps,
                           frames.positions)
    assert np.array_equal(steps, frames.steps) and len(steps) == spec.n_steps // \
        spec.snapshot_nevery + 1
    assert np.allclose(psi, offline.psi, rtol=0, atol=1e-13)
    assert psi.min() < 0.999    # the layer moved: a test that Psi = 1 throughout would pass


@pytest.mark.usefixtures("lammps")
@pytest.mark.parametrize("ranks", [1, 2])
def test_the_slips_reduced_in_the_run_give_the_clusters_of_their_frames(tmp_path, ranks):
    """fix bk/slips ``catalogue`` (scene figures) against bkflow.observables.catalogue.slip_rows of
    the same slips' frames written to 17 digits: every row and cluster, on one and two ranks, on a
    soft layer whose slips break into several clusters."""
    from bkflow.model.params import S_X
    from bkflow.observables import catalogue
    from bkflow.store import formats

    spec = RunSpec(phi=1.0, Lx=16, Ly=6, t_end=600, scene="figures", seed=4, start="random")
    (tmp_path / "data.bk").write_text(data_text(spec, square_lattice(spec.Lx, spec.Ly)))
    deck = setup_text(spec, DeckOptions())
    line = next(ln for ln in deck.splitlines() if "bk/slips" in ln)
    assert "file none" in line and "catalogue slips.npy clusters.npy" in line
    # the frames too, to full precision, for the comparison
    deck = deck.replace(line, line.replace("file none", "file frames.lammpstrj") + " exact")
    (tmp_path / "in.bk").write_text(deck + f"\nrun {spec.n_steps}\n")
    _lmp(tmp_path, ranks)
    slips, clusters = RunDir(tmp_path).read_slip_rows()
    frames = formats.read_frames(tmp_path / "frames.lammpstrj", spec.N)
    want, per = catalogue.slip_rows(frames.positions[0::2], frames.positions[1::2],
                                    square_lattice(spec.Lx, spec.Ly), S_X, spec.k_b)
    assert len(slips) == len(frames) // 2 >= 5
    assert np.array_equal(slips["step_max"], frames.steps[0::2])
    assert np.array_equal(slips["step_min"], frames.steps[1::2])
    assert len(clusters) == len(per["n_c"]) > len(slips)      # several clusters per slip
    for c in catalogue.SIZE_COLUMNS:
        np.testing.assert_allclose(slips[c].astype(float), np.asarray(want[c], float),
                                   rtol=1e-12, atol=1e-12, equal_nan=True, err_msg=c)
    np.testing.assert_array_equal(clusters["step_max"], frames.steps[0::2][per["slip_index"]])
    for c in ("label", "n_c", "n_x", "n_y", "l_x", "l_y", "slip", "bond_change",
              "eq2_estimate"):
        np.testing.assert_allclose(clusters[c].astype(float), np.asarray(per[c], float),
                                   rtol=1e-10, atol=1e-12, err_msg=c)


@pytest.mark.slow
@pytest.mark.usefixtures("lammps")
def test_a_long_run_on_a_small_lattice_stays_under_its_byte_budget(tmp_path):
    """2.5 x 10^5 time units (some 10^4 slips, 10^7 stress samples) at phi = 1000 in the
    default scene on a 4 x 3 lattice: the run writes
    at most what bkflow.lammps.limits budgets for it (a few tens of bytes a time unit, whatever the
    length: every record grows with the slips, none with the samples), and its analysis
    reads back every slip."""
    from bkflow.lammps import limits

    spec = RunSpec(phi=1000.0, Lx=4, Ly=3, seed=1, t_end=2.5e5, **{
        k: v for k, v in protocol_fields("paper").items() if k != "t_end"})
    assert spec.scene == "figures"
    res = run(spec, tmp_path, progress=False)
    written = res.meta["bytes_written"]
    budget = limits.cost(spec).disk_bytes
    assert written <= budget <= 60e6, (written, budget)
    grows = {n: b for n, b in res.meta["file_bytes"].items() if n.endswith(".npy")}
    per_t = sum(grows.values()) / spec.t_end
    assert per_t <= limits.RECORD_BYTES_PER_T + limits.SLIP_ROW_BYTES_PER_T + 1, grows
    from bkflow.analysis.summary import analyze

    s = analyze(tmp_path)
    assert s["n_slips"] > 1000 and s["n_cluster_events"] == s["n_slips"]


@pytest.mark.usefixtures("lammps")
def test_the_analysis_asks_for_what_the_records_hold(tmp_path):
    """A threshold below the recorded one: from the raw series where the scene kept it, refused
    in one line naming scene series where not; the clusters of a re-analysis at another
    threshold are that analysis's slips' (matched by maximum and minimum); a record damaged
    in its header (a field renamed, another shape) is damage, not a crash; a companion's
    stress is its blocks."""
    from bkflow.analysis.summary import analyze
    from bkflow.api import load_run
    from bkflow.model.settings import AnalysisSettings
    from bkflow.store.errors import AnalysisError, DamagedRunError

    base = RunSpec(**{**protocol_fields("paper"), "phi": 10.0, "Lx": 12, "Ly": 4, "seed": 2,
                      "t_end": 1500.0})
    run(base.replace(scene="series"), tmp_path / "s", progress=False)
    low = analyze(tmp_path / "s", AnalysisSettings(slip_threshold=0.0005))
    assert low["n_slips"] > analyze(tmp_path / "s")["n_slips"]
    run(base, tmp_path / "f", progress=False)
    with pytest.raises(AnalysisError, match="scene series"):
        analyze(tmp_path / "f", AnalysisSettings(slip_threshold=0.0005))
    s = analyze(tmp_path / "f", AnalysisSettings(slip_threshold=0.03))
    assert len(load_run(tmp_path / "f").clusters) == \
        int(np.nansum(load_run(tmp_path / "f").events["n_clusters"]))
    assert s["n_cluster_events"] <= s["n_slips"]
    data = bytearray((tmp_path / "f" / "extrema.npy").read_bytes())
    at = data.index(b"'step'")
    data[at:at + 6] = b"'stap'"
    (tmp_path / "f" / "extrema.npy").write_bytes(bytes(data))
    with pytest.raises(DamagedRunError, match="extrema.npy"):
        analyze(tmp_path / "f")
    run(base.replace(t_end=600.0, companion="partial", until_steady=True, start="random"),
        tmp_path / "p", progress=False)
    comp = load_run(tmp_path / "p" / "companion")
    # the companion keeps its turning points too: the pair's estimate reads its slips
    assert len(comp.stress) and len(comp.blocks) > 10


@pytest.mark.usefixtures("lammps")
def test_the_energy_of_slips_below_the_recorded_threshold_comes_from_the_raw_ledger(tmp_path):
    """Scene full, re-analysed at a threshold below the records': the slips come from the raw
    series, and so does each one's energy budget (not another extremum's ledger)."""
    from bkflow.analysis.summary import analyze
    from bkflow.api import load_run
    from bkflow.model.settings import AnalysisSettings

    spec = RunSpec(**{**protocol_fields("paper"), "phi": 10.0, "Lx": 12, "Ly": 4, "seed": 2,
                      "t_end": 1000.0, "scene": "full"})
    run(spec, tmp_path, progress=False)
    analyze(tmp_path, AnalysisSettings(slip_threshold=0.0005))
    ev = load_run(tmp_path).events
    ledger = RunDir(tmp_path).read_ledger()
    t = ledger["t"]
    a = np.searchsorted(t, ev["t_max"].to_numpy() - 1e-9)
    b = np.searchsorted(t, ev["t_min"].to_numpy() - 1e-9)
    assert len(ev) > 20
    np.testing.assert_allclose(ev["breaks"].to_numpy(float),
                               ledger["breaks"][b] - ledger["breaks"][a])
