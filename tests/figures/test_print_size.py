"""The figures of ``bkflow plot`` drawn from a made-up sweep (no run, no LAMMPS: a few seconds),
made to hold what a referee found hard to read at print size: two sizes whose points take every
state, a stiff end where Psi(inf) of the sizes differs by many standard errors at 0.99, clusters
past a whole-box slip's extent and a phi of few clusters, power laws that pass the bootstrap but
lose to a lognormal, p below the bootstrap's resolution, metastable and drifting runs beside
steady ones, and a switching run's contacts. Each figure: every point inside its axes and off the
keys, no text under ``MIN_FONT`` (the helpers of test_figures.py), every marker style keyed; and
item by item what the referee asked for."""

from __future__ import annotations

import re
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from bkflow.analysis import summary_keys as observables
from bkflow.figures import catalogue, clusters, drops, order, style, writer
from bkflow.figures.declared import fig_declared
from bkflow.figures.legends import state_handles
from bkflow.model.lattice import box_extent
from tests.figures.reading import (
    data_lines,
    draw_as_saved,
    figure_legends,
    laws_and_title,
    marked_lines,
    marker_styles,
    outside_or_hidden,
    rgb,
    small_text,
    unit_problems,
    unkeyed_styles,
)

SIZES = ((20, 5), (40, 10))
#: the paper's three sizes (``_Sweep(PAPER_SIZES)``), whose keys hold one size more
PAPER_SIZES = ((20, 5), (40, 10), (60, 15))
PHI = (0.1, 1.0, 10.0, 100.0, 1000.0)
SEEDS = (1, 2)
#: each (phi, seed)'s run state: every point state at each size (10: switching, 100: drifting,
#: 1000: one seed metastable beside a steady one)
RUN_STATE = {0.1: ("steady", "steady"), 1.0: ("steady", "steady"),
             10.0: ("coherent", "quiet+coherent"), 100.0: ("drifting", "steady"),
             1000.0: ("metastable", "steady")}
POINT_STATE = {0.1: "steady", 1.0: "steady", 10.0: "coherent", 100.0: "drifting",
               1000.0: "metastable"}
#: Psi(inf) and its error at (size, phi): at the stiff end the sizes differ by ~4 errors at 0.995
PSI = {(20, 5): (0.56, 0.74, 0.947, 0.985, 0.9948), (40, 10): (0.55, 0.73, 0.946, 0.987, 0.9962),
       (60, 15): (0.55, 0.72, 0.946, 0.988, 0.9968)}
PSI_SEM = {(20, 5): 3e-4, (40, 10): 1e-4, (60, 15): 1e-4}
#: the power-law verdicts at each phi and seed: (verdict, p, R against a lognormal, its p,
#: exponent): at 0.1 the law is drawn; at 1 it passes but a lognormal is better; at 100 the
#: drifting seed 1 is left out and the steady seed 2 rejects it with no bootstrap sample worse;
#: at 1000 the metastable seed 1 (exponent 3) is left out and the steady seed 2's law drawn
FITS = {0.1: (("plausible", 0.43, 0.5, 0.6, 2.0), ("plausible", 0.35, 0.4, 0.7, 2.2)),
        1.0: (("plausible", 0.18, -3.0, 0.01, 2.5), ("plausible", 0.25, -2.5, 0.02, 2.4)),
        10.0: (("rejected", 0.003, -4.0, 0.001, 3.0), ("rejected", 0.01, -4.0, 0.001, 3.1)),
        100.0: (("plausible", 0.5, 0.5, 0.6, 2.0), ("rejected", 0.0, 0.1, 0.5, 2.0)),
        1000.0: (("plausible", 0.6, 0.5, 0.6, 3.0), ("plausible", 0.6, 0.5, 0.6, 2.0))}
#: the clusters per seed at each phi (1000: few); at 0.1 some reach past the whole box's extent
CLUSTERS = {0.1: 400, 1.0: 300, 10.0: 200, 100.0: 150, 1000.0: 15}
BEYOND = 1.2


class _Run:
    """What the figures read of one made-up run directory."""

    def __init__(self, row):
        self.row = row
        self.rng = np.random.default_rng(int(row.seed) * 7 + int(row.Lx) + int(10 * row.phi))

    def spec(self):
        return SimpleNamespace(dt=0.01, snapshot_every=20.0)

    def keeps_raw_stress(self):
        return True

    def stress_outline(self, spec):
        t = np.linspace(0.0, 1000.0, 4001)
        return t, 0.5 + 0.05 * np.abs(np.sin(t / 5.0)) + 0.002 * self.rng.random(len(t))

    def read_events(self):
        n = 300
        drop = 0.01 * (1.0 + self.rng.pareto(1.5, n))
        return pd.DataFrame({"t_max": np.linspace(0.0, 1000.0, n), "sigma_fail": 0.55 + 0 * drop,
                             "drop": drop, "late": np.arange(n) >= 60,
                             "potency": 200.0 * drop})

    def read_clusters(self):
        n, (lx, ly) = CLUSTERS[float(self.row.phi)], (int(self.row.Lx), int(self.row.Ly))
        fx, fy = self.rng.random(n), self.rng.random(n)
        if float(self.row.phi) < 1:
            fy[: n // 10] = BEYOND
        fx[-1] = fy[-1] = 1.0                                 # a whole-box slip
        return pd.DataFrame({"event": np.arange(n) % 300, "n_c": 2 + (fx * lx * ly / 2).astype(int),
                             "l_x": fx * box_extent(lx, ly), "l_y": fy * box_extent(ly, lx)})

    def read_psi_table(self):
        t = np.arange(0.0, 1000.0, 20.0)
        psi = np.full(len(t), 0.99 - 0.1 / float(self.row.phi) ** 0.5)
        psi[0] = 1.0
        return pd.DataFrame({"t": t, "psi": psi})

    def read_reduced(self, spec):
        t = np.arange(10.0, 20000.0, 20.0)
        return SimpleNamespace(series=lambda: (t, 0.11 * self.row.sigma_n + 0 * t, None),
                               block=2000)

    def phase_series(self, spec, red):
        t = np.arange(10.0, 20000.0, 20.0)
        return pd.DataFrame({"t": t, "R": 0.3 + 0.02 * np.sin(t / 300.0)})


class _Sweep:
    """What the figures read of a sweep (``SweepData``'s face), of ``sizes`` (keys of
    ``PSI``); every key an observable declares a figure of (``fig_declared``) made up too."""

    def __init__(self, sizes=SIZES):
        rows = []
        for (lx, ly), phi, seed in ((s, p, k) for s in sizes for p in PHI for k in SEEDS):
            fit = FITS[phi][seed - 1]
            rows.append({
                "job": f"{lx}x{ly}-{phi}-{seed}", "Lx": lx, "Ly": ly, "phi": phi, "seed": seed,
                "state": RUN_STATE[phi][seed - 1], "mu_s": 0.2, "sigma_n": 5.0, "area": 1.0,
                "start": "random", "companion": "partial", "until_steady": True,
                "t_end": 1e5, "t_transient": 4000.0, "n_clusters": CLUSTERS[phi],
                "lx_over_ly": 4.0, "psi_inf": 0.9,
                "regime_fractions[C]": 0.9 if phi >= 10 else 0.1,
                "regime_fractions[DT]": 0.1 if phi >= 10 else 0.9,
                **{f"{key}_{col}": v for key in ("drop", "potency") for col, v in zip(
                    ("power_law", "fit_p", "vs_lognormal", "vs_lognormal_p", "exponent"), fit)},
                **{f"{key}_{col}": v for key in ("drop", "potency")
                   for col, v in (("exponent_err", 0.05), ("x_min", 0.0))},
            })
        self.runs = pd.DataFrame(rows)
        self.runs["drop_x_min"], self.runs["potency_x_min"] = 0.012, 2.4
        points = []
        for (lx, ly), psi in ((s, PSI[s]) for s in sizes):
            for k, phi in enumerate(PHI):
                mu = 0.12 - 0.002 * k - 0.001 * (lx == 40)
                points.append({
                    "Lx": lx, "Ly": ly, "phi": phi, "state": POINT_STATE[phi],
                    "mu_bar": mu, "mu_bar_sem": 3e-4, "mu_bar_large": mu + 0.003,
                    "mu_bar_large_sem": 4e-4, "mean_stress_ratio": mu - 0.004,
                    "mean_stress_ratio_sem": 2e-4, "lx_over_ly": 3.0 + 0.2 * k,
                    "lx_over_ly_sem": 0.05, "psi_inf": psi[k], "psi_inf_sem": PSI_SEM[(lx, ly)],
                    "regime": "DT" if phi < 1 else "C"})
        self.results = pd.DataFrame(points)
        for key in observables.figures().values():
            self.results[key] = self.results.mu_bar
        self.sizes = list(sizes)
        self.root = "made-up"

    def runs_of(self, lx, ly, phi=None):
        r = self.runs[(self.runs.Lx == lx) & (self.runs.Ly == ly)]
        return (r if phi is None else r[np.isclose(r.phi, phi)]).sort_values("seed")

    def results_of(self, lx, ly):
        r = self.results
        return r[(r.Lx == lx) & (r.Ly == ly)].sort_values("phi")

    def run_dir(self, row):
        return _Run(row)


#: the figures of the made-up sweep (the declared ones need keys it has not made up)
NAMES = ("fig1b_stress", "fig2a_friction", "fig2b_asymmetry", "fig3_order", "fig4a_clusters",
         "fig_drops", "fig_potency", "fig_contacts")


@pytest.fixture(scope="module")
def made_up():
    data = _Sweep()
    return data, {name: draw_as_saved(catalogue.figure(data, name)) for name in NAMES}


# --------------------------------------------------------------------------- every figure
@pytest.mark.parametrize("name", NAMES)
def test_every_point_inside_its_axes_and_no_small_text(made_up, name):
    from matplotlib.text import Text

    fig = made_up[1][name]
    assert outside_or_hidden(fig) == [], name
    small = [(t.get_text(), t.get_fontsize()) for t in fig.findobj(Text)
             if t.get_visible() and t.get_text().strip()
             and t.get_fontsize() < style.MIN_FONT - 1e-9]
    assert small == [], small[:5]


@pytest.mark.parametrize("name", NAMES)
def test_every_marker_style_drawn_is_keyed(made_up, name):
    """Each marker shape and fill drawn on a panel (a point's state, a population) is one a
    key of the figure shows: a reader can look every marker up."""
    assert unkeyed_styles(made_up[1][name]) == [], name


@pytest.mark.parametrize("name", NAMES)
def test_every_axis_says_its_unit_a_density_the_inverse_of_its_quantitys(made_up, name):
    """No unit-less axis: a probability density (fig_drops, fig_potency) is per unit of its
    quantity, and says so (test_figures.DENSITY_UNITS)."""
    assert unit_problems(made_up[1][name]) == [], name


# --------------------------------------------------------------------------- print size
#: every figure ``bkflow plot`` draws (its catalogue, ``catalogue.FIGURES``), and one of the
#: family an observable declares (``fig_declared``, here of mu_bar: none may be declared)
PRINTED = (*catalogue.FIGURES, "fig_declared")


def _saved(data, name, out):
    """The Figure ``name`` (of ``PRINTED``) of ``data`` and its PNG as ``bkflow plot`` saves
    it (``writer.save_figure``: trimmed, at bkflow's resolution)."""
    if name == "fig_declared":
        with style.style():
            fig = fig_declared(data, style.Figures(), key="mu_bar")
    else:
        fig = catalogue.figure(data, name)
    (path,) = writer.save_figure(fig, out, name, ("png",))
    return fig, path


@pytest.mark.parametrize("sizes", [SIZES, PAPER_SIZES], ids=["two sizes", "the paper's three"])
@pytest.mark.parametrize("name", PRINTED)
def test_every_figure_fits_a_7_inch_column_with_no_text_under_7_pt(name, sizes, tmp_path):
    """Every figure of the catalogue, as saved, at most ``style.COLUMN_WIDTH`` (7 in) wide, so
    that it prints in a 6.5-7 in column at its own size or larger, and none of its text under
    ``MIN_FONT`` (7 pt) at that size (fig_contacts was 9.7 in wide, fig2a_friction 10.1,
    fig3_order 7.7, fig_drops and fig_potency 7.5: their 7 pt text printed near 5 pt)."""
    from matplotlib.image import imread

    fig, path = _saved(_Sweep(sizes), name, tmp_path)
    width = imread(path).shape[1] / style.STYLE["savefig.dpi"]
    assert width <= style.COLUMN_WIDTH, f"{name}: {width:.2f} in wide"
    assert small_text(fig) == [], name


# --------------------------------------------------------------------------- item by item
def test_the_states_are_told_apart_by_shape_or_by_full_against_open():
    """At print size a half fill is hard to read: two states differ in their marker's shape,
    or one is filled and the other open; markers at least 6 pt with edges of 1 pt."""
    names = list(style.STATE_FILL)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            shapes = style.STATE_MARKER[a] != style.STATE_MARKER[b]
            fills = {style.STATE_FILL[a], style.STATE_FILL[b]} == {"full", "none"}
            assert shapes or fills, (a, b)
    for name in names:
        kw = style.state_marker(name, "tab:blue")
        assert kw["ms"] >= 5 and kw["mew"] >= 1.0
    handles, words = state_handles()
    assert words == [style.STATE_WORDS[n] for n in names]
    assert [(h.get_marker(), h.get_fillstyle()) for h in handles] == \
        [(style.STATE_MARKER[n], style.STATE_FILL[n]) for n in names]


def test_fig2a_marks_every_state_and_keys_the_regimes_in_words(made_up):
    fig = made_up[1]["fig2a_friction"]
    drawn = marker_styles(ln for ax in fig.axes for ln in data_lines(ax))
    assert drawn == {(style.STATE_MARKER[n], style.STATE_FILL[n]) for n in style.STATE_FILL}
    keyed = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    assert style.REGIME_WORDS["DT"] in keyed and "f_x < f_y" in style.REGIME_WORDS["DT"]
    assert style.REGIME_NOTE in keyed
    assert not any("longer across" in t for t in keyed)


def test_fig3_shows_the_sizes_apart_at_the_stiff_end(made_up):
    """Where Psi(inf) of the sizes lies within 0.2% of each other near 1, a panel of
    1 - Psi(inf) on a log axis draws them apart: at the stiffest phi the sizes' points lie
    further apart than their markers are wide."""
    fig = made_up[1]["fig3_order"]
    (low,) = [ax for ax in fig.axes if ax.get_ylabel() == r"$1 - \Psi(\infty)$"]
    assert low.get_yscale() == "log"
    points = marked_lines(data_lines(low))
    stiff = [low.transData.transform(xy)[1] for ln in points for xy in ln.get_xydata()
             if xy[0] == max(PHI)]
    assert len(stiff) == len(SIZES)
    dpi = fig.dpi
    assert abs(stiff[0] - stiff[1]) > style.STATE_SIZE * dpi / 72, stiff
    # (b) shows the stiff points, those whose Psi(inf) lies where (a)'s curves flatten
    ys = {round(1 - v, 6) for s in SIZES for v in PSI[s] if v >= order.PSI_ZOOM}
    drawn = {round(float(y), 6) for ln in points for y in ln.get_ydata()}
    assert drawn == ys


def test_fig4a_says_what_its_axes_are_and_shows_clusters_past_the_whole_box(made_up):
    fig = made_up[1]["fig4a_clusters"]
    panels = [ax for ax in fig.axes if data_lines(ax)]
    for ax in panels:
        assert "whole" in ax.get_xlabel() + ax.get_ylabel() or not ax.get_xlabel()
        for ln in data_lines(ax):
            if ln.get_marker() == "o":
                x, y = np.asarray(ln.get_xydata()).T
                assert ax.get_xlim()[1] >= x.max() and ax.get_ylim()[1] >= y.max()
    said = " ".join(leg.get_title().get_text() for leg in figure_legends(fig)).replace("\n", " ")
    assert "above 1" in said and f"up to {BEYOND:.3g}" in said
    # a few clusters: each share with its count; the counts add up to the panel's
    few = next(ax for ax in panels if ax.get_title().startswith(r"$\phi$ = 1000"))
    counts = [int(c) for c in re.findall(r"\((\d+)\)", few.get_title())]
    assert len(counts) == 2 and sum(counts) == len(SEEDS) * CLUSTERS[1000.0]


def test_fig_drops_title_and_key_come_from_one_verdict(made_up):
    """The title's count of the phi with a law drawn is the number of laws drawn and of key
    entries giving an exponent; a law that passes the bootstrap and loses to a lognormal is
    said to pass; p is never printed as 0.00."""
    fig = made_up[1]["fig_drops"]
    drawn, shown, keys = laws_and_title(fig)
    assert drawn == 2 and shown == len(clusters.cluster_phis(PHI))
    one = next(k for k in keys if k.startswith(r"$\phi$ = 1 "))
    assert "power law p >= 0.18" in one and "lognormal favoured" in one
    assert not any(re.search(r"p <= 0\.00\b", k) for k in keys)
    assert any("p < 0.001" in k for k in keys)


@pytest.mark.parametrize("p,words", [(0.0, "p < 0.001"), (0.0004, "p < 0.001"),
                                     (0.003, "p <= 0.003"), (0.034, "p <= 0.034"),
                                     (0.18, "p <= 0.18")])
def test_a_p_value_is_printed_to_the_bootstraps_resolution(p, words):
    assert drops._p_words("<=", p) == words


def test_fig_potency_fits_only_the_steady_or_switching_seeds(made_up):
    """At phi = 1000 seed 1 is metastable (its exponent 3) and seed 2 steady (2): the law drawn
    is seed 2's, and the key says one of two seeds was fitted; at 100 the drifting seed 1 is
    left out and its rejection by seed 2 stands."""
    data, figs = made_up
    runs = data.runs_of(20, 5, 1000.0)
    verdict = drops.power_law_verdict(runs, "potency")
    assert list(verdict.runs.seed) == [2] and verdict.drawn
    assert "1 of 2 seeds fitted" in verdict.words
    assert set(verdict.runs.state) <= {"steady", "coherent", "quiet", "quiet+coherent"}
    left = drops.power_law_verdict(data.runs_of(20, 5, 100.0), "potency")
    assert left.kind == "rejected" and list(left.runs.seed) == [2]
    ax = figs["fig_potency"].axes[0]
    (law,) = [ln for ln in data_lines(ax) if str(ln.get_marker()) in ("None", "none", "")
              and rgb(ln.get_color()) == rgb(style.phi_colour(1000.0))]
    x, y = np.asarray(law.get_xydata()).T
    assert np.polyfit(np.log(x), np.log(y), 1)[0] == pytest.approx(-2.0)
    for _, r in data.runs.iterrows():   # no verdict rests on a drifting or metastable seed
        v = drops.power_law_verdict(data.runs_of(r.Lx, r.Ly, r.phi), "potency")
        assert not set(v.runs.state) & {"drifting", "metastable"}


def test_fig_drops_and_potency_leave_no_gap_between_their_panels(made_up):
    for name in ("fig_drops", "fig_potency"):
        fig = made_up[1][name]
        r = fig.canvas.get_renderer()
        a, b = (ax.get_window_extent(r) for ax in fig.axes[:2])
        # the gap between the panels: about the right panel's tick labels and axis label
        assert b.x0 - a.x1 < 0.16 * fig.bbox.width, name


def test_fig1b_draws_the_friction_line_inside_its_range(made_up):
    data, figs = made_up
    top = float(data.runs.mu_s.iloc[0] * data.runs.sigma_n.iloc[0])
    for ax in figs["fig1b_stress"].axes:
        lo, hi = ax.get_ylim()
        assert lo <= top <= hi
        assert any(np.allclose(np.asarray(ln.get_ydata(), float), top) for ln in ax.get_lines())
        assert top in ax.get_yticks()


def _run_title(ax) -> str:
    """The title of the run whose panel ``ax`` of fig_contacts is: its row's."""
    return ax.get_figure(root=False).get_suptitle()


def test_fig_contacts_shades_a_switching_run_as_steady_and_keys_it(made_up):
    from matplotlib.colors import to_rgb

    fig = made_up[1]["fig_contacts"]
    keys = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    titles = [_run_title(ax) for ax in fig.axes]
    assert any(t.endswith("coherent") for t in titles), titles
    assert any("switching between the layer's steady states" in k for k in keys)
    for ax in fig.axes:
        for p in ax.patches:
            if _run_title(ax).endswith("coherent"):
                assert np.allclose(p.get_facecolor()[:3], to_rgb("tab:green"))
                assert p.get_hatch()


def _contacts_of_a_switching_run(stationary, drift: float, companion=None):
    """fig_contacts of the made-up sweep whose run shown at phi = 10 (seed 1) visited both
    states with its trend test as given (runs.csv ``stationary``, ``drift``, ``drift_err``;
    ``companion_start``: the run's companion, whose pair's mean stress the test reads), and
    run's title and the shaded spans of its row."""
    data = _Sweep()
    data.runs["companion_start"] = companion
    shown = (data.runs.phi == 10.0) & (data.runs.seed == 1)
    data.runs["state"] = data.runs["state"].where(~shown, "quiet+coherent")
    data.runs["stationary"], data.runs["drift"], data.runs["drift_err"] = True, 0.001, 0.004
    data.runs.loc[shown, ["stationary", "drift", "drift_err"]] = [stationary, drift, 0.004]
    fig = draw_as_saved(catalogue.figure(data, "fig_contacts"))
    row = [ax for ax in fig.axes if _run_title(ax).startswith(r"$\phi$ = 10,")]
    assert len(row) == 2          # the run's stress beside its R
    return fig, _run_title(row[0]), [p for ax in row for p in ax.patches]


def test_fig_contacts_shades_a_switching_run_whose_stress_still_drifts_as_not_steady():
    """A run that names its states (quiet+coherent) but whose trend test says its stress
    still drifts (runs.csv ``stationary`` False: the test the verdict reads, its error
    covering the switching) is shaded as not steady (orange, no hatch), never as one of
    the layer's steady states; its title gives its state as the tables do and the trend
    test's words. Trend-free, the same run is hatched green, and says so."""
    from matplotlib.colors import to_rgb

    fig, title, spans = _contacts_of_a_switching_run(False, -0.03)
    assert title.splitlines()[0].endswith(": quiet+coherent"), title
    assert title.splitlines()[1] == r"drift -3.00% $\pm$ 0.40%: the stress still drifts"
    assert spans and all(np.allclose(p.get_facecolor()[:3], to_rgb("tab:orange"))
                         and not p.get_hatch() for p in spans)
    keys = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    assert any(k.startswith("analysed window: not steady") and "still drifts" in k
               for k in keys), keys
    fig, title, spans = _contacts_of_a_switching_run(True, -0.003, "partial")
    assert r"pair's drift -0.30% $\pm$ 0.40%: trend-free" in title, title
    assert spans and all(np.allclose(p.get_facecolor()[:3], to_rgb("tab:green"))
                         and p.get_hatch() for p in spans)
