"""Work-precision of the time step: the bias of the steady observables against the cost of a
time unit, per phi and size, against a dt -> 0 reference, with each accuracy preset's step and
its error target marked.

    python -m benchmarks.report.work_precision [--plot benchmarks/work_precision.png]
    python -m benchmarks.report.work_precision --from-record [CSV]

The runs are benchmarks/measure/timestep.py's (records benchmarks/records/timestep/): per phi
(0.1 to 1000), size (N = 100, 400) and seed, one run from the random start at each C = dt omega_max
of a grid, in the steady state (the first 20% of each run left out: no start's transient is
measured). The reference of each (N, phi, seed) is the extrapolation to dt -> 0 of its three
smallest steps (velocity Verlet's bias falls as dt^2: x(C) = x0 + a C^2, least squares; the
same seed has the same disorder and start at every C, so the pairs share their noise). The
bias at C is x(C) / x0 - 1, its mean over the seeds with its standard error. Cost: steps per
time unit, which the wall time of a run follows (benchmarks/RESULTS.md, "Speed").

Writes the table to benchmarks/records/work_precision.csv (the record; --from-record redraws
the plot from it alone) and draws the plot.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from benchmarks.harness import BENCH, RECORDS, parser
from benchmarks.measure.timestep import OUT
from benchmarks.report.timestep import load, spec_of
from bkflow.model.timestep import ACCURACY

RECORD = RECORDS / "work_precision.csv"
PLOT = BENCH / "work_precision.png"
OBSERVABLES = (("stress", "<sigma_x>/sigma_n"), ("mu_bar", "mu_bar"))
#: the presets' markers on each size's line, in the colours of their targets' lines
MARKERS = {"fast": "^", "default": "o", "precise": "s"}
PRESET_COLOURS = {"fast": "tab:red", "default": "tab:blue", "precise": "tab:purple"}
#: each size's line: colour and style
SIZE_STYLES = {100: ("0.1", "-"), 400: ("tab:orange", "--")}
#: the reference: the steps extrapolated to dt -> 0 (the smallest this many C of each phi)
RICHARDSON_POINTS = 3
#: the y axis (the size of the bias, %): a smaller one is drawn at its lower edge
FLOOR, CEILING = 1e-3, 60.0
#: the smallest text, in points at the saved size
MIN_FONT = 7.0


def richardson(c, x) -> float:
    """x0 of x(C) = x0 + a C^2 fitted to the points (least squares)."""
    c2 = np.asarray(c, float) ** 2
    A = np.vstack([np.ones_like(c2), c2]).T
    return float(np.linalg.lstsq(A, np.asarray(x, float), rcond=None)[0][0])


def table(runs: pd.DataFrame) -> pd.DataFrame:
    """Per (N, phi, C): the steps per time unit, omega_c dt, and each observable's bias
    against the seed's dt -> 0 reference (mean over seeds, standard error), the seeds."""
    rows = []
    for (n, phi), g in runs.groupby(["N", "phi"]):
        smallest = sorted(g.C.unique())[:RICHARDSON_POINTS]
        refs = {}
        for seed, gs in g[g.C.isin(smallest)].groupby("seed"):
            if gs.C.nunique() == len(smallest):
                refs[seed] = {o: richardson(gs.C, gs[o]) for o, _ in OBSERVABLES}
        for c, gc in g.groupby("C"):
            gc = gc[gc.seed.isin(list(refs))]
            if gc.empty:
                continue
            spec = spec_of(n, phi, c)
            row = {"N": n, "phi": phi, "C": c, "seeds": len(gc),
                   "steps_per_t": 1 / spec.dt, "wc_dt": spec.dt * spec.omega_contact,
                   "in_reference": c in smallest}
            for o, _ in OBSERVABLES:
                d = np.array([r[o] / refs[r.seed][o] - 1 for _, r in gc.iterrows()])
                row[f"{o}_bias"] = float(d.mean())
                row[f"{o}_se"] = float(d.std(ddof=1) / math.sqrt(len(d))) if len(d) > 1 \
                    else math.nan
            rows.append(row)
    return pd.DataFrame(rows)


def preset_points(t: pd.DataFrame) -> pd.DataFrame:
    """Per preset, N and phi: its step's cost and the bias there (measured at that step, or
    interpolated in dt between the steps measured)."""
    rows = []
    for (n, phi), g in t.groupby(["N", "phi"]):
        g = g.sort_values("steps_per_t")
        for name, p in ACCURACY.items():
            s = spec_of(n, phi, preset=name)
            row = {"preset": name, "target": p.dt_error, "N": n, "phi": phi,
                   "steps_per_t": 1 / s.dt}
            for o, _ in OBSERVABLES:
                row[f"{o}_bias"] = float(np.interp(1 / s.dt, g.steps_per_t, g[f"{o}_bias"]))
                row[f"{o}_se"] = float(np.interp(1 / s.dt, g.steps_per_t, g[f"{o}_se"]))
            rows.append(row)
    return pd.DataFrame(rows)


def plot(t: pd.DataFrame, path: Path):
    """The figure: a row per phi, a column per observable; in each panel the size of the bias
    against the cost (log-log), a line per size with its standard error as a band, a point
    within two standard errors of no bias drawn hollow; each preset's step marked on each
    line, and each preset's target a horizontal line in the preset's colour (a preset meets
    its target where its marker lies below its line)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    phis = sorted(t.phi.unique())
    pts = preset_points(t)
    with plt.rc_context({"font.size": MIN_FONT, "axes.titlesize": MIN_FONT + 0.5}):
        fig, axes = plt.subplots(len(phis), len(OBSERVABLES), sharex=True, sharey=True,
                                 figsize=(7.2, 1.45 * len(phis) + 1.3), squeeze=False,
                                 layout="constrained")
        for i, phi in enumerate(phis):
            for j, (o, label) in enumerate(OBSERVABLES):
                _panel(axes[i][j], t[t.phi == phi], pts[pts.phi == phi], o)
                axes[i][j].set_title(f"phi = {phi:g}: bias of {label}")
        for ax in axes[:, 0]:
            ax.set_ylabel("|bias| against dt -> 0 (%)")
        for ax in axes[-1]:
            ax.set_xlabel("cost: steps per time unit")
        _legend(fig, sorted(t.N.unique()))
        fig.savefig(path, dpi=200)
    return fig


def _panel(ax, t: pd.DataFrame, pts: pd.DataFrame, o: str) -> None:
    """One phi, one observable: a line per size, the presets' steps and targets."""
    for name, p in ACCURACY.items():
        ax.axhline(100 * p.dt_error, color=PRESET_COLOURS[name], lw=0.9, ls="--", zorder=1)
    for n, (colour, ls) in SIZE_STYLES.items():
        g = t[t.N == n].sort_values("steps_per_t")
        if g.empty:
            continue
        x = g.steps_per_t.to_numpy()
        y = 100 * np.abs(g[f"{o}_bias"].to_numpy())
        se = 100 * np.nan_to_num(g[f"{o}_se"].to_numpy())
        ax.fill_between(x, np.clip(y - se, FLOOR, None), np.clip(y + se, FLOOR, None),
                        color=colour, alpha=0.15, lw=0)
        ax.plot(x, np.clip(y, FLOOR, None), ls, color=colour, lw=1.0)
        noise = y < 2 * se
        ax.plot(x[~noise], np.clip(y[~noise], FLOOR, None), "o", color=colour, ms=2.5)
        ax.plot(x[noise], np.clip(y[noise], FLOOR, None), "o", color=colour, mfc="white",
                ms=2.5, mew=0.7)
        for name, mk in MARKERS.items():
            q = pts[(pts.N == n) & (pts.preset == name)]
            ax.plot(q.steps_per_t, np.clip(100 * np.abs(q[f"{o}_bias"]), FLOOR, None), mk,
                    color=PRESET_COLOURS[name], mec=colour, mew=1.0, ms=6, zorder=5,
                    label=f"{name} preset, N = {n}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylim(FLOOR, CEILING)


def _legend(fig, sizes) -> None:
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], color=SIZE_STYLES[n][0], ls=SIZE_STYLES[n][1], lw=1.0,
                      marker="o", ms=2.5, label=f"N = {n}") for n in sizes]
    handles += [Line2D([], [], color="0.4", ls="", marker="o", ms=2.5, mfc="white",
                       label="within 2 standard errors of 0")]
    handles += [Line2D([], [], ls="", marker=mk, color=PRESET_COLOURS[name], mec="k", ms=6,
                       label=f"{name} preset") for name, mk in MARKERS.items()]
    handles += [Line2D([], [], color=PRESET_COLOURS[name], lw=0.9, ls="--",
                       label=f"{name}'s target: +-{100 * p.dt_error:g}%")
                for name, p in ACCURACY.items()]
    fig.legend(handles=handles, loc="outside upper center", ncol=4, frameon=False,
               title=f"band: standard error over the seeds; a bias below {FLOOR:g}% is drawn "
                     "at the axis' lower edge; a preset's marker is edged in its size's colour",
               title_fontsize=MIN_FONT)


def write_record(t: pd.DataFrame, path: Path = RECORD) -> None:
    t.to_csv(path, index=False)


def read_record(path: Path = RECORD) -> pd.DataFrame:
    return pd.read_csv(path)


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--plot", default=str(PLOT))
    ap.add_argument("--from-record", nargs="?", const=str(RECORD), default=None,
                    metavar="CSV", help="redraw the plot from the record without reading the "
                    "runs' records")
    a = ap.parse_args(argv)
    if a.from_record:
        t = read_record(Path(a.from_record))
    else:
        t = table(load(OUT))
        write_record(t)
    plot(t, Path(a.plot))
    print(f"plot: {a.plot}; record: {RECORD}")


if __name__ == "__main__":
    main()
