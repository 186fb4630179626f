"""Work-precision: error of mu_bar, <sigma_x>/sigma_n and Psi(inf) against cost, as the
dt-factor C and the run length t_end vary, against a converged reference.

For each phi (default 0.1, 10, 1000) at N = 100 (20x5), every (C, t_end) of the grid runs
seeds 1..S (a bkflow sweep, so re-running only computes what is missing); the reference is
the smallest C with the longest t_end, same seeds. The error of a configuration is the
difference between its mean over seeds and the reference's, relative to the reference; the
seed-to-seed spread (standard error over seeds, relative) is reported beside it so that
statistical and discretization error are not confused. The seeds fix the disorder k_d^i, so
configuration and reference share it (common random numbers); what remains of the spread is
the run's own sampling noise. Cost = mean LAMMPS wall time per run (meta.json) measured with 2
runs side by side on the 2 cores, and atom-steps.

    python benchmarks/work_precision.py [--phi 0.1 10 1000] [--size 20x5] [--seeds 3]
        [--contact-rule reset|reset/step|coulomb] [--damping implicit|half]
        [--out runs/bench/work_precision] [--plot benchmarks/work_precision.png]
    python benchmarks/work_precision.py --from-record [CSV]

Prints markdown tables (one per phi), writes them to benchmarks/records/work_precision.csv
(the record) and draws the plot; --from-record redraws the plot from the record alone.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd

from bkflow.cli.assignments import parse_size
from bkflow.model.params import CONTACT_RULES, DAMPING_MODES, RunSpec
from bkflow.store.tables import read_tables
from bkflow.sweeps.grid import sweep_specs
from bkflow.sweeps.local import sweep

C_VALUES = (0.025, 0.05, 0.1, 0.2, 0.4)
T_VALUES = (1000.0, 2000.0, 4000.0, 8000.0)
REFERENCE = (0.025, 16000.0)
#: the reference's length at the larger C too (the precise preset is one of them)
EXTRA = ((0.1, 16000.0), (0.2, 16000.0), (0.4, 16000.0))
OBSERVABLES = (("mu_bar", "mu_bar"), ("mean_stress_ratio", "<sigma_x>/sigma_n"),
               ("psi_inf", "Psi(inf)"))


def specs_for(phis, size, seeds, **scheme):
    lx, ly = size
    out = []
    for phi in phis:
        for c, t in [(c, t) for c in C_VALUES for t in T_VALUES] + list(EXTRA) + [REFERENCE]:
            out += sweep_specs([phi], [(lx, ly)], seeds, dt_factor=c, t_end=t, scene="order",
                               **scheme)
    return out


def table(runs: pd.DataFrame, phi: float, size=(RunSpec.Lx, RunSpec.Ly)) -> pd.DataFrame:
    lx, ly = size
    r = runs[np.isclose(runs.phi, phi)]
    g = r.groupby(["dt_factor", "t_end"])
    mean = g[[o for o, _ in OBSERVABLES] + ["wall_time_s"]].mean()
    sem = g[[o for o, _ in OBSERVABLES]].std(ddof=1) / np.sqrt(g.size().to_numpy())[:, None]
    ref = mean.loc[REFERENCE]
    rows = []
    for (c, t), m in mean.iterrows():
        spec = RunSpec(phi=phi, Lx=lx, Ly=ly, dt_factor=c, t_end=t)
        row = {"C": c, "t_end": t, "wall_s": m.wall_time_s,
               "atom_steps": float(spec.N * spec.n_steps)}
        for o, _ in OBSERVABLES:
            row[f"{o}_err"] = abs(m[o] - ref[o]) / abs(ref[o])
            row[f"{o}_spread"] = sem.loc[(c, t), o] / abs(ref[o])
        row["reference"] = (c, t) == REFERENCE
        rows.append(row)
    return pd.DataFrame(rows).sort_values(["C", "t_end"]), ref


def markdown(df: pd.DataFrame, ref, phi) -> str:
    out = [f"phi = {phi:g}: reference (C = {REFERENCE[0]}, t_end = {REFERENCE[1]:g}) mu_bar = "
           f"{ref.mu_bar:.5f}, <sigma_x>/sigma_n = {ref.mean_stress_ratio:.5f}, "
           f"Psi(inf) = {ref.psi_inf:.4f}", "",
           "| C | t_end | wall/run | mu_bar err | (spread) | <sigma_x>/sigma_n err | (spread) "
           "| Psi(inf) err | (spread) |", "|---|---|---|---|---|---|---|---|---|"]
    for _, r in df.iterrows():
        if r.reference:
            continue
        out.append(f"| {r.C:g} | {r.t_end:g} | {r.wall_s:.2f} s | {100 * r.mu_bar_err:.2f}% | "
                   f"{100 * r.mu_bar_spread:.2f}% | {100 * r.mean_stress_ratio_err:.2f}% | "
                   f"{100 * r.mean_stress_ratio_spread:.2f}% | {100 * r.psi_inf_err:.2f}% | "
                   f"{100 * r.psi_inf_spread:.2f}% |")
    return "\n".join(out)


#: the smallest error the log axes show (%): an error at or below it (a configuration that
#: agrees with the reference to the digits of the table) is drawn on this floor, marked
ERROR_FLOOR = 0.01
#: the record of the measurement (every table), from which the plot is redrawn without
#: running anything: python benchmarks/work_precision.py --from-record
RECORD = Path(__file__).with_name("records") / "work_precision.csv"


def plot(tables: dict, path: Path, n_atoms: int = RunSpec.Lx * RunSpec.Ly):
    """Error against wall time per run, one column per phi, one row per observable: one
    line per C (colour), along which t_end grows (marker size, keyed); solid the error
    against the reference, dotted the seed spread. The key is below the panels (it covers no
    point); an error at or below ERROR_FLOOR is drawn on the floor as a down-pointing
    triangle. Writes ``path`` and returns the Figure."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    phis = list(tables)
    c_values = sorted({float(c) for df in tables.values() for c in df.C})
    t_values = sorted({float(t) for df in tables.values() for t in df.t_end[~df.reference]})
    colours = dict(zip(c_values, plt.get_cmap("viridis")(np.linspace(0, 0.9, len(c_values)))))
    size = dict(zip(t_values, np.linspace(2.5, 6.5, len(t_values))))
    fig, axes = plt.subplots(len(OBSERVABLES), len(phis), figsize=(3.2 * len(phis), 8.2),
                             squeeze=False, sharex="col", layout="constrained")
    floored = False
    for j, phi in enumerate(phis):
        df = tables[phi][~tables[phi].reference]
        for i, (o, label) in enumerate(OBSERVABLES):
            ax = axes[i, j]
            for c, g in df.groupby("C"):
                g = g.sort_values("t_end")
                err = 100 * g[f"{o}_err"].to_numpy(float)
                low = err <= ERROR_FLOOR
                floored |= bool(low.any())
                y = np.maximum(err, ERROR_FLOOR)
                colour = colours[float(c)]
                ax.plot(g.wall_s, y, "-", lw=0.9, color=colour)
                for x, yy, t, lo in zip(g.wall_s, y, g.t_end, low):
                    ax.plot(x, yy, "v" if lo else "o", ms=size[float(t)], color=colour,
                            mfc="white" if lo else colour, mew=0.9)
                ax.plot(g.wall_s, np.maximum(100 * g[f"{o}_spread"], ERROR_FLOOR), ":",
                        lw=0.8, color=colour)
            ax.axhline(1.0, color="grey", lw=0.6, ls="--")
            ax.set_xscale("log")
            ax.set_yscale("log")
            if i == 0:
                ax.set_title(f"phi = {phi:g}, N = {n_atoms}", fontsize=9)
            if j == 0:
                ax.set_ylabel(f"{label}: error (%)", fontsize=8)
            if i == len(OBSERVABLES) - 1:
                ax.set_xlabel("wall time per run (s)", fontsize=8)
            ax.tick_params(labelsize=7)
    groups = [[(Line2D([], [], color=colours[c], lw=0.9, marker="o", ms=3.5), f"C = {c:g}")
               for c in c_values],
              [(Line2D([], [], color="0.4", ls="none", marker="o", ms=size[t]),
                f"t_end = {t:g}") for t in t_values],
              [(Line2D([], [], color="0.4", lw=0.9), "error against the reference"),
               (Line2D([], [], color="0.4", lw=0.8, ls=":"), "seed spread (standard error)"),
               (Line2D([], [], color="grey", lw=0.6, ls="--"), "1%")]]
    if floored:
        groups[-1].append((Line2D([], [], color="0.4", ls="none", marker="v", mfc="white"),
                           f"error <= {ERROR_FLOOR:g}%, drawn at {ERROR_FLOOR:g}%"))
    # one group per row of the key (a legend fills column by column: the rows laid out so)
    ncol = max(len(g) for g in groups)
    rows = [g + [(Line2D([], [], alpha=0), "")] * (ncol - len(g)) for g in groups]
    keys = [rows[r][c] for c in range(ncol) for r in range(len(rows))]
    fig.legend(*zip(*keys), loc="outside lower center", ncol=ncol, frameon=False, fontsize=7,
               title="one line per C (colour); along each line t_end grows (marker size)",
               title_fontsize=7)
    fig.savefig(path, dpi=150)
    return fig


def write_record(tables: dict, path: Path = RECORD) -> None:
    """The tables of a measurement, one CSV (a column phi beside each table's)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    pd.concat([df.assign(phi=phi) for phi, df in tables.items()]).to_csv(path, index=False)


def read_record(path: Path = RECORD) -> dict:
    """phi -> table, as write_record wrote them."""
    rec = pd.read_csv(path)
    return {float(phi): g.drop(columns="phi").reset_index(drop=True)
            for phi, g in rec.groupby("phi", sort=False)}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("--phi", type=float, nargs="+", default=[0.1, 10.0, 1000.0])
    ap.add_argument("--size", default="20x5")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--contact-rule", choices=CONTACT_RULES, default=RunSpec.contact_rule)
    ap.add_argument("--damping", choices=DAMPING_MODES, default=RunSpec.damping)
    ap.add_argument("--out", default="runs/bench/work_precision")
    ap.add_argument("--plot", default=str(Path(__file__).with_name("work_precision.png")))
    ap.add_argument("--from-record", nargs="?", const=str(RECORD), default=None,
                    metavar="CSV", help="redraw the plot from the record of a measurement "
                    f"(default {RECORD.relative_to(Path(__file__).parent.parent)}) without "
                    "running anything")
    a = ap.parse_args(argv)
    lx, ly = parse_size(a.size)
    if a.from_record:
        plot(read_record(Path(a.from_record)), Path(a.plot), lx * ly)
        print(f"plot: {a.plot} (from {a.from_record})")
        return
    specs = specs_for(a.phi, (lx, ly), a.seeds, contact_rule=a.contact_rule,
                      damping=a.damping)
    rep = sweep(specs, a.out, jobs=a.jobs)
    print(f"{len(rep.finished)} runs done, {rep.finished_before} earlier, {len(rep.failed)} "
          f"failed\n")
    runs, _ = read_tables(a.out)  # runs.csv, as sweep() wrote it: every run of the directory
    runs = runs[(runs.contact_rule == a.contact_rule) & (runs.damping == a.damping)
                & (runs.Lx == lx) & (runs.Ly == ly) & (runs.seed <= a.seeds)]
    tables = {}
    for phi in a.phi:
        df, ref = table(runs, phi, (lx, ly))
        tables[phi] = df
        print(markdown(df, ref, phi) + "\n")
    write_record(tables)
    plot(tables, Path(a.plot), lx * ly)
    print(f"plot: {a.plot}; record: {RECORD}")


if __name__ == "__main__":
    main()
