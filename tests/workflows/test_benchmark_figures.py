"""The figures benchmarks/report/ draws from its records, drawn from made-up records (no run, no
LAMMPS): the stiff end's long runs (stiff_states_figure.py), whether its blocks fall into two
states (bimodality.py, with its record and generated block) and the relaxation from the
synchronized start (stationarity.py). What a referee found wrong, checked:
a threshold on every panel of R and inside its range, a seed that shows both states, every
panel naming its phi and N, a histogram, no text under 7 pt, every point inside its axes and
off the keys, time axes with their unit, t_equil = 0 drawn (not lost off a log axis)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from bkflow.figures.style import COLUMN_WIDTH
from bkflow.observables.states import r_independent
from tests.figures.reading import (
    density_problems,
    draw_as_saved,
    outside_or_hidden,
    small_text,
    text_outside,
)

STARTS = ("synchronized", "random", "stratified", "partial")


@pytest.fixture(scope="module")
def bench():
    """The benchmark modules the figures are drawn by."""
    from benchmarks.measure import stationarity as measured
    from benchmarks.report import bimodality, stationarity, stiff_states_figure

    return {"states_figure": stiff_states_figure, "bimodality": bimodality,
            "stationarity": stationarity, "stationarity_record": measured}


def _blocks(rng, k, r_level, quiet_every=0, n=100):
    """k blocks of 1000 time units: R about r_level, and, every quiet_every blocks, a stretch
    of quiet ones (R at half the threshold, the stress lower)."""
    r = np.clip(r_level * (1 + 0.08 * rng.standard_normal(k)), 1e-3, None)
    if quiet_every:
        quiet = (np.arange(k) // (quiet_every // 2)) % 2 == 1
        r[quiet] = 0.5 * r_independent(n) * (1 + 0.08 * rng.standard_normal(quiet.sum()))
    s = 0.104 + 0.01 * r + 1e-4 * rng.standard_normal(k)
    t0 = 1000.0 * np.arange(k)
    return pd.DataFrame({"t0": t0, "t1": t0 + 1000, "n": 10000, "s": s, "R": r})


def _runs(seed=0) -> pd.DataFrame:
    """benchmarks/report/stiff_states.py's ``load``, its rows made up: at N = 100, phi = 215
    seed 1 never quiet and seed 2 in both states, at phi = 1000 both seeds switching, at N = 400
    none quiet."""
    rng = np.random.default_rng(seed)
    rows = []
    layers = {(100, 215.0): {1: (0.15, 0), 2: (0.15, 40)}, (100, 1000.0): {1: (0.2, 30),
              2: (0.2, 20)}, (400, 1000.0): {1: (0.13, 0), 2: (0.13, 0)}}
    for (n, phi), seeds in layers.items():
        for s, (level, every) in seeds.items():
            for start in STARTS:
                k = 600 if start == "random" else 300       # the longest: the random start's
                whole = _blocks(rng, k, level, every, n)
                rows.append({"N": n, "phi": phi, "start": start, "seed": s, "C": 1.0,
                             "t": float(whole.t1.iloc[-1]), "whole": whole,
                             "blocks": whole.iloc[int(0.2 * k):].reset_index(drop=True)})
    return pd.DataFrame(rows)


def _threshold_lines(ax, value):
    """The lines of ``ax`` drawn across it at ``value`` (axhline or axvline)."""
    out = []
    for ln in ax.get_lines():
        xy = ln.get_xydata()
        if len(xy) != 2:
            continue
        if np.allclose(xy[:, 1], value) and tuple(xy[:, 0]) == (0, 1):
            out.append(("h", ln))
        elif np.allclose(xy[:, 0], value) and tuple(xy[:, 1]) == (0, 1):
            out.append(("v", ln))
    return out


def _inside(ax, how, value) -> bool:
    lo, hi = ax.get_ylim() if how == "h" else ax.get_xlim()
    return lo <= value <= hi


# --------------------------------------------------------------------------- stiff_states
@pytest.fixture(scope="module")
def stiff(bench):
    runs = _runs()
    return runs, draw_as_saved(bench["states_figure"].draw(runs))


def test_every_panel_of_r_draws_the_threshold_within_its_range(stiff):
    """The N = 400 panels drew none (the line fell below their range): every panel of R, at
    every N, has the line at sqrt(pi / 4N), where the reader sees it."""
    _, fig = stiff
    panels = [ax for ax in fig.axes if "coherence $R$" in ax.get_xlabel() + ax.get_ylabel()]
    assert len(panels) == 6                                    # R over time, R's histogram
    for ax in panels:
        n = int(ax.get_title().split("N = ")[1].split(",")[0])
        lines = _threshold_lines(ax, r_independent(n))
        assert lines, f"{ax.get_title()}: no threshold line"
        assert all(_inside(ax, how, r_independent(n)) for how, _ in lines), ax.get_title()


def test_a_layer_with_two_states_is_shown_by_a_seed_that_visits_both(bench, stiff):
    runs, fig = stiff
    g = runs[(runs.N == 100) & (runs.phi == 215.0)]
    assert bench["states_figure"].shown_seed(g, 100) == 2      # seed 1 is never quiet
    titles = [ax.get_title() for ax in fig.axes]
    assert any(t.startswith("N = 100, $\\phi$ = 215, seed 2") for t in titles)


def test_every_panel_names_its_phi_and_n_and_a_histogram_is_drawn(stiff):
    _, fig = stiff
    panels = [ax for ax in fig.axes if ax.get_title()]
    assert len(panels) == 12
    for ax in panels:
        assert "N = " in ax.get_title() and "$\\phi$ = " in ax.get_title(), ax.get_title()
    hists = [ax for ax in panels
             if ax.get_ylabel() == "probability density of $R$\n(per unit of $R$)"]
    assert len(hists) == 3 and all(ax.patches for ax in hists)
    # a density says its unit, the inverse of its quantity's, as the package's figures do
    assert all(density_problems(ax.get_ylabel(), ax.get_xlabel()) == [] for ax in hists)


def test_the_stiff_states_figure_is_readable(stiff):
    """A page's column wide, no text under 7 pt, every point inside its axes and off the key,
    time axes in the model's time unit."""
    _, fig = stiff
    assert fig.get_figwidth() <= COLUMN_WIDTH
    assert small_text(fig) == [] and text_outside(fig) == []
    assert outside_or_hidden(fig) == []
    times = [ax.get_xlabel() for ax in fig.axes if ax.get_xlabel().startswith("$t$")]
    assert len(times) == 9 and all(r"\sqrt{m/k_d}" in x for x in times)


# --------------------------------------------------------------------------- bimodality
def test_sarle_reads_one_mode_and_two(bench):
    bm = bench["bimodality"]
    rng = np.random.default_rng(1)
    assert bm.sarle(rng.standard_normal(20000)) == pytest.approx(1 / 3, abs=0.02)
    assert bm.sarle(rng.uniform(size=20000)) == pytest.approx(5 / 9, abs=0.02)
    two = np.concatenate([rng.normal(0, 1, 10000), rng.normal(6, 1, 10000)])
    assert bm.sarle(two) > bm.SARLE_BIMODAL
    assert math.isnan(bm.sarle([1.0, 1.0, 1.0, 1.0]))


def test_merged_blocks_are_their_samples_weighted_means(bench):
    b = pd.DataFrame({"n": [1, 3, 2, 2, 5], "R": [0.0, 4.0, 1.0, 3.0, 9.0],
                      "s": [1.0, 1.0, 2.0, 4.0, 9.0]})
    m = bench["bimodality"].merged(b, 2)
    assert list(m.R) == [3.0, 2.0] and list(m.s) == [1.0, 3.0]   # the fifth block left out


@pytest.fixture(scope="module")
def bimodal(bench):
    runs = _runs(1)
    rec = bench["bimodality"].record(runs)
    return runs, rec


def test_the_record_tells_two_states_from_one(bimodal):
    _, rec = bimodal
    layers = {(r["N"], r["phi"]): r for r in rec["layers"]}
    two, one = layers[(100, 1000.0)], layers[(400, 1000.0)]
    assert two["sarle_R"]["1000"] > rec["sarle_bimodal"] > one["sarle_R"]["1000"]
    assert 0.2 < two["quiet"]["1000"]["1"] < 0.6
    assert one["quiet"] == {str(k): {"0.5": 0.0, "1": 0.0, "2": 0.0} for k in (1000, 2000, 5000)}
    assert two["blocks"] == sum(len(b) for b in _runs(1).query("N == 100 and phi == 1000").blocks)


def test_the_bimodality_figure_is_readable_and_marks_the_threshold(bench, bimodal):
    """Every panel of R draws the threshold (1 in its units) within its range; no text under
    7 pt; no point outside its axes; a layer not recorded says so."""
    import matplotlib.pyplot as plt

    runs, rec = bimodal
    fig = draw_as_saved(bench["bimodality"].draw(runs, rec))
    try:
        panels = [ax for ax in fig.axes if ax.get_xlabel().startswith(r"$R\,/")]
        assert len(panels) >= 4 + 3
        for ax in panels:
            lines = _threshold_lines(ax, 1.0)
            assert lines and all(_inside(ax, how, 1.0) for how, _ in lines), ax.get_title()
        assert small_text(fig) == []
        assert outside_or_hidden(fig) == []
        texts = [t.get_text() for ax in fig.axes for t in ax.texts]
        assert any("not recorded" in t for t in texts)        # N = 900 is not in the records
    finally:
        plt.close(fig)


def test_the_bimodality_block_renders_its_record(bimodal, monkeypatch):
    from benchmarks.documents import steady as rb

    runs, rec = bimodal
    monkeypatch.setattr(rb, "record", lambda name: rec if name == "bimodality" else None)
    text = rb.bimodality()
    rows = [ln for ln in text.splitlines() if ln.startswith("| 100 ") or ln.startswith("| 400 ")]
    assert len(rows) == len(rec["layers"])
    reading = text[text.index("Reading: b above 0.556"):]
    assert "1000" in reading.split("; the stress")[0]                  # R's two modes
    assert "N = 400" not in reading.split("; the stress")[0]           # and N = 400's one
    monkeypatch.setattr(rb, "record", lambda name: None)
    assert rb.bimodality().startswith("(not measured yet")


# --------------------------------------------------------------------------- stationarity
def _relaxation_made_up():
    """stationarity.relaxation's rows and curves: t_equil = 0 at phi = 10 at both sizes."""
    grid = [(n, phi) for n in (100, 400) for phi in (0.1, 10.0, 1000.0)]
    df = pd.DataFrame([{"N": n, "phi": phi, "seed": s, "tau": 500.0 * (1 + s),
                        "amplitude": 0.01, "t_equil": 0.0 if phi == 10.0 else 80.0,
                        "late_mean": 0.11} for n, phi in grid for s in (1, 2, 3)])
    tc = np.linspace(200, 15800, 40)
    return df, {key: [(tc, 0.11 + 0.001 * np.exp(-tc / 2000))] * 3 for key in grid}


def test_the_relaxation_figure_keeps_t_equil_zero_and_says_its_unit(bench, tmp_path):
    """A t_equil of 0 cannot sit on the log axis: it is drawn on the axis' lower edge with a
    marker of its own, named in the key; the time axes say their unit; the record redraws it."""
    import matplotlib.pyplot as plt

    st = bench["stationarity"]
    bench["stationarity_record"].write_relaxation_record(*_relaxation_made_up(),
                                                         tmp_path / "rec.json")
    df2, curves2 = st.read_relaxation_record(tmp_path / "rec.json")
    fig = draw_as_saved(st.relaxation_figure(df2, curves2, tmp_path / "relax.png"))
    try:
        a, b = fig.axes
        assert a.get_xlabel() == "t (time units)" and "(time units" in b.get_ylabel()
        zero = [ln for ln in b.get_lines() if ln.get_label().startswith("t_equil = 0")]
        assert len(zero) == 2
        for ln in zero:
            assert list(ln.get_xdata()) == [10.0]
            assert ln.get_ydata()[0] == pytest.approx(b.get_ylim()[0])
        labels = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
        assert any("t_equil = 0" in t and "lower edge" in t for t in labels)
        assert small_text(fig) == []
        assert outside_or_hidden(fig) == []
    finally:
        plt.close(fig)
    assert (tmp_path / "relax.png").stat().st_size > 10000


def test_the_relaxation_table_is_its_records_medians_over_fitted_seeds(bench, tmp_path,
                                                                       monkeypatch):
    """RESULTS' relaxation table (benchmarks/documents/steady.py) comes from the record: tau and
    A / s_inf are medians over the seeds with a fit (a seed without one is not a zero), and the
    count of those seeds is printed; t_equil and the late mean over every seed."""
    from benchmarks.documents import steady as rb

    st, measured = bench["stationarity"], bench["stationarity_record"]
    df, curves = _relaxation_made_up()
    df.loc[(df.N == 400) & (df.phi == 1000.0) & (df.seed == 3), ["tau", "amplitude"]] = np.nan
    df.loc[(df.N == 100) & (df.phi == 0.1), "tau"] = np.nan
    rec = tmp_path / "rec.json"
    measured.write_relaxation_record(df, curves, rec)
    monkeypatch.setattr(measured, "RELAXATION_RECORD", rec)
    read = st.read_relaxation_record
    monkeypatch.setattr(st, "read_relaxation_record", lambda: read(rec))
    rows = {tuple(c.strip() for c in line.split("|")[1:3]): line
            for line in rb.relaxation().splitlines()[2:]}
    assert rows[("400", "1000")].split("|")[3:5] == [" 2 of 3 ", " 1.25e+03 "]  # (1000 + 1500) / 2
    assert rows[("100", "0.1")].split("|")[3:6] == [" 0 of 3 ", " - ", " - "]
    assert rows[("100", "10")].split("|")[6] == " 0 "
