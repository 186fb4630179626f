"""The reproduction's own figures of its curves: fig2a_protocols (every curve's mu_bar and
stress against phi, ``protocols_figure``), relaxation (every run's verdict at the length it
ran, ``relaxation_figure``) and sizes (the steady curve against N, ``sizes_figure``); and how
each figure of the reproduction is saved (``write_figure``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from claims_record import SIZE_CURVES, size_trend
from paper_sweeps import LARGE_SIZE, OBSERVABLES, curves, sweep_tables

from bkflow.figures.data import point_states
from bkflow.figures.legends import state_handles
from bkflow.figures.style import STATE_FILL, STYLE, new_figures, state_marker
from bkflow.model.params import PAPER_SIZES


def write_figure(fig, path: Path) -> Path:
    """Save one of the reproduction's figures (PNG, bkflow's resolution, trimmed) at ``path``."""
    fig.savefig(path, dpi=STYLE["savefig.dpi"], bbox_inches="tight")
    return path


#: the curves' colours in fig2a_protocols (Okabe and Ito's colour-blind-safe palette: the
#: paper's run lengths orange, vermillion, reddish purple; the steady protocol blue and sky
#: blue; the synchronized start until steady bluish green) and line styles (the paper's run
#: lengths dotted, dashed, dash-dotted: told apart without colour too; the paper's first-order
#: scheme black, dash-dot-dotted)
CURVE_STYLE = {"paper, t_end = 1000": ("#E69F00", ":"),
               "paper, t_end = 4000": ("#D55E00", "--"),
               "paper, t_end = 16000": ("#CC79A7", "-."),
               "paper, first-order scheme, t_end = 16000": ("#000000", (0, (3, 1, 1, 1, 1, 1))),
               "steady protocol": ("#0072B2", "-"),
               "steady protocol, N = 3600": ("#56B4E9", "-"),
               "synchronized start until steady": ("#009E73", "-")}
#: the long-run curve (benchmarks/report/stiff_states.py writes it from the long runs: each
#: layer's mean over 10^6 time units from four starts, the seeds' mean), drawn in fig2a as the
#: truth the protocols are read against; its columns per figure row
LONG_RUN_CURVE = (Path(__file__).resolve().parents[2] / "benchmarks" / "records"
                  / "long_run_curve.csv")
LONG_RUN_FIELDS = {"mu_bar": "mu_bar", "mean_stress_ratio": "stress"}
LONG_RUN_LABEL = "long runs (each layer's long-run mean; benchmarks/RESULTS.md)"
#: the paper's claim 1: the minimum of mu_bar lies about 40% below mu_s
PAPER_MINIMUM_BELOW_MU_S = 0.4


def _mu_s(tables) -> float | None:
    """The static friction coefficient mu_s of the runs of ``tables`` (results or runs
    DataFrames), None when they used more than one."""
    values = {float(v) for t in tables if "mu_s" in t for v in t.mu_s.dropna()}
    return values.pop() if len(values) == 1 else None


#: fig2a_protocols' layout: two sizes side by side, each a column of the three observables
#: (OBSERVABLES), the next two sizes below: 6.8 in wide, so that, trimmed as saved, it prints
#: at its own size (no text under 7 pt) in a 7 in column; its height (in) per row of sizes,
#: and the key's
PROTOCOL_COLUMNS, PROTOCOL_WIDTH, PROTOCOL_HEIGHT, PROTOCOL_KEY_HEIGHT = 2, 6.8, 3.75, 1.15


def protocols_figure(out: Path, figs: Path) -> Path | None:
    """mu_bar, mu_bar over large drops and <sigma_x>/sigma_n against phi, one column of
    panels per N, two N side by side (PROTOCOL_COLUMNS: the figure fits a 7 in column), one
    curve per protocol and run length (colour and line style, CURVE_STYLE); a point's
    marker's shape and fill are its state, as in every bkflow figure
    (bkflow.figures.style.state_marker, keyed by bkflow.figures.legends.state_handles). Each
    observable's panels share one y range across N, so that a curve's depth can be compared
    between sizes; the right axis reads each value as a fraction below mu_s (the runs' static
    friction coefficient), and a grey line marks the paper's minimum, 40% below mu_s."""
    cs = curves(out)
    if not cs:
        return None
    long_run = pd.read_csv(LONG_RUN_CURVE) if LONG_RUN_CURVE.exists() else None
    ns = sorted({int(n) for _, res in cs.values() for n in res.N})
    fig, panels = _protocol_axes(new_figures(), ns)
    mu_s = _mu_s([res for _, res in cs.values()])
    present = set()
    for n, column in panels.items():
        for ax, (field, _, _) in zip(column, OBSERVABLES):
            present |= _protocol_panel(ax, cs, n, field, long_run, mu_s)
    _label_protocol_panels(fig, panels, mu_s)
    _protocol_key(fig, present, mu_s)
    return write_figure(fig, figs / "fig2a_protocols.png")


def _protocol_axes(plt, ns: list) -> tuple:
    """fig2a_protocols' figure and its panels, {N: [one axes per observable, top to bottom]}:
    PROTOCOL_COLUMNS sizes to a row of sizes, each observable's panels sharing one y range
    (its tick labels on the left column only), phi shared by every panel; the cells no size
    fills are hidden."""
    ncol = min(PROTOCOL_COLUMNS, len(ns))
    blocks = -(-len(ns) // ncol)
    k = len(OBSERVABLES)
    fig, axes = plt.subplots(k * blocks, ncol, squeeze=False, sharex=True, figsize=(
        PROTOCOL_WIDTH, PROTOCOL_HEIGHT * blocks + PROTOCOL_KEY_HEIGHT))
    fig.get_layout_engine().set(wspace=0.06)   # one column's 10^3 clear of the next's 10^-1
    panels = {n: [axes[(i // ncol) * k + row, i % ncol] for row in range(k)]
              for i, n in enumerate(ns)}
    for row in range(k):
        for n in ns[1:]:
            panels[n][row].sharey(panels[ns[0]][row])
    used = {id(ax) for column in panels.values() for ax in column}
    for ax in axes.flat:
        ax.set_visible(id(ax) in used)
    return fig, panels


def _protocol_panel(ax, cs: dict, n: int, field: str, long_run, mu_s) -> set:
    """One panel of fig2a_protocols: ``field`` against phi at N = ``n``, every curve of
    ``cs`` with its points' states, the long-run curve, and (a mu_bar) the paper's minimum;
    the states drawn."""
    present = set()
    for label, (_, res) in cs.items():
        g = res[res.N == n].sort_values("phi")
        if not len(g) or field not in g:
            continue
        c, ls = CURVE_STYLE[label]
        ax.errorbar(g.phi, g[field], yerr=g[f"{field}_sem"].fillna(0), color=c, lw=0.9,
                    ls=ls, capsize=1.5, marker="none", label=label, zorder=2)
        states = point_states(g)
        for name in STATE_FILL:
            k = states == name
            if k.any():
                present.add(name)
                ax.plot(g.phi[k], g[field][k], ls="none", zorder=3,
                        **state_marker(name, c, 6.0))
    lr = long_run[long_run.N == n].sort_values("phi") if long_run is not None else []
    if len(lr) and LONG_RUN_FIELDS.get(field) in lr:
        key = LONG_RUN_FIELDS[field]
        ax.errorbar(lr.phi, lr[key], yerr=lr[key + "_se"].fillna(0), color="0.55", lw=2.2,
                    alpha=0.8, capsize=1.5, marker="none", zorder=1, label=LONG_RUN_LABEL)
    if mu_s is not None and field.startswith("mu_bar"):  # claim 1 is about mu_bar
        ax.axhline((1 - PAPER_MINIMUM_BELOW_MU_S) * mu_s, color="0.55", lw=0.8,
                   ls=(0, (6, 3)), zorder=1)
    ax.set_xscale("log")
    return present


def _label_protocol_panels(fig, panels: dict, mu_s) -> None:
    """fig2a_protocols' labels: N over each column, the observable left of the left column,
    phi under each row of sizes (its ticks there too), and right of the right column the
    value as a fraction below mu_s, the paper's measure."""
    ns = list(panels)
    ncol = min(PROTOCOL_COLUMNS, len(ns))
    for i, (n, column) in enumerate(panels.items()):
        column[0].set_title(f"N = {n}", fontsize=8)
        column[-1].set_xlabel(r"$\phi = k_b/\Delta k_d$", fontsize=8)
        column[-1].tick_params(labelbottom=True)
        last = i % ncol == ncol - 1 or n == ns[-1]
        for ax, (_, _, label) in zip(column, OBSERVABLES):
            if i % ncol == 0:
                ax.set_ylabel(label, fontsize=7.5)
            else:
                ax.tick_params(labelleft=False)
            if last and mu_s is not None:
                right = ax.secondary_yaxis("right", functions=(
                    lambda y: 100 * (1 - np.asarray(y) / mu_s),
                    lambda p: mu_s * (1 - np.asarray(p) / 100)))
                right.set_ylabel(rf"below $\mu_s$ = {mu_s:g} (%)", fontsize=7.5)


def _protocol_key(fig, present: set, mu_s) -> None:
    """fig2a_protocols' key below its panels: the curves in its first rows, the paper's
    minimum beside them, the marker convention of the states ``present`` in its last rows."""
    from matplotlib.lines import Line2D

    found = {}
    for ax in fig.axes:  # a curve drawn at some N only (N = 3600) is keyed too
        for h, lab in zip(*ax.get_legend_handles_labels()):
            found.setdefault(lab, h)
    keys = [(found[lab], lab) for lab in (*CURVE_STYLE, LONG_RUN_LABEL) if lab in found]
    if mu_s is not None:
        keys.append((Line2D([], [], color="0.55", lw=0.8, ls=(0, (6, 3))),
                     rf"the paper's minimum of $\overline{{\mu}}$: "
                     rf"{100 * PAPER_MINIMUM_BELOW_MU_S:.0f}% below $\mu_s$"))
    ncol = 2
    keys += [(Line2D([], [], alpha=0), "")] * (-len(keys) % ncol)
    keys += list(zip(*state_handles(present)))
    handles, labels = zip(*_row_major(keys, ncol))
    fig.legend(handles, labels, loc="outside lower center", ncol=ncol, frameon=False,
               fontsize=7, handlelength=2.6)


def _row_major(keys: list, ncol: int) -> list:
    """``keys`` reordered so that a legend of ``ncol`` columns (which fills column by
    column) shows them row by row; the last row padded with blank keys."""
    from matplotlib.lines import Line2D

    keys = list(keys) + [(Line2D([], [], alpha=0), "")] * (-len(keys) % ncol)
    rows = len(keys) // ncol
    return [keys[r * ncol + c] for c in range(ncol) for r in range(rows)]


#: the sets of runs in the relaxation figure: (protocol directory, its start and rule in
#: words, marker)
RELAXATION_SETS = (("paper", "synchronized start, a fixed length (the paper's protocol)", "o"),
                   ("sync_steady", "synchronized start, until steady", "D"),
                   ("steady", "random start, until steady (the steady protocol)", "s"),
                   ("steady_3600", "random start, until steady (the steady protocol)", "s"))
#: a run's verdict (runs.csv ``state``) as a colour (Okabe and Ito's palette) and words
RELAXATION_STATES = {
    "steady": ("#0072B2", "steady: the start forgotten"),
    "switching": ("#009E73", "in the layer's own states (quiet / coherent): the start "
                             "forgotten"),
    "drifting": ("#E69F00", "drifting: not settled yet"),
    "metastable": ("#D55E00", "metastable: still remembers its start"),
    "none": ("0.6", "no verdict")}


def _run_verdicts(runs: pd.DataFrame) -> np.ndarray:
    """Each run's verdict as RELAXATION_STATES names it."""
    from bkflow.observables.states import SWITCHING

    states = runs["state"].astype(object).where(runs["state"].notna(), "none").astype(str) \
        if "state" in runs else pd.Series("none", index=runs.index)
    states = np.where(states.isin(SWITCHING), "switching", states.to_numpy())
    return np.where(np.isin(states, list(RELAXATION_STATES)), states, "none")


def relaxation_figure(out: Path, figs: Path) -> Path | None:
    """How long the start is remembered, from the verdicts alone: every run (each seed) at
    phi and at the length it ran (t_run: the paper's fixed lengths, or where a run until
    steady stopped: steady and within its error target, or at its cap), coloured by its
    state, one column per N. A drift or a flat plateau that still remembers the start cannot
    pass for a forgotten start here: the verdict reads the stress's trend and the contacts'
    phases (docs/model.md "Steady state"). No equilibration time is drawn: Chodera's
    detection answers tens of time units on a slow drift and 0 on the synchronized plateau
    (benchmarks/measure/stationarity.py measures it)."""
    sets = []
    for name, words, marker in RELAXATION_SETS:
        t = sweep_tables(out, name)
        if t is not None:
            sets.append((name, words, marker, t[0]))
    if not sets:
        return None
    ns = sorted({int(n) for *_, runs in sets for n in runs.N})
    plt = new_figures()
    ncols = min(len(ns), 2)
    nrows = -(-len(ns) // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(3.4 * ncols + 0.4, 2.7 * nrows + 1.3),
                             squeeze=False, sharex=True, sharey=True)
    for ax in axes.flat[len(ns):]:
        ax.set_visible(False)
    axes = axes.flat
    present, markers, left_out = set(), {}, 0
    for col, n in enumerate(ns):
        ax = axes[col]
        for _, words, marker, runs in sets:
            g = runs[runs.N == n]
            if not len(g):
                continue
            drawn = _draw_relaxation_runs(ax, g, marker, present)
            left_out += len(g) - len(drawn)
            markers.setdefault(words, (marker, set()))[1].update(
                {(n, float(t)) for t in drawn.t_end})
        _label_relaxation_panel(ax, n, bottom=col >= len(ns) - ncols, left=col % ncols == 0)
    # the states in the first column, the sets of runs in the second
    fig.legend(*_relaxation_key(present, markers), loc="outside lower center", ncol=2,
               frameon=False, fontsize=6.5)
    fig.suptitle("How long the start is remembered: every run's verdict at the length it ran\n"
                 "(the verdict reads the stress's trend and the contacts' phases: neither a "
                 "drift nor a plateau that\nremembers the start passes for steady; no "
                 "equilibration time is drawn: a slow drift fools it)"
                 + (f"\n{left_out} run(s) without a length left out" if left_out else ""),
                 fontsize=7.5)
    return write_figure(fig, figs / "relaxation.png")


def _draw_relaxation_runs(ax, g: pd.DataFrame, marker: str, present: set) -> pd.DataFrame:
    """One set of runs ``g`` of one N on ``ax`` of the relaxation figure, each at phi and its
    length, coloured by its verdict (the verdicts drawn added to ``present``); the runs drawn
    returned: those without a length (none on a log axis) are left out."""
    t_run = g.t_run.to_numpy(float)
    ok = np.isfinite(t_run) & (t_run > 0)   # a log axis: a length must be > 0
    g, t_run = g[ok], t_run[ok]
    # the seeds of one phi side by side, within 0.2 decade (the grid's phi lie a
    # third of a decade apart: each phi's runs stay a group of their own)
    order = sorted(set(g.seed))
    rank = g.seed.map({s: i for i, s in enumerate(order)}).to_numpy(float)
    step = min(0.07, 0.2 / max(len(order) - 1, 1))
    x = g.phi.to_numpy(float) * 10 ** (step * (rank - (len(order) - 1) / 2))
    ms = 3.8 if len(order) <= 4 else 2.8
    verdicts = _run_verdicts(g)
    for v, (colour, _) in RELAXATION_STATES.items():
        k = verdicts == v
        if k.any():
            present.add(v)
            ax.plot(x[k], t_run[k], marker, ls="none", ms=ms, color=colour, mew=0.3,
                    mec="white", alpha=0.9)
    return g


def _label_relaxation_panel(ax, n: int, bottom: bool, left: bool) -> None:
    """The relaxation figure's panel of N = ``n``: its title and log axes, phi under it in the
    ``bottom`` row, the length left of it in the ``left`` column."""
    lx, ly = (PAPER_SIZES[n] if n in PAPER_SIZES else LARGE_SIZE)
    ax.set_title(f"N = {n} ({lx}x{ly})", fontsize=9)
    ax.set_xscale("log")
    ax.set_yscale("log")
    if bottom:
        ax.set_xlabel(r"$\phi$")
    if left:
        ax.set_ylabel(r"its length $t_{\rm run}$ ($\sqrt{m/k_d}$)")


def _relaxation_key(present: set, markers: dict) -> tuple[list, list]:
    """The relaxation figure's key (handles, labels): the verdicts ``present``, then each set
    of runs drawn (``markers``: its words -> its marker and (N, t_end) pairs) with its
    lengths or caps."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles = [Patch(color=RELAXATION_STATES[v][0]) for v in RELAXATION_STATES if v in present]
    labels = [RELAXATION_STATES[v][1] for v in RELAXATION_STATES if v in present]
    for words, (marker, ends) in markers.items():
        handles.append(Line2D([], [], marker=marker, ls="none", color="0.35", ms=4))
        labels.append(words + ": " + _lengths(ends, "fixed" in words))
    return handles, labels


def _lengths(ends: set, fixed: bool) -> str:
    """The lengths (fixed) or caps of a set of runs, from its (N, t_end) pairs: one list
    where every N has the same, else the most common and the others by N."""
    by_n = {}
    for n, t in ends:
        by_n.setdefault(n, set()).add(t)
    groups = {}
    for n, ts in sorted(by_n.items()):
        groups.setdefault(tuple(sorted(ts)), []).append(n)
    common = max(groups, key=lambda k: len(groups[k]))
    word = "t_end = " if fixed else "cap "
    text = word + ", ".join(f"{t:g}" for t in common)
    others = [f"{', '.join(f'{t:g}' for t in ts)} at N = {', '.join(map(str, ns))}"
              for ts, ns in groups.items() if ts != common]
    return text + (f" ({'; '.join(others)})" if others else "")


def sizes_figure(out: Path, figs: Path) -> Path | None:
    """The steady curve as the lattice grows: mu_bar against N (log) at every phi all sizes
    were run at, with its error over seeds, and the line fitted on the sizes with at least 3
    seeds (size_trend); the sizes of fewer seeds drawn as diamonds (an open marker
    means a drifting point in bkflow's figures)."""
    cs = curves(out)
    steady = [cs[k][0] for k in SIZE_CURVES if k in cs]
    if not steady:
        return None
    trend = size_trend(pd.concat(steady, ignore_index=True))
    if not trend["phi"]:
        return None
    plt = new_figures()
    fig, ax = plt.subplots(figsize=(4.6, 3.8))
    from bkflow.figures.style import phi_colour

    for phi, v in trend["phi"].items():
        c = phi_colour(float(phi))
        n, m, e = (np.asarray(v[k], float) for k in ("N", "mean", "sem"))
        fit = np.isin(n, v["fitted"])
        ax.errorbar(n[fit], m[fit], yerr=e[fit], color=c, marker="o", ls="none", ms=4,
                    capsize=2, label=rf"$\phi$ = {phi}")
        ax.errorbar(n[~fit], m[~fit], yerr=np.nan_to_num(e[~fit]), color=c, marker="D",
                    ls="none", ms=4, capsize=2)
        if v["slope_per_decade"] is not None:
            x = np.log10(n)
            k = fit
            xm = np.average(x[k], weights=1 / e[k] ** 2)
            ym = np.average(m[k], weights=1 / e[k] ** 2)
            xs = np.linspace(x.min(), x.max(), 20)
            ax.plot(10 ** xs, ym + v["slope_per_decade"] * (xs - xm), color=c, lw=0.8)
    ax.set_xscale("log")
    ax.set_xlabel("N (particles)")
    ax.set_ylabel(r"$\overline{\mu}$ (steady protocol)")
    ax.set_title("The steady state as the lattice grows: circles, fitted (10 seeds);\n"
                 "diamonds, 2 seeds (not fitted); lines: the fit against log N", fontsize=7.5)
    fig.legend(*ax.get_legend_handles_labels(), loc="outside lower center", ncol=5,
               frameon=False, fontsize=7)
    return write_figure(fig, figs / "sizes.png")


