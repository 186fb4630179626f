"""Figures of a sweep directory, one per figure of the paper (``bkflow plot DIR``).

Reads tables only: ``runs.csv``, ``results.csv`` and the records and tables of each run
(its reduced stress and phases, Psi(t), its slips' clusters, and what the analysis wrote:
events.parquet), through
``bkflow.store.tables`` and ``bkflow.store.rundir``; it never analyses. Writes PNG and PDF into
``DIR/figures``:

| file | what |
|---|---|
| ``fig1b_stress`` | sigma_x(t) of two runs (phi near 1e3 and 1), sigma_fail marked |
| ``fig2a_friction`` | mu_bar(phi) per size, error bars, regimes keyed; <sigma_x>/sigma_n beside |
| ``fig2b_asymmetry`` | <l_x>/<l_y>(phi) per size |
| ``fig3_order`` | Psi(inf)(phi) per size; beside it 1 - Psi(t) from the start, sample by sample |
| ``fig4a_clusters`` | l_y vs l_x of every slip cluster for the phi of ``CLUSTER_PHI`` |
| ``fig_drops`` | stress-drop sizes for the same phi, a power law where plausible |
| ``fig_potency`` | the slips' potencies for the same phi, and against their stress drops |
| ``fig_contacts`` | sigma_x(t) and the contacts' phase coherence R(t) of three runs |

Error bars are standard errors over seeds; with a single seed, the run's own standard error.
A figure whose data the sweep did not record (e.g. scene ``friction``: no clusters) is
skipped with a note, never drawn empty. No text of a figure is smaller than ``MIN_FONT``
points at its saved size (tests/test_figures.py checks this and the rest of what a reader
needs: every point inside its axes, units, a key for every code).
"""

from __future__ import annotations

import functools
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from bkflow.model.lattice import box_extent, box_fractions
from bkflow.model.params import SpecError, parse_typed, split_assignment
from bkflow.store.formats import MARK, atomic_file, foreign_file, read_text, shell_word
from bkflow.store.rundir import RunDir, sweep_run_dir
from bkflow.store.tables import FIGURES_DIR, read_tables, varied_parameters

FORMATS = ("png", "pdf")
MARKERS = ("o", "s", "D", "^", "v", "P")
#: the regimes' colours of the letters in fig2a (the paper's code: black, red, green, blue;
#: W, which the paper has not, grey), always with their key
REGIME_COLOURS = {"C": "black", "W": "tab:grey", "LC": "tab:red", "DP": "tab:green",
                  "DT": "tab:blue"}
#: the regimes in words, for the keys (bkflow.observables.clusters.regime)
REGIME_WORDS = {"C": "crystalline, the whole box slips",
                "W": "the whole box slips, not crystalline",
                "LC": "laminar crystalline: whole rows",
                "DP": "disordered, longer along x",
                "DT": "disordered, longer across x"}
#: phi of the Psi(t) panel (the paper's Fig. 3 inset)
INSET_PHI = (1e3, 1e2, 10.0, 1.0)
#: samples of Psi(t) (one every ``snapshot_every`` time units) that fig3's Psi(t) panel shows
#: from the start: on a linear time axis, each sample marked, so that the reader sees how few
#: samples the fall of Psi from 1 spans (it is over within the first two or three)
PSI_SAMPLES = 40
#: the phi of the cluster scatter (fig4a), fig_drops and fig_potency: the swept values
#: nearest these targets, log-evenly spaced over the default range 0.1 .. 1000 (4/3 of a
#: decade apart, so that on the default grid of 3 per decade each is a grid point). Fixed, so
#: that the figures of two sweeps or two versions show the same layers (they once showed the
#: phi where each regime was most frequent, which moved with the data)
CLUSTER_PHI = (1e3, 46.4159, 2.15443, 0.1)
#: the range of phi over which ``phi_colour`` runs: one colour per phi in every figure
PHI_RANGE = (0.1, 1000.0)
#: the smallest text of any figure, in points at its saved size
MIN_FONT = 7.0


def phi_colour(phi: float):
    """The colour of a phi where a figure draws a few phi as sets (fig4a, fig_drops,
    fig_potency): plasma over log10 phi in ``PHI_RANGE``, the stiff end dark, cut at 0.85
    (the yellow end is not seen on white; viridis made 0.1 and 2.15 two greens that a
    translucent scatter cannot tell apart). A sequential map, the same for a phi in every
    figure, whose hues cannot be read as the paper's regime code (black C, red LC, green DP,
    blue DT: its Fig. 4a draws regimes, not phi)."""
    from matplotlib import colormaps

    lo, hi = (math.log10(v) for v in PHI_RANGE)
    frac = min(1.0, max(0.0, (math.log10(phi) - lo) / (hi - lo)))
    return colormaps["plasma"](0.85 * (1.0 - frac))


class PlotError(ValueError):
    """The directory holds nothing to plot."""


#: bkflow's figure style, applied (matplotlib.rc_context) only while bkflow builds and saves
#: a figure: the user's rcParams are never changed
STYLE = {"font.size": 9, "axes.labelsize": 9, "legend.fontsize": 7.5, "xtick.labelsize": 8,
         "ytick.labelsize": 8, "lines.markersize": 4, "figure.dpi": 100, "savefig.dpi": 200,
         "savefig.bbox": "tight"}


class Figures:
    """What the figure functions need of pyplot, without pyplot's state: every figure is a
    ``matplotlib.figure.Figure`` of its own, never registered with pyplot, so that making one
    neither switches the backend nor touches (or closes) a user's open figures. A notebook
    shows the Figure it is given; files are written with ``Figure.savefig``."""

    def subplots(self, nrows=1, ncols=1, figsize=None, layout="constrained", **kw):
        fig = self.figure(figsize=figsize, layout=layout)
        return fig, fig.subplots(nrows, ncols, **kw)

    def figure(self, figsize=None, layout="constrained", **kw):
        """A Figure with a layout engine (constrained by default), so that it keeps its
        labels inside however it is saved: a plain ``savefig()`` cuts nothing off."""
        return _figure_class()(figsize=figsize, layout=layout, **kw)

    def close(self, fig=None):
        """Nothing to close: no figure is registered with pyplot."""


@functools.cache
def _figure_class():
    from matplotlib.figure import Figure

    class BkFigure(Figure):
        """A Figure that a notebook shows as a PNG even where pyplot (and with it the inline
        backend's display hook) was never imported."""

        def _repr_png_(self):
            import io as _io

            buf = _io.BytesIO()
            with style():
                self.savefig(buf, format="png", dpi=100, bbox_inches="tight")
            return buf.getvalue()

    return BkFigure


def style():
    """The context in which bkflow builds (and saves) its figures: ``STYLE``."""
    import matplotlib

    return matplotlib.rc_context(STYLE)


def _style() -> Figures:
    return Figures()


def _num(v: float) -> str:
    """A parameter value for a key: three significant digits, never an exponent
    (2.15443 -> 2.15, 1000 -> 1000)."""
    text = f"{v:.3g}"
    return f"{v:.0f}" if "e+" in text else text


def _size_label(lx, ly) -> str:
    return f"N = {int(lx) * int(ly)} ({int(lx)}x{int(ly)})"


def _nearest(values, target) -> float:
    values = np.asarray(sorted(set(values)), dtype=float)
    return float(values[np.argmin(np.abs(np.log10(values) - math.log10(target)))])


def _errors(g: pd.DataFrame, field: str) -> np.ndarray:
    """The point's error: for the fields whose runs carry their own error
    (tables.WITHIN_RUN_ERRORS) the larger of the seeds' standard error and the runs' errors
    combined (``<field>_err``, covering the switching between states); for the others the
    seeds' standard error; where a point has one seed, the run's own error."""
    sem = (g[f"{field}_err"] if f"{field}_err" in g else g[f"{field}_sem"]).to_numpy(
        dtype=float)
    own = f"{field}_err_within_run"
    if own in g:
        sem = np.where(np.isfinite(sem), sem, g[own].to_numpy(dtype=float))
    return np.where(np.isfinite(sem), sem, 0.0)


def parse_where(items) -> dict:
    """``["t_end=16000", "start=random"]`` -> {column: value} (numbers where they parse;
    none for a parameter left unset, NaN in the tables): bkflow.model.params' NAME=VALUE parser."""
    out = {}
    for item in items or ():
        try:
            key, text = split_assignment(item, "--where")
            value = None if not text.strip() else parse_typed(
                "any", text, f"--where {item!r}", none_words=("none", "nan"))
        except SpecError as exc:
            raise PlotError(f"{exc}; e.g. --where t_end=16000") from None
        out[key] = value
    return out


def _select(df: pd.DataFrame, where: dict) -> pd.DataFrame:
    for key, value in where.items():
        if key not in df:
            raise PlotError(f"--where {key}=...: the tables have no column {key!r}")
        col = df[key]
        if value is None:
            df = df[col.isna() | col.astype(str).str.lower().isin(("none", "nan", ""))]
        elif isinstance(value, bool):
            df = df[col.astype(str).str.lower() == str(value).lower()]
        elif isinstance(value, (int, float)):   # a number from Python, e.g. {"Lx": 20}
            df = df[np.isclose(pd.to_numeric(col, errors="coerce"), float(value), rtol=1e-9,
                               atol=0)]
        else:
            df = df[col.astype(str) == str(value)]
    return df


class SweepData:
    """The tables and per-run files of a sweep directory; ``where`` ({column: value}) keeps
    the runs of those parameters only (a directory may hold several sweeps)."""

    def __init__(self, root, where: dict | None = None):
        self.root = Path(root)
        try:
            self.runs, self.results = read_tables(self.root)
        except FileNotFoundError as exc:
            raise PlotError(f"{self.root} has no {Path(exc.filename).name}: is it a bkflow "
                            "sweep directory (bkflow sweep --out DIR)?") from None
        except pd.errors.EmptyDataError:
            raise PlotError(f"{self.root}: no finished runs to plot yet") from None
        if where:
            self.runs, self.results = _select(self.runs, where), _select(self.results, where)
            if self.runs.empty:
                raise PlotError(f"{self.root}: no finished run has "
                                + ", ".join(f"{k} = {v}" for k, v in where.items()))
        if self.runs.empty:
            raise PlotError(f"{self.root}: no finished runs to plot yet")
        self._check_one_analysis()
        self.sizes = sorted({(int(a), int(b)) for a, b in zip(self.runs.Lx, self.runs.Ly)},
                            key=lambda s: s[0] * s[1])

    def _check_one_analysis(self) -> None:
        """Figures come from one analysis: the tables', the sweep's (its project document)
        and every run's summary under the same settings, or none is drawn (an interrupted
        ``bkflow collect --analysis ...`` leaves some runs re-analysed and the tables old)."""
        import json

        from bkflow.model.params import AnalysisSettings
        from bkflow.store.tables import SETTINGS_FILE

        advice = ("(an interrupted bkflow collect?): run bkflow collect "
                  f"{shell_word(self.root)} to bring "
                  "them together, then plot")
        from bkflow.store.tables import settings_in

        try:
            tables = AnalysisSettings.from_dict(settings_in(json.loads(
                read_text(self.root / SETTINGS_FILE))))
        except FileNotFoundError:
            tables = AnalysisSettings()
        except (ValueError, TypeError, SpecError) as exc:
            raise PlotError(f"{self.root / SETTINGS_FILE} is unreadable ({exc}) {advice}") \
                from None
        try:
            doc = json.loads(read_text(self.root / "signac_project_document.json"))
            sweep = AnalysisSettings.from_dict(dict(doc.get("analysis_settings", {})))
        except (OSError, ValueError, TypeError, AttributeError, SpecError):
            sweep = tables
        #: the analysis settings the tables were made under (the regime rule's bounds)
        self.settings = tables
        if sweep != tables:
            raise PlotError(f"{self.root}: the sweep's analysis settings are not those its "
                            f"tables were made under {advice}")
        from bkflow.store.tables import StaleTablesError

        for job in self.runs["job"]:
            rd = sweep_run_dir(self.root, job)
            if rd.problem() is None and rd.analysis_problem(tables) is not None:
                raise StaleTablesError(f"{rd.path}: {rd.analysis_problem(tables)}, not the "
                                       f"tables' {advice}")

    def run_dir(self, row) -> RunDir:
        """The run directory of a runs.csv row, checked against its completion record (a
        figure never draws a cut file)."""
        rd = sweep_run_dir(self.root, row["job"])
        why = rd.problem()
        if why is not None:
            raise PlotError(f"{rd.path}: {why}: the sweep's own command (bkflow sweep ... --out "
                            f"{shell_word(self.root)}) redoes it")
        return rd

    def runs_of(self, lx, ly, phi=None) -> pd.DataFrame:
        r = self.runs[(self.runs.Lx == lx) & (self.runs.Ly == ly)]
        if phi is not None:
            r = r[np.isclose(r.phi, phi, rtol=1e-9, atol=0)]
        return r.sort_values("seed")

    def results_of(self, lx, ly) -> pd.DataFrame:
        return self.results[(self.results.Lx == lx) & (self.results.Ly == ly)].sort_values("phi")


def _check_targets(out: Path, formats, recorded) -> list[Path]:
    """The files a plot writes into ``out``; a user's file among them (not written by bkflow,
    not in ``recorded``, the names figures.json lists) is never replaced: PlotError."""
    targets = [out / f"{name}.{fmt}" for name in FIGURES for fmt in formats]
    for p in targets:
        why = foreign_file(p, recorded)
        if why is not None:
            raise PlotError(why)
    return targets


def _save(fig, out: Path, name: str, formats) -> list[Path]:
    """Write ``fig`` as ``out/name.FMT``, atomically and marked (targets checked before)."""
    paths = []
    for fmt in formats:
        p = out / f"{name}.{fmt}"
        meta = {"Creator": MARK} if fmt in ("png", "pdf", "svg", "ps", "eps") else None
        try:
            with atomic_file(p, binary=True) as f:  # SIGTERM or a full disk: the old figure
                fig.savefig(f, format=fmt, metadata=meta, dpi=STYLE["savefig.dpi"],
                            bbox_inches="tight")
        except (RuntimeError, ValueError) as exc:  # pgf without LaTeX, and the like
            why = " ".join(str(exc).split())[:160]
            raise PlotError(f"matplotlib cannot write {fmt} here ({why}); choose another "
                            "--format") from None
        paths.append(p)
    return paths


def fig1b_stress(data: SweepData, plt, window: float = 150.0):
    """sigma_x(t) over the last ``window`` time units of two runs (phi nearest 1e3 and 1),
    slips' sigma_fail marked. Both panels on one y range, fitted to the traces so that a
    reader compares their stick-slip by eye; the Amontons-Coulomb line mu_s sigma_n, far
    above the traces in a layer whose contacts break one by one, is drawn where it lies in
    that range and otherwise named in the right margin, its arrow pointing up (or down) to
    it (a range stretched to it left the traces a sliver of each panel)."""
    lx, ly = data.sizes[0]
    phis = sorted(set(data.runs_of(lx, ly).phi))
    chosen = list(dict.fromkeys([_nearest(phis, 1e3), _nearest(phis, 1.0)]))
    fig, axes = plt.subplots(len(chosen), 1, figsize=(6.0, 2.1 * len(chosen) + 0.5),
                             squeeze=False)
    lows, highs, tops = [], [], []
    outline = False
    for ax, phi, colour, marker in zip(axes[:, 0], chosen, ("black", "tab:red"), ("s", "o")):
        row = data.runs_of(lx, ly, phi).iloc[0]
        rd = data.run_dir(row)
        t, sigma = rd.stress_outline(rd.spec())   # the turning points, or the raw series
        ev = rd.read_events()
        t0 = t[-1] - window
        keep = t >= t0
        # the raw series where the run kept it, else the line through its turning points
        outline = outline or not rd.keeps_raw_stress()
        ax.plot(t[keep], sigma[keep], color=colour, lw=0.8,
                label=rf"$\phi$ = {_num(phi)}, {_size_label(lx, ly)}, seed {int(row.seed)}")
        k = ev.t_max >= t0
        fill = STATE_FILL.get(str(row.get("state", "drifting")), "none")
        ax.plot(ev.t_max[k], ev.sigma_fail[k], marker, color=colour, fillstyle=fill,
                mfc=colour if fill != "none" else "white", mfcalt="white", ls="none",
                label=r"$\sigma_{\rm fail}$ (slip maxima; " + str(row.get("state", "n/a"))
                + ")")
        ax.set_ylabel(r"$\sigma_x$ ($k_d/l$)")
        ax.set_xlabel(r"t ($\sqrt{m/k_d}$)")  # each panel: the two runs' times differ
        lows.append(float(np.min(sigma[keep])))
        highs.append(float(max(np.max(sigma[keep]),
                               np.max(ev.sigma_fail[k].to_numpy(float), initial=-np.inf))))
        tops.append(float(row.mu_s * row.sigma_n))
    # one y range for both panels, fitted to the traces, so that their stresses compare by eye
    lo, hi = min(lows), max(highs)
    pad = 0.06 * (hi - lo) if hi > lo else 0.05 * abs(hi) or 0.05
    lo, hi = lo - pad, hi + pad
    for ax, top in zip(axes[:, 0], tops):
        ax.set_ylim(lo, hi)
        words = rf"Amontons-Coulomb $\mu_s\sigma_n$ = {top:.3g}"
        if lo <= top <= hi:
            ax.axhline(top, color="tab:blue", ls="-.", lw=1, label=words)
        else:  # outside the range: named in the right margin, the arrow pointing to it
            up = top > hi
            ax.annotate("Amontons-Coulomb\n" + rf"$\mu_s\sigma_n$ = {top:.3g}",
                        xy=(1.012, 1.0 if up else 0.0),
                        xycoords="axes fraction", xytext=(1.012, 0.5),
                        textcoords="axes fraction", rotation=90, ha="left", va="center",
                        fontsize=MIN_FONT, color="tab:blue", annotation_clip=False,
                        arrowprops={"arrowstyle": "->", "color": "tab:blue", "lw": 0.8,
                                    "shrinkA": 2, "shrinkB": 0})
        # the key above the panel: inside, it would sit on the trace
        ax.legend(loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=3, frameon=False,
                  fontsize=MIN_FONT, borderaxespad=0.1, handlelength=1.5, columnspacing=1.0)
    fig.suptitle(r"Fig. 1b: stick-slip of the shear stress $\sigma_x(t)$ ("
                 + protocol_label(data) + ")"
                 + ("\nthe lines join its turning points (the drops above 0.1% of "
                    r"$\mu_s\sigma_n$; --scene series keeps every sample)" if outline else ""),
                 fontsize=9)
    return fig


#: how a point's state (results.csv ``state``, docs/model.md "Steady state") is drawn: its
#: marker filled (every seed's run steady), open (some drifting), half-filled, left half (some
#: metastable: a flat stress that still remembers its start; split vertically, so that the
#: curve through the marker does not hide the split), or bottom half (switching between
#: states: the error bar covers the switching)
STATE_FILL = {"steady": "full", "switching": "bottom", "drifting": "none", "metastable": "left"}


def _point_states(g: pd.DataFrame) -> np.ndarray:
    """The points' states as STATE_FILL names them (the states visited: ``switching``)."""
    from bkflow.observables.states import SWITCHING

    if "state" not in g:
        return np.full(len(g), "drifting")
    states = g["state"].fillna("drifting").astype(str)
    return np.where(states.isin(SWITCHING), "switching", states.to_numpy())


def _smooth(t, x, width: float):
    """x averaged over consecutive windows of ``width`` time units: (centres, means)."""
    t, x = np.asarray(t, float), np.asarray(x, float)
    if len(t) < 2 or width <= 0:
        return t, x
    k = ((t - t[0]) // width).astype(int)
    n = np.bincount(k)
    keep = n > 0
    if keep.sum() > 1 and t[-1] - (t[0] + k[-1] * width) < 0.5 * width:
        keep[k[-1]] = False  # a last window under half the width: an edge artefact
    return (np.bincount(k, t)[keep] / n[keep], np.bincount(k, x)[keep] / n[keep])


def _contact_phis(phis) -> list[float]:
    """A soft, an intermediate and a stiff phi of those swept: the softest, the stiffest,
    and the one nearest their geometric mean (0.1, 10, 1000 on the default grid; all three
    of a sweep of three phi, such as 10, 100, 1000: nearest-to-target choices left its middle
    one out), each once."""
    phis = sorted(set(float(p) for p in phis))
    middle = _nearest(phis, math.sqrt(phis[0] * phis[-1]))
    return list(dict.fromkeys([phis[0], middle, phis[-1]]))


def _window(shortest: float, block: float) -> float:
    """The smoothing window of fig_contacts, in time units: the largest 1, 2 or 5 times a
    power of ten at most a twentieth of the shortest run shown, or, where that is shorter than
    one block of the records, the smallest such number at least one block: one window for
    every panel, so that their curves are smoothed alike."""
    decade = math.floor(math.log10(max(shortest / 20.0, 1e-12)))
    steps = [m * 10.0 ** e for e in range(decade - 1, decade + 12) for m in (1.0, 2.0, 5.0)]
    below = [w for w in steps if w <= shortest / 20.0 * (1 + 1e-9)]
    if below and below[-1] >= block * (1 - 1e-9):
        return below[-1]
    return min(w for w in steps if w >= block * (1 - 1e-9))


def fig_contacts(data: SweepData, plt):
    """The memory of the start, run by run: sigma_x(t)/sigma_n and the contacts' phase
    coherence R(t) (docs/model.md "Contact phase") over the whole run, for a soft, an
    intermediate and a stiff phi of the smallest size (``_contact_phis``; seed 1, or the
    first). The dark curves are means over one window of time (``_window``, the same in every
    panel and said in the key: "1% of the run" made runs of different lengths look alike
    when they were not smoothed alike); the light curve is R's block means as recorded. The
    analysed window (from the end of the transient) is shaded, green where the run is
    steady and orange where it is not (its state in the panel's title), keyed below."""
    lx, ly = data.sizes[0]
    chosen = _contact_phis(data.runs_of(lx, ly).phi)
    fig, axes = plt.subplots(2, len(chosen), figsize=(3.0 * len(chosen) + 0.6, 4.1),
                             sharex="col", squeeze=False)
    panels = []
    for j, phi in enumerate(chosen):
        row = data.runs_of(lx, ly, phi).iloc[0]
        rd = data.run_dir(row)
        spec = rd.spec()
        red = rd.read_reduced(spec)
        phase = rd.phase_series(spec, red)
        if phase is None:
            axes[0, j].text(0.5, 0.5, "no phase series\n(run made before bkflow recorded it)",
                            transform=axes[0, j].transAxes, ha="center", va="center",
                            fontsize=MIN_FONT)
            continue
        t, sigma, _ = red.series()    # block means
        panels.append((j, phi, row, t, sigma, phase, red.block * spec.dt))
    if not panels:
        return None
    block = max(b for *_, b in panels)   # the records' block, in time units
    width = _window(min(t[-1] - t[0] for _, _, _, t, _, _, _ in panels), block)
    steady_seen = other_seen = False
    for j, phi, row, t, sigma, phase, _ in panels:
        top, bottom = axes[0, j], axes[1, j]
        ts, ss = _smooth(t, sigma / row.sigma_n, width)
        top.plot(ts, ss, color="black", lw=0.8)
        bottom.plot(phase["t"], phase["R"], color="plum", lw=0.3, alpha=0.6)
        tr, rr = _smooth(phase["t"], phase["R"], width)
        bottom.plot(tr, rr, color="indigo", lw=1.2)
        t0 = float(row.t_transient) if "t_transient" in row and pd.notna(row.t_transient) \
            else t[0]
        steady = row.get("state") == "steady"
        steady_seen, other_seen = steady_seen or steady, other_seen or not steady
        for ax in (top, bottom):
            ax.axvspan(t0, t[-1], color="tab:green" if steady else "tab:orange", alpha=0.1,
                       lw=0)
        top.set_title(rf"$\phi$ = {_num(phi)}, {_size_label(lx, ly)}, seed {int(row.seed)}: "
                      f"{row.get('state', 'n/a')}", fontsize=MIN_FONT + 0.5)
        bottom.set_ylim(0, 1.02)
        bottom.set_xlabel(r"t ($\sqrt{m/k_d}$)")
    for top, bottom in axes.T:  # every panel: the stresses' ranges differ
        top.set_ylabel(r"$\sigma_x/\sigma_n$")
        bottom.set_ylabel(r"$R = |\langle e^{2\pi i u}\rangle|$")
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles = [Line2D([], [], color="black", lw=0.8), Line2D([], [], color="indigo", lw=1.2),
               Line2D([], [], color="plum", lw=0.8)]
    labels = [rf"$\sigma_x/\sigma_n$, mean over {width:g} time units",
              f"R, mean over {width:g} time units",
              f"R, block means ({block:.3g} time units)"]
    if steady_seen:
        handles.append(Patch(color="tab:green", alpha=0.25, lw=0))
        labels.append("analysed window (after the transient), steady run")
    if other_seen:
        handles.append(Patch(color="tab:orange", alpha=0.25, lw=0))
        labels.append("analysed window, run not steady (state in the title)")
    fig.legend(handles, labels, loc="outside lower center", ncol=3, frameon=False,
               fontsize=MIN_FONT, handlelength=1.8, columnspacing=1.2,
               title=protocol_label(data), title_fontsize=MIN_FONT)
    fig.suptitle("The start's memory: the stress and the contacts' phase coherence",
                 fontsize=9)
    return fig


def _series(ax, g: pd.DataFrame, field: str, marker: str, label: str):
    """One curve against phi with error bars, each point's marker drawn by its state
    (``STATE_FILL``)."""
    line = ax.errorbar(g.phi, g[field], yerr=_errors(g, field), marker="none", capsize=2,
                       lw=0.8, label=label)
    colour = line[0].get_color()
    states = _point_states(g)
    for name, fill in STATE_FILL.items():
        k = states == name
        if k.any():
            ax.plot(g.phi[k], g[field][k], marker, color=colour, ls="none", ms=5,
                    fillstyle=fill, mfc=colour if fill != "none" else "white",
                    mfcalt="white")
    return line


def state_handles(present=tuple(STATE_FILL)) -> tuple[list, list[str]]:
    """The key of the marker convention (``STATE_FILL``) for the states ``present``:
    grey markers and their words, in the convention's order."""
    from matplotlib.lines import Line2D

    words = {"steady": "steady (every seed)", "drifting": "drifting (some seed)",
             "metastable": "metastable (some seed)",
             "switching": "switching between states (some seed)"}
    shown = [(name, fill) for name, fill in STATE_FILL.items() if name in present]
    return ([Line2D([], [], marker="o", ls="none", color="grey", fillstyle=fill,
                    mfc="grey" if fill != "none" else "white", mfcalt="white")
             for _, fill in shown], [words[name] for name, _ in shown])


def protocol_label(data: SweepData) -> str:
    """What the figure's runs are, in words, from what the sweep recorded of them (runs.csv
    ``start``, ``companion``, ``until_steady``, ``t_end``): "steady protocol" only for the
    steady protocol's own start and companion (params.STEADY_START beside
    STEADY_COMPANION, until steady); any other start run until steady says so
    ("synchronized start until steady, partial companion"); a fixed length names its start
    and lengths ("paper's protocol, t_end = 1000": the synchronized start); else the
    mixture."""
    from bkflow.model.params import STEADY_COMPANION, STEADY_START

    r = data.runs

    def recorded(column) -> pd.Series:
        """Each run's value of ``column`` as text, "" where none was recorded."""
        if column not in r:
            return pd.Series("", index=r.index)
        v = r[column].astype(str).where(r[column].notna(), "")
        return v.where(~v.str.lower().isin(("none", "nan")), "")

    steady = recorded("until_steady").str.lower().isin(("true", "1", "1.0"))
    start, companion = recorded("start"), recorded("companion")
    starts, companions = set(start) - {""}, set(companion) - {""}
    start_words = "/".join(sorted(starts)) + " start" if starts else "runs"
    companion_words = ", " + "/".join(sorted(companions)) + " companion" if companions else ""
    if steady.all():
        if (start == STEADY_START).all() and (companion == STEADY_COMPANION).all():
            return "steady protocol"
        return start_words + " until steady" + companion_words
    if not steady.any() and "t_end" in r:
        ends = sorted(set(pd.to_numeric(r["t_end"], errors="coerce").dropna()))
        who = "paper's protocol" if starts == {"synchronized"} and not companions else \
            "fixed length, " + start_words + companion_words
        return who + ", t_end = " + ", ".join(_num(e) for e in ends)
    return "mixed protocols"


def state_key(fig, data: SweepData, ax=None, extra=((), ())) -> None:
    """The figure's key, below its panels where it covers no point: the curves of ``ax`` (its
    labelled handles, e.g. one per size) and the marker convention (``STATE_FILL``) for
    the states present in the figure's points (grey markers); ``extra`` (handles, labels),
    e.g. fig2a's regime letters, on rows of their own below."""
    handles, labels = ax.get_legend_handles_labels() if ax is not None else ([], [])
    more, words = state_handles(set(_point_states(data.results)))
    groups = [(handles + more, labels + words), (list(extra[0]), list(extra[1]))]
    groups = [g for g in groups if g[0]]
    if not groups:
        return
    # as many columns as the figure's width holds (a key wider than the figure squeezes it)
    ncol = min(max(len(h) for h, _ in groups), 6, max(2, int(fig.get_figwidth() // 1.6)))
    handles, labels = _in_rows(groups, ncol)
    fig.legend(handles, labels, loc="outside lower center", ncol=ncol, frameon=False,
               fontsize=MIN_FONT, handletextpad=0.3, columnspacing=1.2,
               title=protocol_label(data), title_fontsize=MIN_FONT)


def _in_rows(groups, ncol: int) -> tuple[list, list[str]]:
    """(handles, labels) of several groups in the order that a legend of ``ncol`` columns
    (which fills column by column) shows as rows, each group starting a row of its own
    (blank entries fill a group's last row)."""
    from matplotlib.lines import Line2D

    rows = []
    for handles, labels in groups:
        entries = list(zip(handles, labels))
        entries += [(Line2D([], [], ls="none"), "")] * (-len(entries) % ncol)
        rows += [entries[i:i + ncol] for i in range(0, len(entries), ncol)]
    ordered = [row[c] for c in range(ncol) for row in rows]
    return [h for h, _ in ordered], [label for _, label in ordered]


def fig2a_friction(data: SweepData, plt):
    """mu_bar(phi) (every slip above the threshold), mu_bar over the large drops, and
    <sigma_x>/sigma_n(phi), per size, with error bars; markers by state (``STATE_FILL``);
    the majority regime of the smallest size written above each phi in the paper's colours,
    keyed below (``regime_key``)."""
    fig, (a, c, b) = plt.subplots(1, 3, figsize=(10.0, 3.1))
    for (lx, ly), m in zip(data.sizes, MARKERS):
        g = data.results_of(lx, ly)
        for ax, f in ((a, "mu_bar"), (c, "mu_bar_large"), (b, "mean_stress_ratio")):
            if f in g:
                _series(ax, g, f, m, _size_label(lx, ly))
    shown = _regime_labels(a, data)
    a.set_ylabel(r"$\overline{\mu} = \langle\sigma_{\rm fail}\rangle/\sigma_n$")
    c.set_ylabel(r"$\overline{\mu}$ over large drops")
    b.set_ylabel(r"$\langle\sigma_x\rangle/\sigma_n$")
    for ax in (a, c, b):
        ax.set_xscale("log")
        ax.set_xlabel(r"$\phi = k_b/\Delta k_d$")
    state_key(fig, data, ax=a, extra=regime_key(shown))
    a.set_title(f"Fig. 2a: macroscopic friction (letters: regime, {data.sizes[0][0]}x"
                f"{data.sizes[0][1]})", fontsize=8)
    c.set_title("large drops only (drop > mean drop)", fontsize=8)
    b.set_title("time-averaged stress", fontsize=9)
    return fig


def regime_key(regimes) -> tuple[list, list[str]]:
    """The key of the regime letters (``REGIME_COLOURS``, ``REGIME_WORDS``) for the regimes
    given: each letter as its marker, in its colour."""
    from matplotlib.lines import Line2D

    order = [r for r in REGIME_COLOURS if r in set(regimes)]
    handles = [Line2D([], [], ls="none", marker=rf"$\mathrm{{{r}}}$",
                      ms=7 if len(r) == 1 else 10, color=REGIME_COLOURS[r], mew=0)
               for r in order]
    return handles, [REGIME_WORDS[r] for r in order]


def _regime_labels(ax, data: SweepData) -> list[str]:
    """The majority regime of the smallest size, written above each phi; the regimes
    written."""
    lx, ly = data.sizes[0]
    g = data.results_of(lx, ly)
    if "regime" not in g or g.regime.isna().all():
        return []
    ax.margins(y=0.18)
    tr = ax.get_xaxis_transform()
    shown = []
    for phi, reg in zip(g.phi, g.regime):
        if isinstance(reg, str):
            ax.text(phi, 0.98, reg, transform=tr, ha="center", va="top", fontsize=MIN_FONT,
                    color=REGIME_COLOURS.get(reg, "grey"))
            shown.append(reg)
    return shown


def fig2b_asymmetry(data: SweepData, plt):
    """<l_x>/<l_y>(phi) per size; the box's Lx/Ly dotted, and in the key what a whole-box
    slip reaches on a lattice with an odd side (not Lx/Ly: ``bkflow.model.lattice.box_extent``)."""
    from matplotlib.lines import Line2D

    fig, ax = plt.subplots(figsize=(4.6, 2.9))
    for (lx, ly), m in zip(data.sizes, MARKERS):
        g = data.results_of(lx, ly)
        _series(ax, g, "lx_over_ly", m, _size_label(lx, ly))
    aspects = sorted({lx / ly for lx, ly in data.sizes})
    for r in aspects:
        ax.axhline(r, color="grey", ls=":", lw=0.8)
    # a whole-box slip's l_x/l_y is not Lx/Ly: N/(N-1) cancels, an odd side's ring distances
    # (L^2 - 1)/4 do not (bkflow.model.lattice.box_extent)
    whole = ", ".join(f"{box_extent(lx, ly) / box_extent(ly, lx):.3g} on "
                      f"{lx}x{ly}" for lx, ly in data.sizes
                      if (lx % 2 or ly % 2) and lx > 1 and ly > 1)
    ax.set_xscale("log")
    ax.set_xlabel(r"$\phi = k_b/\Delta k_d$")
    ax.set_ylabel(r"$\langle l_x\rangle / \langle l_y\rangle$")
    ax.set_title("Fig. 2b: cluster asymmetry", fontsize=9)
    # the notes in the key below, where they cover no point
    state_key(fig, data, ax=ax, extra=([Line2D([], [], color="grey", ls=":", lw=0.8)], [
        "the box's Lx/Ly" + (f"; a whole-box slip on an odd side\nreaches {whole}"
                             if whole else "")]))
    return fig


def fig3_order(data: SweepData, plt):
    """(a) Psi(inf)(phi) per size; (b) the paper's inset, 1 - Psi(t) from the start of one
    seed for phi in INSET_PHI (N = 400 where swept), on a log axis (the stiff layers' Psi
    all lie within 2% of 1). Psi is recorded every ``snapshot_every`` time units (psi.npy;
    20 by default), and its fall from Psi(0) = 1 is over within two or three samples: a log
    time axis from the first sample made those samples look like a resolved fall. (b) shows
    the first ``PSI_SAMPLES`` samples on a linear time axis, each one marked, and says the
    sampling interval: the fall is drawn as what the record holds, a step the sampling does
    not resolve, followed by the plateau."""
    fig, (ax, ins) = plt.subplots(1, 2, figsize=(7.6, 3.1), width_ratios=(1.25, 1))
    for (lx, ly), m in zip(data.sizes, MARKERS):
        g = data.results_of(lx, ly)
        _series(ax, g, "psi_inf", m, _size_label(lx, ly))
    ax.set_xscale("log")
    ax.set_xlabel(r"$\phi = k_b/\Delta k_d$")
    ax.set_ylabel(r"$\Psi(\infty)$")
    ax.set_ylim(0.4, 1.05)
    state_key(fig, data, ax=ax)
    ax.set_title(r"Fig. 3: bond-orientational order $\Psi$", fontsize=9)
    inset_size = (40, 10) if (40, 10) in data.sizes else data.sizes[0]
    runs = data.runs_of(*inset_size)
    phis = sorted(set(runs.phi))
    shown, steps = [], []
    for target in INSET_PHI:
        phi = _nearest(phis, target)
        if phi in shown:
            continue
        shown.append(phi)
        p = data.run_dir(data.runs_of(*inset_size, phi).iloc[0]).read_psi()
        if p is None or len(p) < 2:
            continue
        t, psi = p.t.to_numpy(dtype=float), p.psi.to_numpy(dtype=float)
        step = float(np.median(np.diff(t)))
        steps.append(step)
        k = t <= t[0] + PSI_SAMPLES * step * (1 + 1e-9)
        # 1 - Psi on a log axis: Psi(0) = 1 exactly, and a sample at 1 has no place on it
        t, dis = t[k], 1.0 - psi[k]
        k = dis > 0
        ins.plot(t[k], dis[k], "o-", color=phi_colour(phi), lw=0.6, ms=2.2,
                 label=rf"$\phi$ = {_num(phi)}")
    if not steps:
        fig.delaxes(ins)
        return fig
    ins.set_yscale("log")
    ins.set_xlim(left=0)
    ins.set_xlabel(r"t ($\sqrt{m/k_d}$)")
    ins.set_ylabel(r"$1 - \Psi(t)$")
    lo, hi = f"{min(steps):.3g}", f"{max(steps):.3g}"   # (the runs' time steps differ)
    every = lo if lo == hi else f"{lo} to {hi}"
    ins.set_title(f"the paper's inset: from the start, N = {inset_size[0] * inset_size[1]}, "
                  "one seed;\n"
                  rf"$\Psi$ sampled every {every} time units (dots), $\Psi(0) = 1$",
                  fontsize=MIN_FONT)
    ins.legend(fontsize=MIN_FONT, frameon=False, loc="upper center",
               bbox_to_anchor=(0.5, -0.24), ncol=4, handlelength=1.5, columnspacing=0.8)
    return fig


def cluster_phis(phis) -> list[float]:
    """The phi of the cluster scatter, fig_drops and fig_potency among the swept ``phis``: for
    each target of ``CLUSTER_PHI`` the nearest (on a log scale), each once, stiffest first.
    The same targets in every sweep, so that two sweeps' figures show the same layers where
    both swept them."""
    return sorted({_nearest(phis, target) for target in CLUSTER_PHI}, reverse=True)


def _cluster_size(data: SweepData) -> tuple[int, int]:
    """The size of the cluster figures: the paper's 20x5 where swept, else the smallest."""
    return (20, 5) if (20, 5) in data.sizes else data.sizes[0]


def fig4a_clusters(data: SweepData, plt):
    """l_y against l_x of every slip cluster, all seeds, each as a fraction of the whole box's
    own extent on its side, for the phi of ``CLUSTER_PHI`` (20x5 if swept): one panel per
    phi on shared axes, so that no phi's clusters hide another's (on one panel the thousands
    of a soft layer covered the rest, and the stiff layers' clusters all sit on one spot of
    the C / W corner); each panel's title gives its count and the shares of its clusters in
    the regimes (``cluster_sets``)."""
    lx, ly = _cluster_size(data)
    sets = cluster_sets(data, lx, ly, cluster_phis(data.runs_of(lx, ly).phi))
    if not sets:
        return None
    n = len(sets)
    ncols = 2 if n > 1 else 1
    nrows = -(-n // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(3.3 * ncols + 0.3, 3.2 * nrows + 0.9),
                             sharex=True, sharey=True, squeeze=False)
    top = _cluster_top(sets, (lx, ly))
    span = _span(data)
    for ax, one in zip(axes.flat, sets):
        _cluster_panel(ax, [one], (lx, ly), span, top)
        phi, c, shares = one
        ax.set_title(rf"$\phi$ = {_num(phi)}: {len(c)} clusters" + "\n"
                     + _shares_words(shares), fontsize=8)
    for ax in axes.flat[n:]:
        ax.set_axis_off()
    for k, ax in enumerate(axes.flat[:n]):
        if k + ncols >= n:    # no panel below: its x axis is labelled
            ax.set_xlabel(r"$l_x / l_x^{\mathrm{box}}$ (whole box's extent along x)")
            ax.xaxis.set_tick_params(labelbottom=True)
    for ax in axes[:, 0]:
        ax.set_ylabel(r"$l_y / l_y^{\mathrm{box}}$ (whole box's extent across)")
    # the key (the colours of phi, as in fig_drops and fig_potency, and the bounds) in a spare
    # panel where there is one, else below the panels
    from matplotlib.lines import Line2D

    key = [Line2D([], [], ls="none", marker="o", ms=5, mew=0, color=phi_colour(phi),
                  label=rf"$\phi$ = {_num(phi)}") for phi, *_ in sets] + _cluster_guides(span)
    if n < axes.size:
        axes.flat[-1].legend(handles=key, loc="center", frameon=False, fontsize=MIN_FONT)
    else:
        fig.legend(handles=key, loc="outside lower center", ncol=3, frameon=False,
                   fontsize=MIN_FONT)
    fig.suptitle(f"Fig. 4a: slip clusters, {_size_label(lx, ly)} ({protocol_label(data)})",
                 fontsize=9)
    return fig


def cluster_sets(data: SweepData, lx, ly, phis) -> list[tuple]:
    """[(phi, its clusters pooled over the seeds, {regime: share})] of the runs at (lx, ly)
    for each of ``phis`` whose runs recorded clusters."""
    sets = []
    for phi in phis:
        runs = data.runs_of(lx, ly, phi)
        frames = [(r, c) for (_, r), c in zip(
            runs.iterrows(), (data.run_dir(r).read_clusters() for _, r in runs.iterrows()))
            if c is not None and len(c)]
        if frames:
            kept = pd.DataFrame([r for r, _ in frames])
            sets.append((phi, pd.concat([c for _, c in frames]),
                         _regime_shares(kept, [c for _, c in frames])))
    return sets


def _shares_words(shares: dict) -> str:
    """"C 98%, LC 2%": the regimes' shares of a set of clusters, those of 0.5% or more."""
    return ", ".join(f"{reg} {share:.0%}" for reg, share in shares.items() if share >= 0.005)


def _span(data: SweepData) -> float:
    """The fraction of a side from which the sweep's analysis counts it spanned."""
    from bkflow.model.params import SPAN_FRACTION

    return float(getattr(getattr(data, "settings", None), "span_fraction", SPAN_FRACTION))


def _cluster_top(sets, box) -> float:
    """The upper limit of both axes of a cluster scatter: every cluster inside (a soft
    layer's clusters reach past 1 across the box), at least 1.15 (the C / W corner's name)."""
    return max(1.15, 1.03 * max(float(max(f.max() for f in box_fractions(
        c.l_x, c.l_y, box))) for _, c, _ in sets))


def _cluster_guides(span: float) -> list:
    """The key of the regime bounds drawn on a cluster scatter."""
    from matplotlib.lines import Line2D

    return [Line2D([], [], color="grey", lw=0.6, ls=":",
                   label=f"{span:g} of a side: spanning (the regimes' bounds)"),
            Line2D([], [], color="grey", lw=0.6, ls="--", label="the DP / DT bound")]


def _cluster_panel(ax, sets, box, span: float, top: float) -> dict:
    """Draw ``sets`` (``cluster_sets``) on ``ax`` as small filled circles in their phi's
    colour (``phi_colour``), translucent (the more clusters, the fainter), the densest set
    lowest, with the regime bounds and the regions' names in grey; returns {phi: a key handle
    (opaque and larger, labelled with the count and the regime shares)}."""
    keys = {}
    # the largest set first and lowest: a sparse set is drawn over a dense one, not hidden
    for z, (phi, c, shares) in enumerate(sorted(sets, key=lambda s: -len(s[1]))):
        fx, fy = box_fractions(c.l_x, c.l_y, box)
        colour = phi_colour(phi)
        alpha = float(np.clip(20.0 / math.sqrt(len(c)), 0.15, 0.8))
        ax.plot(fx, fy, "o", color=colour, ms=2.0, mew=0, alpha=alpha, zorder=2 + z,
                label="_nolegend_")
        words = _shares_words(shares)
        # an empty line added to the axes, so that a caller's ax.legend() finds it too
        keys[phi], = ax.plot([], [], "o", color=colour, ms=5, mew=0,
                             label=rf"$\phi$ = {_num(phi)}: {len(c)} clusters"
                             + (f" ({words})" if words else ""))
    ax.plot([0, top], [0, top], color="grey", lw=0.6, ls="--")
    ax.axvline(span, color="grey", lw=0.6, ls=":")
    ax.axhline(span, color="grey", lw=0.6, ls=":")
    # the regions' names in grey (the colours belong to the phi), under the points: a name
    # never hides a cluster
    for txt, x, y in (("C / W", 1.07, 1.07), ("LC", 1.07, 0.5), ("DP", 0.6, 0.2),
                      ("DT", 0.2, 0.6)):
        ax.text(x, y, txt, fontsize=8, ha="center", va="center", color="dimgrey",
                weight="bold", zorder=1)
    ax.set_xlim(-0.03, top)  # a cluster one particle across sits at 0: drawn whole
    ax.set_ylim(-0.03, top)
    return keys


def _regime_shares(runs: pd.DataFrame, frames) -> dict:
    """{regime: share of the clusters} of ``frames`` (the clusters of each run of ``runs``):
    the runs' own shares as the analysis classified them (runs.csv
    ``regime_fractions[R]``, bkflow.observables.clusters.regime), weighted by each run's clusters. A
    figure reads the regimes from the tables; it never classifies."""
    weights = np.array([len(c) for c in frames], dtype=float)
    shares = {}
    for reg in REGIME_COLOURS:
        col = f"regime_fractions[{reg}]"
        if col in runs:
            f = pd.to_numeric(runs[col], errors="coerce").to_numpy(dtype=float)
            ok = np.isfinite(f)
            if ok.any() and weights[ok].sum() > 0:
                shares[reg] = float(np.sum(f[ok] * weights[ok]) / weights[ok].sum())
    return shares


def cluster_scatter(data: SweepData, plt, lx, ly, phis, title, ax=None):
    """l_y/l_y^box against l_x/l_x^box of every cluster of the runs at (lx, ly) and each phi,
    all on one panel (``ax``, or a new figure's), with the regime bounds of
    ``bkflow.observables.clusters.regime`` drawn in and the regions named in grey; None when no
    clusters. Each phi is a set of small filled circles in its colour (``phi_colour``: a sequential
    map, so that no set reads as one of the paper's regime colours, and filled, as open markers
    mean a drifting run in bkflow's other figures), translucent and the densest lowest; the
    key gives each set's count and regime shares, which a reader cannot count where sets lie
    on one another (fig4a draws one panel per phi instead)."""
    fig = None
    if ax is None:
        fig, ax = plt.subplots(figsize=(4.2, 4.9))
    sets = cluster_sets(data, lx, ly, phis)
    if not sets:
        if fig is not None:
            plt.close(fig)
        return None
    span = _span(data)
    keys = _cluster_panel(ax, sets, (lx, ly), span, _cluster_top(sets, (lx, ly)))
    # each extent against the whole box's own on its side: a whole-box slip sits at (1, 1)
    # on odd and even sides alike (bkflow.model.lattice.box_fractions)
    ax.set_xlabel(r"$l_x / l_x^{\mathrm{box}}$ (whole box's extent along x)")
    ax.set_ylabel(r"$l_y / l_y^{\mathrm{box}}$ (whole box's extent across)")
    ax.set_title(title, fontsize=9)
    ax.legend(handles=[keys[phi] for phi, *_ in sets] + _cluster_guides(span), frameon=False,
              fontsize=MIN_FONT, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=1,
              title=r"colour: $\phi$ (regime shares of its clusters)",
              title_fontsize=MIN_FONT)
    return fig if fig is not None else ax.figure


def _log_density(d, bins: int, part=None) -> tuple[np.ndarray, np.ndarray]:
    """Probability density of positive values in logarithmic bins (centres, density); with
    ``part`` (a mask of ``d``), that part's share of it, in the same bins: the parts' densities
    add up to the whole's."""
    lo, hi = d.min(), max(d.max(), d.min() * 1.0001)
    edges = np.geomspace(lo, hi, bins + 1)
    counts, _ = np.histogram(d if part is None else d[part], edges)
    return np.sqrt(edges[:-1] * edges[1:]), counts / (len(d) * np.diff(edges))


def _late_drops(data: SweepData, runs: pd.DataFrame):
    """The drops after the transient of ``runs`` (events.parquet), pooled over the seeds, and
    whether each drop's slip moved every particle of the layer (its largest cluster in
    clusters.csv holds all N; None when a run recorded no clusters)."""
    drops, whole = [], []
    for _, r in runs.iterrows():
        rd = data.run_dir(r)
        e = rd.read_events()
        late = e["late"].fillna(False).astype(bool).to_numpy()
        d = pd.to_numeric(e["drop"], errors="coerce").to_numpy(dtype=float)
        drops.append(d[late])
        c = rd.read_clusters()
        if c is None:
            whole = None
        elif whole is not None:
            largest = c.groupby("event")["n_c"].max()
            n_max = largest.reindex(np.arange(len(e))).to_numpy(dtype=float)
            whole.append((n_max >= int(r.Lx) * int(r.Ly))[late])
    d = np.concatenate(drops) if drops else np.empty(0)
    keep = np.isfinite(d) & (d > 0)
    return d[keep], (np.concatenate(whole)[keep] if whole else None)


def _drop_verdict(runs: pd.DataFrame, key: str = "drop") -> tuple[bool, str]:
    """Whether the seeds' stress drops (``key`` "drop"; "potency": the slips' potencies)
    follow a power law, from their analyses (runs.csv: ``drop_power_law``, ``drop_fit_p``,
    ``drop_vs_lognormal[_p]``; ``bkflow.observables.stress.power_law_test``): plausible only when it
    is in every seed and no seed's lognormal is significantly better (R < 0, p < 0.1); and the
    key's words."""
    verdicts = runs[f"{key}_power_law"].astype(str).tolist() if f"{key}_power_law" in runs \
        else ["no fit"] * len(runs)
    def column(name):
        return pd.to_numeric(runs[name], errors="coerce") if name in runs \
            else pd.Series(np.nan, index=runs.index)

    p = column(f"{key}_fit_p")
    n = len(verdicts)
    R, Rp = column(f"{key}_vs_lognormal"), column(f"{key}_vs_lognormal_p")
    favoured = int(((R < 0) & (Rp < 0.1)).sum())  # seeds whose lognormal is significantly better
    if n and all(v == "plausible" for v in verdicts) and favoured:
        return False, (f"a lognormal favoured in {favoured} of {n} seeds" if n > 1 else
                       "a lognormal favoured") + f" (power law p >= {p.min():.2f})"
    if n and all(v == "plausible" for v in verdicts):
        alpha = column(f"{key}_exponent").mean()
        err = column(f"{key}_exponent_err").mean()
        return True, (rf"$\alpha$ = {alpha:.2f} $\pm$ {err:.2f} (p >= {p.min():.2f}"
                      + (f" in all {n} seeds)" if n > 1 else ")"))
    rejected = sum(v == "rejected" for v in verdicts)
    if not rejected:
        return False, "no fit"
    lognormal = bool(((R < 0) & (Rp < 0.1)).sum() == rejected)
    worst = p[runs[f"{key}_power_law"].astype(str) == "rejected"].max()
    shown = "p < 0.001" if worst < 0.001 else f"p <= {worst:.2f}"
    return False, ("power law rejected" + (f" in {rejected} of {n} seeds" if n > 1 else "")
                   + f" ({shown}" + (", lognormal favoured)" if lognormal else ")"))


def fig_drops(data: SweepData, plt):
    """(a) Density of stress-drop sizes after the transient (events.parquet, the seeds pooled)
    for the phi of the cluster figure (``cluster_phis``; those with two drops or more are
    drawn), with the maximum-likelihood power law drawn only where the analysis found it
    plausible in every seed (Clauset et al.'s bootstrap, p >= 0.1; runs.csv
    ``drop_power_law``), else the rejection written in the key.
    (b) The stiffest phi drawn in (a) whose runs recorded clusters, split into its two
    populations: slips that move every particle of the layer (system-wide) and the rest,
    each density weighted by its share so that the two add up to (a)'s; its title says which
    of (a)'s phi it is, counted from the data. Markers by the point's state
    (``STATE_FILL``), colours by phi (``phi_colour``)."""
    lx, ly = _cluster_size(data)
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(7.4, 3.6))
    points = data.results_of(lx, ly)
    drawn, stiff, lines = [], None, 0
    for phi, m in zip(cluster_phis(data.runs_of(lx, ly).phi), MARKERS):
        colour = phi_colour(phi)
        runs = data.runs_of(lx, ly, phi)
        d, whole = _late_drops(data, runs)
        if len(d) < 2:
            continue
        drawn.append(phi)
        plausible, words = _drop_verdict(runs)
        state = _point_states(points[np.isclose(points.phi, phi, rtol=1e-9, atol=0)])
        fill = STATE_FILL.get(state[0] if len(state) else "drifting", "none")
        x, dens = _log_density(d, 15)
        nz = dens > 0
        ax.plot(x[nz], dens[nz], m, color=colour, fillstyle=fill,
                mfc=colour if fill != "none" else "white", mfcalt="white",
                label=rf"$\phi$ = {_num(phi)}: {words}")
        if plausible:
            # the fitted density over the tail (the seeds' mean exponent above their x_min),
            # scaled by the tail's share of all drops
            alpha = pd.to_numeric(runs.drop_exponent, errors="coerce").mean()
            x_min = pd.to_numeric(runs.drop_x_min, errors="coerce").mean()
            xs = np.geomspace(x_min, d.max(), 50)
            share = np.mean(d >= x_min)
            ax.plot(xs, share * (alpha - 1) / x_min * (xs / x_min) ** -alpha,
                    color=colour, lw=0.8)
            lines += 1
        if whole is not None and (stiff is None or phi > stiff[0]):
            stiff = (phi, d, whole, colour, fill)
    if not drawn:  # no run had two stress drops after its transient
        return None
    for a in (ax, bx):
        a.set_xscale("log")
        a.set_yscale("log")
        a.set_xlabel(r"stress drop $\Delta\sigma_x$ ($k_d/l$)")
    ax.set_ylabel("probability density")
    bx.set_ylabel("probability density (of all drops)")
    ax.set_title(f"stress-drop sizes, {_size_label(lx, ly)}\n" + (
        "lines: power laws that pass Clauset et al.'s test (p >= 0.1)" if lines else
        "no power law passes Clauset et al.'s test (p >= 0.1)"), fontsize=8)
    state_key(fig, data)
    # below the axes: a rejection's words never cover a point
    ax.legend(frameon=False, fontsize=MIN_FONT, loc="upper left", bbox_to_anchor=(-0.02, -0.2))
    if stiff is None:
        bx.text(0.5, 0.5, "no cluster data\n(scene without slip frames)",
                transform=bx.transAxes, ha="center", va="center", fontsize=MIN_FONT)
        return fig
    phi, d, whole, colour, fill = stiff
    for part, label, m, ls in ((whole, "system-wide (every particle slips)", "^", "-"),
                               (~whole, "partial", "v", "--")):
        x, dens = _log_density(d, 15, part)  # (a)'s bins: the two add up to (a)'s density
        nz = dens > 0
        if nz.any():
            bx.plot(x[nz], dens[nz], marker=m, ls=ls, color=colour, lw=0.8, fillstyle=fill,
                    mfc=colour if fill != "none" else "white", mfcalt="white",
                    label=f"{label}: {np.mean(part):.0%} of {len(d)}")
    bx.set_title(rf"two populations at $\phi$ = {_num(phi)}" + "\n(" + _which(phi, drawn)
                 + ")", fontsize=8)
    bx.legend(frameon=False, fontsize=MIN_FONT, loc="upper left", bbox_to_anchor=(-0.02, -0.2))
    return fig


def _which(phi: float, drawn) -> str:
    """Which of the phi ``drawn`` ``phi`` is, in words from their number: "the stiffest of
    the three in (a)", "the only one in (a)", or, when a stiffer one drawn in (a) recorded
    no clusters, "the stiffest with slip clusters"."""
    words = {2: "two", 3: "three", 4: "four", 5: "five", 6: "six"}
    if len(drawn) == 1:
        return "the only one in (a)"
    if phi < max(drawn):
        return "the stiffest with slip clusters"
    return f"the stiffest of the {words.get(len(drawn), len(drawn))} in (a)"


def _late_potencies(data: SweepData, runs: pd.DataFrame):
    """(potencies, stress drops) of the slips after the transient that have a potency
    (events.parquet of scenes with slip frames), pooled over the seeds."""
    pot, drops = [], []
    for _, r in runs.iterrows():
        e = data.run_dir(r).read_events()
        if "potency" not in e:
            continue
        late = e["late"].fillna(False).astype(bool).to_numpy()
        pot.append(pd.to_numeric(e["potency"], errors="coerce").to_numpy(float)[late])
        drops.append(pd.to_numeric(e["drop"], errors="coerce").to_numpy(float)[late])
    if not pot:
        return np.empty(0), np.empty(0)
    p, d = np.concatenate(pot), np.concatenate(drops)
    keep = np.isfinite(p) & (p > 0)
    return p[keep], d[keep]


def fig_potency(data: SweepData, plt):
    """The magnitude-frequency view, beside fig_drops: (a) the density of the slips'
    potencies after the transient for the phi of the cluster figure (``cluster_phis``), the
    seeds pooled, with the analysis's verdict on a power law in the key (runs.csv
    ``potency_power_law``; the fitted law drawn where it is plausible in every seed); (b) each
    slip's potency against its stress drop, the largest set drawn lowest.

    The potency is events.parquet's ``potency`` (bkflow.observables.catalogue): the sum over the
    slipping particles of their slips in x, sum_i dx_i, a length in lattice units l. (Seismic
    potency, slip times area, is this times the area l^2 each particle stands for: l^3; the axes
    show the sum as computed, so their unit is l.)"""
    lx, ly = _cluster_size(data)
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(7.4, 3.6))
    points = data.results_of(lx, ly)
    drawn = 0
    for phi, m in zip(cluster_phis(data.runs_of(lx, ly).phi), MARKERS):
        colour = phi_colour(phi)
        runs = data.runs_of(lx, ly, phi)
        pot, drops = _late_potencies(data, runs)
        if len(pot) < 2:
            continue
        drawn += 1
        plausible, words = _drop_verdict(runs, "potency")
        state = _point_states(points[np.isclose(points.phi, phi, rtol=1e-9, atol=0)])
        fill = STATE_FILL.get(state[0] if len(state) else "drifting", "none")
        style_ = dict(color=colour, fillstyle=fill, mfcalt="white",
                      mfc=colour if fill != "none" else "white")
        x, dens = _log_density(pot, 15)
        nz = dens > 0
        ax.plot(x[nz], dens[nz], m, label=rf"$\phi$ = {_num(phi)}: {words}", **style_)
        if plausible:
            alpha = pd.to_numeric(runs.potency_exponent, errors="coerce").mean()
            x_min = pd.to_numeric(runs.potency_x_min, errors="coerce").mean()
            xs = np.geomspace(x_min, pot.max(), 50)
            ax.plot(xs, np.mean(pot >= x_min) * (alpha - 1) / x_min * (xs / x_min) ** -alpha,
                    color=colour, lw=0.8)
        # the largest set lowest: a sparse one is drawn over it, not under it
        bx.plot(drops, pot, m, ms=2.5, alpha=0.6, ls="none", zorder=2 + 1 / len(pot),
                **style_)
    if not drawn:  # no run recorded slip frames
        return None
    for a in (ax, bx):
        a.set_xscale("log")
        a.set_yscale("log")
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    for axis in (ax.xaxis, bx.yaxis):  # potencies span a decade or two: 1-2-5 ticks, plain
        axis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
        axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        axis.set_minor_formatter(NullFormatter())
    ax.set_xlabel(r"potency $\sum_i \Delta x_i$ of the slipping particles ($l$)")
    ax.set_ylabel("probability density")
    ax.set_title(f"potencies, {_size_label(lx, ly)}: a law drawn only where\nClauset et al.'s "
                 "test passes (p >= 0.1) and a lognormal is not favoured", fontsize=8)
    bx.set_xlabel(r"stress drop $\Delta\sigma_x$ ($k_d/l$)")
    bx.set_ylabel(r"potency $\sum_i \Delta x_i$ ($l$)")
    bx.set_title("each slip's potency against its stress drop", fontsize=8)
    state_key(fig, data)
    # below the axis label (two lines tall with its sum)
    ax.legend(frameon=False, fontsize=MIN_FONT, loc="upper left",
              bbox_to_anchor=(-0.02, -0.27))
    return fig


FIGURES = {"fig1b_stress": fig1b_stress, "fig2a_friction": fig2a_friction,
           "fig2b_asymmetry": fig2b_asymmetry, "fig3_order": fig3_order,
           "fig4a_clusters": fig4a_clusters, "fig_drops": fig_drops,
           "fig_potency": fig_potency, "fig_contacts": fig_contacts}
#: what each figure needs the runs to have recorded
_NEEDS = {"fig2b_asymmetry": "lx_over_ly", "fig3_order": "psi_inf",
          "fig4a_clusters": "lx_over_ly", "fig_potency": "potency_exponent"}


def plot(root, out=None, formats=FORMATS, where: dict | None = None) -> tuple[list[Path], dict]:
    """Write every figure that the sweep in ``root`` has data for into ``out`` (default
    ``root/figures``), of the runs matching ``where`` ({column: value}; all by default).
    A sweep that varies other parameters too (``bkflow sweep --vary``) gets one set of
    figures per combination, in subdirectories ``NAME=VALUE[,NAME=VALUE]``. The figures are
    recorded with the tables they were drawn from (``figures.json``): a sweep or collect that
    changes the tables removes them (``bkflow.store.tables.retire_figures``).
    Returns (paths written, {figure: why it was skipped})."""
    from bkflow.store.formats import inside, within
    from bkflow.store.rundir import RunDir
    from bkflow.store.tables import FIGURES_RECORD, record_figures, tables_digest

    # the sweep's own figures directory is written and emptied by bkflow: never through a link
    out = Path(out) if out is not None else inside(root, FIGURES_DIR, "the figures directory")
    # the sweep's lock: no collect or sweep (the tables' writers) rewrites the tables while a
    # plot draws from them, and the record names the tables as they were read
    try:
        SweepData(root, where)  # refuses before anything, a lock file too, is written
    except PlotError:
        if RunDir(root).busy():   # a collect under way: its tables are half made, not wrong
            from bkflow.store.rundir import RunBusyError

            raise RunBusyError(f"another bkflow process (a collect or sweep) is writing "
                               f"{root}'s tables now; plot once it is done") from None
        raise
    with RunDir(root).lock():
        digest = tables_digest(root)
        data = SweepData(root, where)
        _check_formats(formats)
        try:
            old = json.loads(read_text(out / FIGURES_RECORD))
            if not isinstance(old, dict) or not isinstance(old["files"], list):
                raise TypeError("not a record of figures")
            # only plain names inside the figures directory are the record's (an absolute
            # path, '..' or a name through a link is nobody's to keep, replace or remove)
            recorded = {f for f in old["files"] if isinstance(f, str) and within(out, f)}
            same = (old.get("tables_sha256") == digest and old.get("where") == (where or None))
        except (OSError, ValueError, KeyError, TypeError, AttributeError):
            recorded, same = set(), False
        kept = [out / f for f in sorted(recorded)] if same else []
        # figures of other tables, or of another --where: not what this plot shows; those it
        # does not draw again are removed, so that the directory holds one record's figures
        stale = [] if same else [out / f for f in sorted(recorded)]
        targets = _check_targets(out, formats, recorded)
        out.mkdir(parents=True, exist_ok=True)
        # while figures are being written the record says so: an interrupted plot leaves
        # complete = false, and a later change of the tables still retires what it wrote
        record_figures(root, out, sorted({*kept, *targets, *stale}), where, complete=False,
                       digest=digest)
        written, skipped = _plot(data, out, formats, where, recorded)
        for p in stale:
            if p not in written and p.is_file() and not p.is_symlink():
                p.unlink()
        record_figures(root, out, sorted({*kept, *written}), where, complete=True,
                       digest=digest)
    return written, skipped


def _check_formats(formats) -> None:
    plt = _style()
    supported = plt.figure().canvas.get_supported_filetypes()
    bad = [f for f in formats if f not in supported]
    if bad:
        raise PlotError(f"format {', '.join(bad)} is not one matplotlib writes; choose from "
                        f"{', '.join(sorted(supported))}")


def _plot(data: SweepData, out: Path, formats, where, recorded) -> tuple[list[Path], dict]:
    """The figures of ``data`` into ``out`` (formats checked, the top directory's targets
    too); a sweep that varies other parameters: one subdirectory per combination, whose
    targets are checked here against ``recorded`` (relative to the top directory)."""
    varied = varied_parameters(data.results)
    if varied:
        written, skipped = [], {}
        combos = data.results[varied].astype(str).drop_duplicates().to_dict("records")
        for combo in combos:
            # one directory per combination (a '/' in a value, reset/step, would nest one)
            name = ",".join(f"{k}={v}" for k, v in combo.items()).replace("/", "-")
            sub = {**(where or {}), **parse_where([f"{k}={v}" for k, v in combo.items()])}
            inner = {f[len(name) + 1:] for f in recorded if f.startswith(name + "/")}
            _check_targets(out / name, formats, inner)
            w, s = _plot(SweepData(data.root, sub), out / name, formats, sub, inner)
            written += w
            skipped.update({f"{name}/{k}": v for k, v in s.items()})
        return written, skipped
    out.mkdir(parents=True, exist_ok=True)
    written, skipped = [], {}
    for name in FIGURES:
        try:
            fig = figure(data, name)
        except PlotError as exc:
            skipped[name] = str(exc)
            continue
        except ValueError as exc:  # e.g. --where leaves nothing positive for a log axis
            skipped[name] = f"nothing to draw for these runs ({' '.join(str(exc).split())})"
            continue
        with style():
            written += _save(fig, out, name, formats)
    return written, skipped


def figure(data: SweepData, name: str):
    """The Figure ``name`` of ``FIGURES`` (or its short name: ``fig2a``, ``drops``) of a
    sweep's data, a ``matplotlib.figure.Figure`` made without pyplot; a PlotError saying why
    when the sweep did not record what it needs."""
    full = _figure_name(name)
    need = _NEEDS.get(full)
    if need and not np.isfinite(pd.to_numeric(data.runs.get(need), errors="coerce")).any():
        raise PlotError(f"no run recorded {need} (scene {', '.join(set(data.runs.scene))})")
    with style():
        fig = FIGURES[full](data, Figures())
    if fig is None:
        raise PlotError("no data")
    return fig


def _figure_name(name: str) -> str:
    if name in FIGURES:
        return name
    found = [f for f in FIGURES if f.split("_")[0] == name or f.split("_", 1)[-1] == name]
    if len(found) != 1:
        raise PlotError(f"no figure {name!r}; figures: {', '.join(FIGURES)} (or their first "
                        "or last part, e.g. fig2a, drops)")
    return found[0]
