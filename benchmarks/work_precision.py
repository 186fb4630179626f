"""Work-precision of the time step: the bias of the steady observables against the cost of a
time unit, per phi and size, against a dt -> 0 reference, with each accuracy preset's step and
its error target marked.

    python benchmarks/work_precision.py [--plot benchmarks/work_precision.png]
    python benchmarks/work_precision.py --from-record [CSV]

The runs are benchmarks/timestep.py's (records benchmarks/records/timestep/): per phi (0.1 to
1000), size (N = 100, 400) and seed, one run from the random start at each C = dt omega_max
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

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

RECORD = HERE / "records" / "work_precision.csv"
PLOT = HERE / "work_precision.png"
OBSERVABLES = (("stress", "<sigma_x>/sigma_n"), ("mu_bar", "mu_bar"))
#: the presets' markers on each phi's line, and the colours of their targets' lines
MARKERS = {"fast": "^", "default": "o", "precise": "s"}
TARGET_COLOURS = {"fast": "tab:red", "default": "tab:blue", "precise": "0.2"}
#: the reference: the steps extrapolated to dt -> 0 (the smallest this many C of each phi)
RICHARDSON_POINTS = 3
#: a bias below this (relative) is drawn at it (the y axis is symmetric-logarithmic)
LINEAR_BELOW = 1e-3


def richardson(c, x) -> float:
    """x0 of x(C) = x0 + a C^2 fitted to the points (least squares)."""
    c2 = np.asarray(c, float) ** 2
    A = np.vstack([np.ones_like(c2), c2]).T
    return float(np.linalg.lstsq(A, np.asarray(x, float), rcond=None)[0][0])


def table(runs: pd.DataFrame) -> pd.DataFrame:
    """Per (N, phi, C): the steps per time unit, omega_c dt, and each observable's bias
    against the seed's dt -> 0 reference (mean over seeds, standard error), the seeds."""
    from timestep_report import spec_of

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
    from timestep_report import spec_of

    from bkflow.model.params import ACCURACY

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
    """The figure: a column per size, a row per observable; per phi a line of the bias
    against the cost (symmetric-logarithmic in the bias), its standard error as a band, each
    preset's step marked on it, and each preset's target as dashed lines at +-target."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    from bkflow.model.params import ACCURACY

    sizes = sorted(t.N.unique())
    phis = sorted(t.phi.unique())
    colours = plt.get_cmap("viridis")(np.linspace(0, 0.9, len(phis)))
    pts = preset_points(t)
    fig, axes = plt.subplots(len(OBSERVABLES), len(sizes), figsize=(4.2 * len(sizes), 6.8),
                             sharex=True, sharey=True, squeeze=False)
    for j, n in enumerate(sizes):
        for i, (o, label) in enumerate(OBSERVABLES):
            ax = axes[i][j]
            for name, p in ACCURACY.items():
                for sign in (1, -1):
                    ax.axhline(100 * sign * p.dt_error, color=TARGET_COLOURS[name], lw=0.8,
                               ls="--", alpha=0.8)
            for k, phi in enumerate(phis):
                g = t[(t.N == n) & (t.phi == phi)].sort_values("steps_per_t")
                if g.empty:
                    continue
                x, y = g.steps_per_t.to_numpy(), 100 * g[f"{o}_bias"].to_numpy()
                se = 100 * np.nan_to_num(g[f"{o}_se"].to_numpy())
                ax.fill_between(x, y - se, y + se, color=colours[k], alpha=0.15, lw=0)
                ax.plot(x, y, "-", color=colours[k], lw=1.3)
                for name, mk in MARKERS.items():
                    q = pts[(pts.N == n) & (pts.phi == phi) & (pts.preset == name)]
                    if len(q):
                        ax.plot(q.steps_per_t, 100 * q[f"{o}_bias"], mk, color=colours[k],
                                ms=6, mec="k", mew=0.6)
            ax.set_xscale("log")
            ax.set_yscale("symlog", linthresh=100 * LINEAR_BELOW, linscale=0.6)
            ax.axhline(0, color="k", lw=0.5)
            ax.set_title(f"N = {n}: {label}", fontsize=9)
            if j == 0:
                ax.set_ylabel("bias against dt -> 0 (%)")
            if i == len(OBSERVABLES) - 1:
                ax.set_xlabel("cost: steps per time unit")
            ax.tick_params(labelsize=8)
    handles = [Line2D([], [], color=colours[k], lw=1.5, label=f"phi = {phi:g}")
               for k, phi in enumerate(phis)]
    handles += [Line2D([], [], ls="", marker=mk, color="0.5", mec="k", label=f"{name} preset")
                for name, mk in MARKERS.items()]
    handles += [Line2D([], [], color=TARGET_COLOURS[name], lw=0.8, ls="--",
                       label=f"{name}'s target: +-{100 * p.dt_error:g}%")
                for name, p in ACCURACY.items()]
    fig.legend(handles=handles, loc="lower center", ncol=5, fontsize=8, frameon=False,
               title="band: standard error over the seeds", title_fontsize=8)
    fig.tight_layout(rect=(0, 0.14, 1, 1))
    fig.savefig(path, dpi=150)
    return fig


def write_record(t: pd.DataFrame, path: Path = RECORD) -> None:
    t.to_csv(path, index=False)


def read_record(path: Path = RECORD) -> pd.DataFrame:
    return pd.read_csv(path)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plot", default=str(PLOT))
    ap.add_argument("--from-record", nargs="?", const=str(RECORD), default=None,
                    metavar="CSV", help="redraw the plot from the record without reading the "
                    "runs' records")
    a = ap.parse_args(argv)
    if a.from_record:
        t = read_record(Path(a.from_record))
    else:
        from timestep import OUT
        from timestep_report import load

        t = table(load(OUT))
        write_record(t)
    plot(t, Path(a.plot))
    print(f"plot: {a.plot}; record: {RECORD}")


if __name__ == "__main__":
    main()
