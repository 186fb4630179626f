"""The figures the paper's reproduction (workflows/paper/: paper_figures.py, energy_argument.py,
aspect_check.py) and benchmarks/report/work_precision.py draw themselves, drawn from made-up
tables (no run, no LAMMPS): every value drawn inside its axes and none under a key, nothing
non-positive on a log axis, and what each figure promises its reader (shared y ranges, the mu_s
reference, the runs left out and why, distinguishable curves); and reproduce.py, which calls
them, runs as a script with its modules beside it."""

from __future__ import annotations

import math
import sys

import numpy as np
import pandas as pd
import pytest

from bkflow.figures.style import STYLE
from tests.figures.reading import hidden_points, small_text
from tests.support import ROOT, workflow_module

PAPER = ROOT / "workflows" / "paper"


@pytest.fixture(scope="module")
def paper_figures():
    return workflow_module(PAPER / "paper_figures.py", "paper_figures")


@pytest.fixture(scope="module")
def energy():
    return workflow_module(PAPER / "energy_argument.py", "energy_argument")


@pytest.fixture(scope="module")
def aspect():
    return workflow_module(PAPER / "aspect_check.py", "aspect_check")


@pytest.fixture(scope="module")
def sweeps():
    return workflow_module(PAPER / "paper_sweeps.py", "paper_sweeps")


def test_reproduce_runs_as_a_script_with_its_modules_beside_it():
    """python workflows/paper/reproduce.py finds the modules beside it by their file names."""
    import subprocess

    p = subprocess.run([sys.executable, str(PAPER / "reproduce.py"), "--help"],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert "--protocols" in p.stdout and "Reproduce the paper's claims" in p.stdout


@pytest.fixture(scope="module")
def work_precision():
    from benchmarks.report import work_precision

    return work_precision


@pytest.fixture()
def figures(monkeypatch):
    """Every Figure the figure functions save, instead of a file."""
    from matplotlib.figure import Figure

    drawn = {}

    def keep(self, path, **kw):
        drawn[getattr(path, "name", str(path))] = self

    monkeypatch.setattr(Figure, "savefig", keep)
    return drawn


PHI = [0.1, 1.0, 10.0, 100.0, 1000.0]


def _results(n, offset, states, mu_s=0.2):
    """One curve's results at size n: mu_bar falling with phi, lower at larger n."""
    phi = np.array(PHI)
    base = 0.121 - 0.002 * np.log10(phi / 0.1) - offset
    return pd.DataFrame({"N": n, "phi": phi, "mu_bar": base, "mu_bar_sem": 3e-4,
                         "mu_bar_large": base + 0.003, "mu_bar_large_sem": 4e-4,
                         "mean_stress_ratio": base - 0.004, "mean_stress_ratio_sem": 2e-4,
                         "state": states, "mu_s": mu_s})


def _curves():
    states = ["steady", "steady", "coherent", "drifting", "metastable"]
    paper = pd.concat([_results(100, 0.0, states), _results(400, 0.004, states)])
    steady = pd.concat([_results(100, 0.001, ["steady"] * 5),
                        _results(400, 0.006, ["steady"] * 4 + [None])])
    return {"paper, t_end = 1000": (None, paper),
            "paper, t_end = 4000": (None, paper.assign(mu_bar=paper.mu_bar - 0.001)),
            "steady protocol": (None, steady)}


def test_fig2a_protocols_shares_y_per_row_keys_mu_s_and_tells_the_states_apart(
        paper_figures, figures, monkeypatch, tmp_path):
    """Each row one y range across N (so that a deeper curve at larger N is seen as such),
    every point inside its axes and none under the key; the paper's minimum, 40% below mu_s,
    drawn in the mu_bar rows and a right axis in % below mu_s; each state its fill, as in
    every bkflow figure, and each curve its own colour and line style."""
    monkeypatch.setattr(paper_figures, "curves", lambda out: _curves())
    paper_figures.protocols_figure(tmp_path, tmp_path)
    fig = figures["fig2a_protocols.png"]
    assert hidden_points(fig) == []
    panels = [ax for ax in fig.axes if ax.get_lines()]
    rows = {}
    for ax in panels:
        rows.setdefault(round(ax.get_position().y0, 3), []).append(ax)
    assert len(rows) == 3 and all(len(r) == 2 for r in rows.values())
    for r in rows.values():
        assert r[0].get_ylim() == r[1].get_ylim()
    top = max(rows)
    lo, hi = rows[top][0].get_ylim()   # N = 100's panel holds N = 400's lowest point too
    assert lo < 0.121 - 0.002 * 4 - 0.004 < 0.121 < hi
    for y0, r in rows.items():
        refs = [ln for ln in r[0].get_lines()   # a line across the axes (axhline) at 0.12
                if list(ln.get_xdata()) == [0, 1]
                and np.allclose(np.asarray(ln.get_ydata(), float), 0.6 * 0.2)]
        assert len(refs) == (1 if y0 != min(rows) else 0), y0   # the mu_bar rows only
    right = [c for ax in fig.axes for c in ax.child_axes if "below" in c.get_ylabel()]
    assert len(right) == 3 and all(r"$\mu_s$ = 0.2" in ax.get_ylabel() for ax in right)
    # the right axis: a tick at p% sits where the left axis reads (1 - p/100) mu_s
    for parent in fig.axes:
        for sec in parent.child_axes:
            ticks = sec.get_yticks()
            ticks = ticks[(ticks >= min(sec.get_ylim())) & (ticks <= max(sec.get_ylim()))]
            assert len(ticks) >= 2
            for p in ticks:
                y = sec.transData.transform((0, p))[1]
                left = parent.transData.inverted().transform((0, y))[1]
                assert left == pytest.approx(0.2 * (1 - p / 100), rel=1e-6)
    # the states: drawn and keyed as in every bkflow figure (one convention, style.py's)
    from bkflow.figures.style import STATE_FILL, STATE_MARKER, STATE_WORDS

    keyed = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    for name in ("steady", "switching", "drifting", "metastable"):
        assert STATE_WORDS[name] in keyed, name
    shown = {(ln.get_marker(), ln.get_fillstyle()) for ax in panels for ln in ax.get_lines()
             if ln.get_marker() in STATE_MARKER.values()}
    assert shown == {(STATE_MARKER[n], STATE_FILL[n]) for n in STATE_FILL}
    from matplotlib.lines import Line2D

    handles = {(h.get_marker(), h.get_fillstyle()) for leg in fig.legends
               for h in leg.findobj(Line2D) if h.get_marker() in STATE_MARKER.values()}
    assert shown <= handles
    # the curves: no two alike; colours at least 0.25 apart in RGB where the line style is
    # the same (two reds that only differ in shade were the complaint)
    from matplotlib.colors import to_rgb

    style = list(paper_figures.CURVE_STYLE.values())
    for i, (c1, ls1) in enumerate(style):
        for c2, ls2 in style[i + 1:]:
            far = np.linalg.norm(np.subtract(to_rgb(c1), to_rgb(c2))) >= 0.25
            assert far or ls1 != ls2, (c1, c2)
            assert far, (c1, c2)


def test_fig2a_protocols_fits_a_7_inch_column_with_no_text_under_7_pt(
        paper_figures, sweeps, monkeypatch, tmp_path):
    """The reproduction's four sizes (N = 100, 400, 900 and 3600, the largest only in the
    steady protocol) in panels two sizes wide: the PNG as saved (trimmed, at bkflow's
    resolution) at most 7 in wide, so that it prints in a 6.5-7 in column at its own size or
    larger, and no text of it under 7 pt at that size; each observable's panels one y range
    across the sizes, every point inside its axes and none under the key."""
    from matplotlib.image import imread

    curves = _curves()
    big = _results(3600, 0.01, ["steady"] * 5)
    wide = {label: (None, pd.concat([res, res.assign(N=900, mu_bar=res.mu_bar - 0.002)]))
            for label, (_, res) in curves.items()}
    wide["steady protocol, N = 3600"] = (None, big)
    monkeypatch.setattr(paper_figures, "curves", lambda out: wide)
    kept = {}
    write = paper_figures.write_figure
    monkeypatch.setattr(paper_figures, "write_figure",
                        lambda fig, path: kept.setdefault("fig", fig) and write(fig, path))
    path = paper_figures.protocols_figure(tmp_path, tmp_path)
    height, width = imread(path).shape[:2]
    dpi = STYLE["savefig.dpi"]
    assert width / dpi <= 7.0, f"{width / dpi:.2f} in wide"
    fig = kept["fig"]
    assert small_text(fig) == []
    assert hidden_points(fig) == []
    panels = [ax for ax in fig.axes if ax.get_lines()]
    assert len(panels) == 4 * len(sweeps.OBSERVABLES)
    ranges = {}
    for ax in panels:
        ranges.setdefault(ax.get_ylim(), []).append(ax)
    assert sorted(len(r) for r in ranges.values()) == [4] * len(sweeps.OBSERVABLES)
    titles = {ax.get_title() for ax in panels} - {""}
    assert titles == {f"N = {n}" for n in (100, 400, 900, 3600)}


def _runs(n, t_end, start="synchronized"):
    rows = []
    for phi in PHI:
        for seed in (1, 2, 3):
            state = {0.1: "steady", 1.0: "steady", 10.0: "coherent", 100.0: "drifting",
                     1000.0: "metastable"}[phi]
            rows.append({"N": n, "phi": phi, "seed": seed, "t_end": t_end, "t_run": t_end,
                         "state": state, "t_equil": 0.0 if phi == 1000 else -1.0,
                         "start": start})
    return pd.DataFrame(rows)


def test_the_relaxation_figure_draws_verdicts_not_equilibration_times(
        paper_figures, figures, monkeypatch, tmp_path):
    """Every run with a length is drawn at it, on a log axis that holds nothing non-positive;
    a run without one (t_run 0 or missing) is left out and counted in the title; each
    verdict has its colour and words in the key; no equilibration time is drawn."""
    paper = pd.concat([_runs(100, t) for t in (1000.0, 4000.0)] + [_runs(400, 1000.0)])
    steady = _runs(100, 1e5, "random").assign(t_run=lambda d: 600.0 * d.phi ** 0.5)
    steady.loc[0, "t_run"] = 0.0
    steady.loc[1, "t_run"] = math.nan
    tables = {"paper": paper, "steady": steady}
    monkeypatch.setattr(paper_figures, "sweep_tables",
                        lambda out, name, where=None: (tables[name], None) if name in tables
                        else None)
    paper_figures.relaxation_figure(tmp_path, tmp_path)
    fig = figures["relaxation.png"]
    assert hidden_points(fig) == []
    drawn = 0
    for ax in fig.axes:
        if ax.get_yscale() == "log":
            for ln in ax.get_lines():
                y = np.asarray(ln.get_ydata(), float)
                assert (y > 0).all()
                drawn += len(y)
    assert drawn == len(paper) + len(steady) - 2
    title = fig.get_suptitle()
    assert "2 run(s) without a length left out" in title and "equilibration" in title
    keyed = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    for v in ("steady", "switching", "drifting", "metastable"):
        assert paper_figures.RELAXATION_STATES[v][1] in keyed, v
    assert any("t_end = 1000, 4000" in k for k in keyed)
    assert any("cap 100000" in k for k in keyed)
    assert not any("equil" in (ax.get_ylabel() + ax.get_title()) for ax in fig.axes)


def _clusters(rng, n=400):
    eq2 = 10 ** rng.uniform(-5, 0, n)
    change = eq2 * 10 ** rng.normal(0.5, 0.8, n) * np.where(rng.random(n) < 0.25, -1, 1)
    eq2[:40] = 0.0             # spanning both axes: no perimeter
    change[40:45] = 0.0        # no change
    return pd.DataFrame({"eq2_estimate": eq2, "bond_change": change,
                         "phi": rng.choice(PHI, n)})


def test_the_energy_figure_shows_every_cluster_or_says_why_not(energy, figures, tmp_path):
    """Rise above, fall below: every cluster with a perimeter and a change is a point (none
    off its log axes: the fall's size on the same upright log axes, whose corner labels no
    longer collide); those without a perimeter and those that did not change are counted in
    the figure; no twin axis; the key below, covering nothing; the shares are claim 4's
    regimes (LC, DT)."""
    rng = np.random.default_rng(5)
    per = pd.DataFrame({"phi": PHI, "LC": [0, 0, 0.01, 0.1, 0.4],
                        "DT": [0.3, 0.2, 0.01, 0, 0], "slip_median": 0.1})
    found = {(label, 100): {"clusters_table": _clusters(rng), "per_phi": per,
                            "delta_star": 1.33}
             for label in energy.ENERGY_CURVES}
    energy.energy_figure(found, tmp_path)
    fig = figures["energy_argument.png"]
    assert hidden_points(fig) == []
    g = pd.concat(f["clusters_table"] for f in found.values())
    shown = g[(g.eq2_estimate > 0) & (g.bond_change != 0)]
    from matplotlib.collections import PathCollection

    points = [c.get_offsets() for ax in fig.axes for c in ax.collections
              if isinstance(c, PathCollection)]
    assert sum(len(p) for p in points) == len(shown)
    for p in points:
        assert (np.asarray(p) > 0).all()
    assert not [ax for ax in fig.axes if ax.yaxis_inverted()]
    assert any("fell" in ax.get_ylabel() for ax in fig.axes)
    keyed = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    assert any(k.startswith("LC") for k in keyed) and any(k.startswith("DT") for k in keyed)
    notes = " ".join(t.get_text() for ax in fig.axes for t in ax.texts)
    assert f"not drawn: {(g.eq2_estimate == 0).sum()} of all {len(g)} clusters" in notes
    assert f"{((g.eq2_estimate > 0) & (g.bond_change == 0)).sum()} changed by exactly 0" \
        in notes
    boxes = [tuple(np.round(ax.get_position().bounds, 3)) for ax in fig.axes]
    assert len(boxes) == len(set(boxes)), "two axes in one place: a twin axis"
    assert not any(ax.get_legend() for ax in fig.axes)


def test_the_aspect_share_figure_tells_all_six_lattices_apart(
        aspect, sweeps, figures, monkeypatch, tmp_path):
    """Six lattices, six styles (colour: the aspect ratio; line and marker: the size; every
    marker filled), each keyed with its size and N, the key below the axes, an error bar over
    the seeds on every point."""
    rows = []
    for lx, ly in sweeps.ASPECT_SIZES:
        for phi in PHI:
            for seed in (1, 2, 3):
                rows.append({"Lx": lx, "Ly": ly, "phi": phi, "seed": seed, "n_clusters": 100,
                             "regime_fractions[DT]": 0.5 / (1 + phi) * lx / (lx + ly)
                             * (1 + 0.05 * seed)})
    monkeypatch.setattr(aspect, "read_tables", lambda d: (pd.DataFrame(rows), None))
    aspect.aspect_share_figure(tmp_path, tmp_path)
    fig = figures["aspect_dt_share.png"]
    assert hidden_points(fig) == []
    (ax,) = fig.axes
    lines = [ln for ln in ax.get_lines() if ln.get_marker() not in ("None", "", "_")]
    styles = {(ln.get_color(), ln.get_marker(), ln.get_linestyle()) for ln in lines}
    assert len(lines) == len(styles) == 6
    assert all(ln.get_markerfacecolor() == ln.get_color() for ln in lines)
    from matplotlib.collections import LineCollection

    bars = [c for c in ax.collections if isinstance(c, LineCollection)]
    assert len(bars) == 6 and all(len(b.get_segments()) == len(PHI) for b in bars)
    keyed = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    assert keyed == [f"N = {lx * ly}: {lx}x{ly} (Lx/Ly = {lx / ly:g})"
                     for lx, ly in sweeps.ASPECT_SIZES]


def _wp_runs(seed=0):
    """Runs of timestep.py's records, synthetic: a bias of -a C^2 plus noise per seed."""
    rng = np.random.default_rng(seed)
    rows = []
    for n in (100, 400):
        for phi in (0.1, 1000.0):
            for s in range(1, 4):
                x0 = 0.11 * (1 + 0.002 * rng.standard_normal())
                for c in (0.025, 0.05, 0.1, 0.2, 0.4, 1.0, 1.5):
                    rows.append({"N": n, "phi": phi, "seed": s, "C": c,
                                 "stress": x0 * (1 - 0.01 * c ** 2) + 1e-6 * rng.standard_normal(),
                                 "mu_bar": 1.04 * x0 * (1 - 0.01 * c ** 2)})
    return pd.DataFrame(rows)


def test_work_precision_marks_the_presets_and_targets_and_redraws_from_its_record(
        work_precision, tmp_path):
    """The bias is against the dt -> 0 extrapolation of the three smallest steps (a bias
    falling as C^2 comes back as such); the plot draws a panel per phi and observable (each
    titled with both), a line per size in it, every preset's step on each line, every target,
    data inside the axes and none under the key, the key outside the panels, no text under
    7 pt; --from-record redraws it from the record alone."""
    import matplotlib.pyplot as plt

    from bkflow.model.timestep import ACCURACY

    wp = work_precision
    t = wp.table(_wp_runs())
    one = t[(t.N == 100) & (t.phi == 0.1)].set_index("C")
    assert one.loc[1.0, "mu_bar_bias"] == pytest.approx(-0.01, rel=1e-6)
    assert one.loc[0.4, "mu_bar_bias"] == pytest.approx(-0.0016, rel=1e-6)
    assert list(one.in_reference) == [True] * 3 + [False] * 4
    fig = wp.plot(t, tmp_path / "wp.png")
    try:
        assert (tmp_path / "wp.png").stat().st_size > 10000
        assert hidden_points(fig) == []
        texts = [x.get_text() for leg in fig.legends for x in leg.get_texts()]
        assert {"N = 100", "N = 400"} <= set(texts)
        for name, p in ACCURACY.items():
            assert f"{name} preset" in texts
            assert f"{name}'s target: +-{100 * p.dt_error:g}%" in texts
        assert len(fig.axes) == 2 * len(wp.OBSERVABLES)       # two phi, each observable
        assert {ax.get_title() for ax in fig.axes} == {
            f"phi = {phi:g}: bias of {label}" for phi in (0.1, 1000) for _, label in wp.OBSERVABLES}
        r = fig.canvas.get_renderer()
        key = fig.legends[0].get_window_extent(r)
        for ax in fig.axes:
            assert ax.get_xlabel() in ("", "cost: steps per time unit")
            assert not key.overlaps(ax.get_window_extent(r)), "the key lies on a panel"
            marked = {ln.get_label() for ln in ax.get_lines() if len(ln.get_xydata())
                      and ln.get_marker() in wp.MARKERS.values()}
            assert {f"{name} preset, N = {n}" for name in ACCURACY for n in (100, 400)} <= marked
            targets = {round(ln.get_ydata()[0], 9) for ln in ax.get_lines()
                       if ln.get_linestyle() == "--" and ln.get_xydata()[0][0] == 0}
            assert targets == {round(100 * p.dt_error, 9) for p in ACCURACY.values()}
        assert small_text(fig) == []
    finally:
        plt.close(fig)
    record = tmp_path / "record.csv"
    wp.write_record(t, record)
    pd.testing.assert_frame_equal(wp.read_record(record), t, check_dtype=False)
    wp.main(["--from-record", str(record), "--plot", str(tmp_path / "again.png")])
    assert (tmp_path / "again.png").stat().st_size > 10000
