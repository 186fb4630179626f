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

Prints markdown tables (one per phi) and writes the plot.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd

from bkflow.grid import sweep_specs
from bkflow.params import CONTACT_RULES, DAMPING_MODES, RunSpec, parse_size
from bkflow.sweep import sweep
from bkflow.tables import read_tables

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


def plot(tables: dict, path: Path, n_atoms: int = RunSpec.Lx * RunSpec.Ly) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    phis = list(tables)
    fig, axes = plt.subplots(len(OBSERVABLES), len(phis), figsize=(3.2 * len(phis), 7.5),
                             squeeze=False, sharex="col")
    for j, phi in enumerate(phis):
        df = tables[phi][~tables[phi].reference]
        for i, (o, label) in enumerate(OBSERVABLES):
            ax = axes[i, j]
            for c, g in df.groupby("C"):
                g = g.sort_values("t_end")
                ax.plot(g.wall_s, 100 * g[f"{o}_err"].clip(lower=1e-4), "o-", ms=3, lw=0.8,
                        label=f"C = {c:g}")
                ax.plot(g.wall_s, 100 * g[f"{o}_spread"], ":", lw=0.6,
                        color=ax.lines[-1].get_color())
            ax.axhline(1.0, color="grey", lw=0.6, ls="--")
            ax.set_xscale("log")
            ax.set_yscale("log")
            if i == 0:
                ax.set_title(f"phi = {phi:g}, N = {n_atoms}", fontsize=9)
            if j == 0:
                ax.set_ylabel(f"{label} error (%)", fontsize=8)
            if i == len(OBSERVABLES) - 1:
                ax.set_xlabel("wall time per run (s)", fontsize=8)
            ax.tick_params(labelsize=7)
    axes[0, 0].legend(fontsize=6, frameon=False, title="solid: error vs reference\n"
                      "dotted: seed spread", title_fontsize=6)
    fig.tight_layout()
    fig.savefig(path, dpi=150)


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
    a = ap.parse_args(argv)
    lx, ly = parse_size(a.size)
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
    plot(tables, Path(a.plot), lx * ly)
    print(f"plot: {a.plot}")


if __name__ == "__main__":
    main()
