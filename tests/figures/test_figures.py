"""The figures of ``bkflow plot`` as a reader sees them at print size, drawn from a small real
sweep (the synchronized start until steady at phi = 10, 100, 1000, as the reproduction's
``sync_steady``; a few seconds of LAMMPS) and from synthetic tables: every point inside its
axes and off the keys, no text under ``MIN_FONT`` points, units on the axes, a key for every
colour, letter and shading that encodes something, one y range where panels are compared;
and what a referee found wrong, figure by figure (the protocol named as run, the text of
fig_drops following its data, fig_contacts' phi and smoothing, fig4a's fixed phi and
markers, fig1b's range, fig3's Psi samples, the potency's unit). test_print_size.py draws them
from a made-up sweep, without LAMMPS, for what the referee found hard to read at print size."""

from __future__ import annotations

import re
import subprocess
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from bkflow.figures import catalogue, clusters, drops, style
from bkflow.figures.data import SweepData
from bkflow.figures.legends import protocol_label
from tests.figures.reading import (
    data_lines,
    draw_as_saved,
    every_axes,
    key_colours,
    laws_and_title,
    outside_or_hidden,
    rgb,
    small_text,
    unit_problems,
    unkeyed_styles,
)
from tests.support import tool

SWEEP = ["--phi", "10,100,1000", "--start", "synchronized", "--seeds", "1", "--t-end", "400",
         "--jobs", "2", "--quiet"]


@pytest.fixture(scope="module")
def sweep(lammps, tmp_path_factory):
    out = tmp_path_factory.mktemp("figures") / "sync"
    proc = subprocess.run([tool("bkflow"), "sweep", *SWEEP, "--out", str(out)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    return out


@pytest.fixture(scope="module")
def drawn(sweep):
    """The sweep's data and every figure, drawn (tick labels and layout made) as saved."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    data = SweepData(sweep)
    figs = {}
    for name in catalogue.FIGURES:
        fig = catalogue.figure(data, name)
        with style.style():
            FigureCanvasAgg(fig).draw()
        figs[name] = fig
    return data, figs


# --------------------------------------------------------------------------- every figure
@pytest.mark.parametrize("name", list(catalogue.FIGURES))
def test_no_text_is_smaller_than_the_least_readable_size(drawn, name):
    _, figs = drawn
    small = small_text(figs[name])
    assert small == [], f"{name}: text under {style.MIN_FONT} pt: {small[:5]}"


@pytest.mark.parametrize("name", list(catalogue.FIGURES))
def test_every_point_lies_inside_its_axes_and_off_the_keys(drawn, name):
    _, figs = drawn
    assert outside_or_hidden(figs[name]) == [], name


@pytest.mark.parametrize("name", list(catalogue.FIGURES))
def test_every_marker_style_drawn_is_keyed(drawn, name):
    """Each marker shape and fill on a panel (a point's state, a phi, a population) is shown
    by a key of the figure."""
    _, figs = drawn
    assert unkeyed_styles(figs[name]) == [], name


@pytest.mark.parametrize("name", ["fig_drops", "fig_potency"])
def test_the_density_titles_and_keys_say_the_same(drawn, name):
    """The title's count of the phi with a law drawn, the laws drawn and the key's exponents
    agree; no p is printed as 0.00 (below the bootstrap's resolution: p < 0.001)."""
    _, figs = drawn
    _, _, keys = laws_and_title(figs[name])
    assert not any(re.search(r"p <= 0\.00?\b", k) for k in keys), keys


@pytest.mark.parametrize("name", list(catalogue.FIGURES))
def test_every_axis_says_what_it_shows_in_its_units(drawn, name):
    _, figs = drawn
    assert unit_problems(figs[name]) == [], name


@pytest.mark.parametrize("name", list(catalogue.FIGURES))
def test_every_colour_and_shading_that_encodes_something_is_keyed(drawn, name):
    """Within a panel, two or more colours of data (lines or markers) mean something: each
    is in a key of the figure; so is every shaded span's colour."""
    from matplotlib.patches import Polygon, Rectangle

    _, figs = drawn
    fig = figs[name]
    keyed = key_colours(fig)
    for ax in every_axes(fig):
        colours = {rgb(ln.get_color()) for ln in data_lines(ax)
                   if ln.get_transform() is ax.transData}
        if len(colours) > 1:
            assert colours - keyed == set(), f"{name}: colours without a key {colours - keyed}"
        spans = {rgb(p.get_facecolor()) for p in ax.patches
                 if isinstance(p, (Polygon, Rectangle)) and p is not ax.patch}
        assert spans - keyed == set(), f"{name}: shading without a key {spans - keyed}"


def test_panels_that_are_compared_share_their_ranges(drawn):
    _, figs = drawn
    stress = [ax for ax in figs["fig1b_stress"].axes if "sigma_x" in ax.get_ylabel()]
    assert len(stress) == 2 and stress[0].get_ylim() == stress[1].get_ylim()
    coherence = [ax for ax in figs["fig_contacts"].axes if ax.get_ylabel().startswith("$R")]
    assert len(coherence) == 3 and len({ax.get_ylim() for ax in coherence}) == 1
    panels = [ax for ax in figs["fig4a_clusters"].axes if data_lines(ax)]
    assert len(panels) == 3
    assert len({ax.get_xlim() for ax in panels}) == 1
    assert len({ax.get_ylim() for ax in panels}) == 1


# --------------------------------------------------------------------------- item by item
def _runs(**columns) -> SimpleNamespace:
    n = max(len(v) if isinstance(v, list) else 1 for v in columns.values())
    return SimpleNamespace(runs=pd.DataFrame({k: v if isinstance(v, list) else [v] * n
                                              for k, v in columns.items()}))


@pytest.mark.parametrize("columns,label", [
    ({"start": "random", "companion": "partial", "until_steady": True, "t_end": 1e5},
     "steady protocol"),
    ({"start": "synchronized", "companion": "partial", "until_steady": True, "t_end": 64000.0},
     "synchronized start until steady, partial companion"),
    ({"start": "synchronized", "companion": "partial", "until_steady": "True", "t_end": 64e3},
     "synchronized start until steady, partial companion"),
    ({"start": "random", "companion": np.nan, "until_steady": True, "t_end": 1e5},
     "random start until steady"),
    ({"start": "synchronized", "companion": np.nan, "until_steady": [False, False],
      "t_end": [1000.0, 16000.0]}, "paper's protocol, t_end = 1000, 16000"),
    ({"start": "random", "companion": np.nan, "until_steady": "False", "t_end": 8000.0},
     "fixed length, random start, t_end = 8000"),
    ({"start": ["random", "synchronized"], "companion": "partial",
      "until_steady": [True, False], "t_end": 8000.0}, "mixed protocols"),
])
def test_the_protocol_label_says_what_was_run(columns, label):
    assert protocol_label(_runs(**columns)) == label


def test_the_sweeps_figures_name_the_start_it_ran(drawn):
    """The synchronized start run until steady is not called the steady protocol anywhere."""
    from matplotlib.text import Text

    _, figs = drawn
    for name, fig in figs.items():
        texts = [t.get_text() for t in fig.findobj(Text)]
        assert not any("steady protocol" in t for t in texts), name
        if name != "fig2b_asymmetry":
            assert any("synchronized start until steady" in t for t in texts), name


def test_the_cluster_figures_show_fixed_phi():
    grid = [0.1, 0.215443, 0.464159, 1.0, 2.15443, 4.64159, 10.0, 21.5443, 46.4159, 100.0,
            215.443, 464.159, 1000.0]
    assert clusters.cluster_phis(grid) == [1000.0, 46.4159, 2.15443, 0.1]
    assert clusters.cluster_phis(grid + [3.0, 50.0]) == [1000.0, 46.4159, 2.15443, 0.1]
    assert clusters.cluster_phis([10.0, 100.0, 1000.0]) == [1000.0, 100.0, 10.0]
    assert clusters.cluster_phis([1.0, 1000.0]) == [1000.0, 1.0]


def test_phi_colours_are_sequential_and_not_the_papers_regime_code():
    from matplotlib.colors import rgb_to_hsv

    shades = [rgb_to_hsv(style.phi_colour(phi)[:3])[2] for phi in sorted(clusters.CLUSTER_PHI)]
    assert shades == sorted(shades, reverse=True)   # the stiffer, the darker
    regime = {rgb(c) for c in style.REGIME_COLOURS.values()}
    assert not {rgb(style.phi_colour(phi)) for phi in clusters.CLUSTER_PHI} & regime


def test_fig4a_draws_every_phi_visible_filled_and_counted(drawn):
    """One panel per phi: each shows all its clusters (the count in its title is the sweep's
    n_clusters), as filled circles in its phi's colour."""
    data, figs = drawn
    panels = [ax for ax in figs["fig4a_clusters"].axes if data_lines(ax)]
    shown = []
    for ax in panels:
        m = re.match(r"\$\\phi\$ = (\S+): (\d+) clusters", ax.get_title())
        assert m, ax.get_title()
        phi, count = float(m.group(1)), int(m.group(2))
        shown.append(phi)
        dots = [ln for ln in data_lines(ax) if ln.get_marker() == "o"]
        assert len(dots) == 1 and len(dots[0].get_xydata()) == count
        assert count == int(data.runs_of(20, 5, phi).n_clusters.sum())
        assert dots[0].get_markerfacecolor() not in ("none", "None", "white")
        assert rgb(dots[0].get_markerfacecolor()) == rgb(style.phi_colour(phi))
    assert shown == [1000.0, 100.0, 10.0]


def test_the_cluster_scatter_draws_the_densest_set_lowest_and_counts_each(drawn):
    data, _ = drawn
    fig = draw_as_saved(clusters.cluster_scatter(data, style.Figures(), 20, 5,
                                                 [10.0, 100.0, 1000.0], "t"))
    (ax,) = fig.axes
    sets = [ln for ln in data_lines(ax) if ln.get_marker() == "o"]
    sizes = [len(ln.get_xydata()) for ln in sets]
    assert len(sets) == 3
    order = sorted(sets, key=lambda ln: ln.get_zorder())
    assert [len(ln.get_xydata()) for ln in order] == sorted(sizes, reverse=True)
    assert all(ln.get_alpha() < 1 for ln in sets)
    keys = [t.get_text() for t in ax.get_legend().get_texts()]
    for n in sizes:
        assert any(f": {n} clusters" in k for k in keys), keys
    assert outside_or_hidden(fig) == []


@pytest.mark.parametrize("with_drops,words", [
    ((10.0, 100.0, 1000.0), "the stiffest of the three in (a)"),
    ((10.0, 1000.0), "the stiffest of the two in (a)"),
    ((1000.0,), "the only one in (a)"),
])
def test_fig_drops_counts_the_phi_it_drew(drawn, monkeypatch, with_drops, words):
    data, _ = drawn
    rng = np.random.default_rng(1)

    def late_drops(data, runs):
        phi = float(runs.phi.iloc[0])
        if phi not in with_drops:
            return np.empty(0), np.empty(0, bool)
        return 0.01 + np.exp(rng.normal(-3.5, 0.8, 500)), rng.random(500) < 0.5

    monkeypatch.setattr(drops, "_late_drops", late_drops)
    with style.style():
        fig = drops.fig_drops(data, style.Figures())
    left, right = fig.axes
    points = [ln for ln in data_lines(left) if ln.get_marker() not in ("None", "", None)]
    assert len(points) == len(with_drops)
    assert right.get_title().endswith(f"({words})"), right.get_title()


def test_fig_contacts_shows_each_phi_smoothed_over_one_stated_window(drawn):
    _, figs = drawn
    fig = figs["fig_contacts"]
    tops = [ax for ax in fig.axes if ax.get_ylabel() == r"$\sigma_x/\sigma_n$"]
    titles = [ax.get_figure(root=False).get_suptitle() for ax in tops]   # each run's row's
    phis = [float(re.match(r"\$\\phi\$ = (\S+),", t).group(1)) for t in titles]
    assert phis == [10.0, 100.0, 1000.0]
    said = {float(w) for leg in fig.legends for t in leg.get_texts()
            for w in re.findall(r"mean over (\S+) time units", t.get_text())}
    assert len(said) == 1
    window = said.pop()
    for ax in fig.axes:
        dark = [ln for ln in data_lines(ax) if rgb(ln.get_color()) in
                {rgb("black"), rgb("indigo")}]
        assert len(dark) == 1
        steps = np.diff(dark[0].get_xdata())
        assert np.median(steps) == pytest.approx(window, rel=0.1)
    assert len(fig.get_suptitle()) <= 80   # the detail is in the key and the docstring


def test_fig1b_fits_its_range_to_the_traces_and_draws_the_friction_line_in_it(drawn):
    """One y range for both panels, the traces filling at least 70% of each panel's height
    (they did not when a plain axis reached up to mu_s sigma_n), and mu_s sigma_n inside the
    range: where it lies far from the traces, beyond a break of the axis, its value a tick."""
    data, figs = drawn
    top = float(data.runs.mu_s.iloc[0] * data.runs.sigma_n.iloc[0])
    axes = figs["fig1b_stress"].axes
    ys = np.concatenate([ln.get_ydata() for ax in axes for ln in data_lines(ax)
                         if ln.get_transform() is ax.transData])
    r = figs["fig1b_stress"].canvas.get_renderer()
    for ax in axes:
        lo, hi = ax.get_ylim()
        assert lo <= top <= hi
        shown = ax.transData.transform(np.column_stack([np.zeros_like(ys), ys]))[:, 1]
        assert np.ptp(shown) >= 0.7 * ax.get_window_extent(r).height
        lines = [ln for ln in ax.get_lines() if ln.get_transform() is not ax.transData]
        assert any(np.allclose(np.asarray(ln.get_ydata(), float), top) for ln in lines)
        if ax.get_yscale() != "linear":   # a broken axis: the line's value is a tick
            assert top in ax.get_yticks()


def test_fig3_shows_psi_sample_by_sample_with_its_interval(drawn):
    data, figs = drawn
    panel = next(ax for ax in figs["fig3_order"].axes if ax.get_ylabel() == r"$1 - \Psi(t)$")
    assert panel.get_xscale() == "linear"
    every = float(re.search(r"every (\S+) time units", panel.get_title()).group(1))
    lines = data_lines(panel)
    assert lines
    for ln in lines:
        t = ln.get_xdata()
        assert ln.get_marker() not in ("None", "", None)   # every sample marked
        assert len(t) >= 10
        assert np.median(np.diff(t)) == pytest.approx(every, rel=0.01)
    snapshot = data.run_dir(data.runs.iloc[0]).spec().snapshot_every
    assert every == pytest.approx(snapshot, rel=0.01)


def test_the_potency_is_a_length(drawn):
    _, figs = drawn
    labels = [ax.get_xlabel() + ax.get_ylabel() for ax in figs["fig_potency"].axes]
    assert sum("potency" in lab for lab in labels) == 2
    for lab in labels:
        assert "l^3" not in lab
        if "potency" in lab:
            assert "($l$)" in lab


def test_fig2a_keys_its_regime_letters(drawn):
    _, figs = drawn
    fig = figs["fig2a_friction"]
    letters = {(t.get_text(), rgb(t.get_color())) for t in fig.axes[0].texts}
    assert letters
    from matplotlib.lines import Line2D

    keyed = {(re.sub(r"\$\\mathrm\{(\w+)\}\$", r"\1", str(h.get_marker())), rgb(h.get_color()))
             for leg in fig.legends for h in leg.findobj(Line2D)}
    assert letters <= keyed, letters - keyed


def test_the_checks_find_what_they_look_for():
    """The helpers above report a point outside its axes, a marker under a key, an unkeyed
    colour and text under the least size, and pass a figure without them."""
    fig, (a, b) = style.Figures().subplots(1, 2)
    a.plot([0, 1, 2], [0, 1, 2], "o", color="tab:red")
    a.set_ylim(0, 1.5)                                     # (2, 2) lies above the axes
    b.plot([0.5], [0.5], "s", color="tab:blue", label="under the key")
    b.plot([0, 1], [0, 1], color="tab:green")
    b.legend(loc="center")                                 # over the marker at (0.5, 0.5)
    draw_as_saved(fig)
    found = outside_or_hidden(fig)
    assert sum("outside its axes" in f for f in found) == 1
    assert sum("under a key" in f for f in found) == 1
    assert rgb("tab:blue") in key_colours(fig) and rgb("tab:green") not in key_colours(fig)
    a.set_title("small", fontsize=style.MIN_FONT - 1)
    assert small_text(fig) == [("small", style.MIN_FONT - 1)]
    fine, ax = style.Figures().subplots()
    ax.plot([0, 1], [0, 1], "o")
    assert outside_or_hidden(draw_as_saved(fine)) == []
    assert small_text(fine) == []


def test_the_unit_check_finds_a_density_without_its_unit():
    """A probability density is no pure number: its axis says the inverse of its quantity's
    unit, or the check reports it."""
    fig, (a, b) = style.Figures().subplots(1, 2)
    for ax in (a, b):
        ax.plot([1, 2], [1, 2], "o")
        ax.set_xlabel(r"stress drop $\Delta\sigma_x$ ($k_d/l$)")
    a.set_ylabel("probability density")
    b.set_ylabel("probability density (of all drops)")
    assert len(unit_problems(fig)) == 2
    a.set_ylabel(r"probability density of $\Delta\sigma_x$ ($l/k_d$)")
    b.set_ylabel(r"probability density of $\Delta\sigma_x$, all drops ($k_d/l$)")
    assert unit_problems(fig) == [f"{b.get_ylabel()!r}: a density without its unit ($l/k_d$)"]
    b.set_ylabel(a.get_ylabel())
    assert unit_problems(fig) == []
