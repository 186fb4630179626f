"""Work-precision of the steady state: the cost and the error of each accuracy preset under the
steady protocol, against converged steady references (docs/model.md "Steady state").

    python benchmarks/steady_presets.py [--out runs/bench/steady] [--groundtruth runs/groundtruth]
                                        [--phi 0.1,10,100,1000] [--sizes 100,900] [--seeds 3]

1. References, per (phi, N): fixed runs from the random start at C = 0.2, 0.1 and 0.05,
   t_end = 32000, seeds 1..S (OUT/reference_N<N>). Their means over seeds give the
   discretization error at each C (against C = 0.05). The random start still creeps at
   phi >= 100 over 32000 time units (benchmarks/RESULTS.md "Time to steady"), so the level of
   the reference is taken from the ground truth of benchmarks/steady.py (the last quarter of
   64000-time-unit runs at C = 0.2, pooled over the starts that reached their plateau), scaled
   by the measured ratio C = 0.05 / C = 0.2: the converged steady reference.
2. Presets: ``bkflow sweep`` with each --accuracy preset (the steady protocol: the run and its
   companion until both are steady and agree, at most the preset's cap), same seeds
   (OUT/<preset>_N<N>); the precise preset at N = 100 only (at N = 900 its stiff runs cost
   about an hour each on this machine).

Prints, per preset, phi and N: the wall time per run (the pair), the states, and the error of
<sigma_x>/sigma_n and mu_bar against the converged reference, with the reference's own
uncertainty (seed scatter and the spread of the starts' plateaus) beside it.
"""

from __future__ import annotations

import argparse
import glob
import math
import os
from pathlib import Path

import numpy as np
import pandas as pd

from bkflow.grid import parse_sizes, phi_values, sweep_specs
from bkflow.params import ACCURACY, protocol_fields
from bkflow.rundir import RunDir
from bkflow.sweep import sweep
from bkflow.tables import read_tables

C_VALUES = (0.2, 0.1, 0.05)
T_REF = 32000.0
#: the ground truth's last quarter counts from runs at least this long
GT_T_MIN = 60000.0


def run_all(out: Path, phis, sizes, seeds: int, jobs: int) -> None:
    for lx, ly in sizes:
        n = lx * ly
        specs = [s for c in C_VALUES for s in
                 sweep_specs(phis, [(lx, ly)], seeds, dt_factor=c, t_end=T_REF, start="random",
                             scene="friction")]
        sweep(specs, out / f"reference_N{n}", jobs=jobs, progress=False)
        for preset in ACCURACY:
            if preset == "precise" and n > 100:
                continue
            fields = protocol_fields("steady", preset)
            sweep(sweep_specs(phis, [(lx, ly)], seeds, scene="friction", **fields),
                  out / f"{preset}_N{n}", jobs=jobs, progress=False)


def _late_quarter(path: Path) -> tuple[float, float]:
    """The mean stress ratio and mu_bar over the last quarter of a run (events.csv)."""
    rd = RunDir(path)
    spec = rd.spec()
    t, sigma = rd.read_stress()
    t1 = t[-1]
    ev = rd.read_events()
    late = ev[ev.t_max >= 0.75 * t1]
    return (float(sigma[t >= 0.75 * t1].mean() / spec.sigma_n),
            float(late.sigma_fail.mean() / spec.sigma_n))


def groundtruth_levels(roots) -> pd.DataFrame:
    """Per (phi, N, seed): the plateau of the stress ratio and of mu_bar, pooled over the
    starts' last quarters (a synchronized run still on its plateau is left out: its quarter
    is more than 1% above the others' median), and the spread of the starts."""
    rows = []
    for root in roots:
        for meta in glob.glob(os.path.join(root, "workspace", "*", "meta.json")):
            rd = RunDir(Path(meta).parent)
            spec = rd.spec()
            if spec.t_end < GT_T_MIN:
                continue
            s, mu = _late_quarter(rd.path)
            rows.append({"phi": spec.phi, "N": spec.N, "seed": spec.seed, "start": spec.start,
                         "stress": s, "mu_bar": mu})
    df = pd.DataFrame(rows)
    out = []
    for key, g in df.groupby(["phi", "N", "seed"]):
        med = g.stress.median()
        keep = g[~((g.start == "synchronized") & (g.stress > 1.01 * med))]
        out.append({"phi": key[0], "N": key[1], "seed": key[2],
                    "stress": keep.stress.mean(), "mu_bar": keep.mu_bar.mean(),
                    "spread": (keep.stress.max() - keep.stress.min()) / keep.stress.mean()})
    return pd.DataFrame(out)


def references(out: Path, gt: pd.DataFrame, sizes) -> pd.DataFrame:
    """The converged steady reference per (phi, N): the ground truth's level scaled by the
    discretization ratio C = 0.05 / C = 0.2 of the fixed-length runs, mean over seeds."""
    rows = []
    for lx, ly in sizes:
        n = lx * ly
        runs, _ = read_tables(out / f"reference_N{n}")
        for phi, g in runs.groupby("phi"):
            by_c = g.groupby("dt_factor")[["mean_stress_ratio", "mu_bar"]].mean()
            level = gt[(np.isclose(gt.phi, phi)) & (gt.N == n)]
            row = {"phi": phi, "N": n}
            for obs, gcol in (("mean_stress_ratio", "stress"), ("mu_bar", "mu_bar")):
                ratio = by_c.loc[0.05, obs] / by_c.loc[0.2, obs]
                row[obs] = level[gcol].mean() * ratio if len(level) else by_c.loc[0.05, obs]
                row[f"{obs}_sem"] = (level[gcol].std(ddof=1) / math.sqrt(len(level))
                                     * ratio if len(level) > 1 else math.nan)
                for c in C_VALUES:
                    row[f"{obs}_C{c:g}"] = by_c.loc[c, obs] / by_c.loc[0.05, obs] - 1
            row["start_spread"] = level.spread.max() if len(level) else math.nan
            rows.append(row)
    return pd.DataFrame(rows)


def report(out: Path, refs: pd.DataFrame, sizes) -> None:
    print("## Discretization: fixed runs from the random start, t_end = 32000, against "
          "C = 0.05 (mean over seeds)\n")
    print("| N | phi | <sigma_x>/sigma_n at C = 0.2 / 0.1 | mu_bar at C = 0.2 / 0.1 |")
    print("|---|---|---|---|")
    for _, r in refs.iterrows():
        print(f"| {r.N:g} | {r.phi:g} | {100 * r['mean_stress_ratio_C0.2']:+.2f}% / "
              f"{100 * r['mean_stress_ratio_C0.1']:+.2f}% | {100 * r['mu_bar_C0.2']:+.2f}% / "
              f"{100 * r['mu_bar_C0.1']:+.2f}% |")
    print("\n## The presets under the steady protocol, against the converged steady reference "
          "(mean over seeds)\n")
    print("| preset | N | phi | wall per run (s) | states | error <sigma_x>/sigma_n | error "
          "mu_bar | reference: seed sem, starts' spread |")
    print("|---|---|---|---|---|---|---|---|")
    for preset in ACCURACY:
        for lx, ly in sizes:
            n = lx * ly
            d = out / f"{preset}_N{n}"
            if not (d / "runs.csv").exists():
                continue
            runs, _ = read_tables(d)
            for phi, g in runs.groupby("phi"):
                ref = refs[(np.isclose(refs.phi, phi)) & (refs.N == n)].iloc[0]
                es = g.mean_stress_ratio.mean() / ref.mean_stress_ratio - 1
                em = g.mu_bar.mean() / ref.mu_bar - 1
                states = ", ".join(f"{k} {v}" for k, v in g.state.value_counts().items())
                print(f"| {preset} | {n} | {phi:g} | {g.wall_time_s.mean():.1f} | {states} | "
                      f"{100 * es:+.2f}% | {100 * em:+.2f}% | "
                      f"{100 * ref.mean_stress_ratio_sem / ref.mean_stress_ratio:.2f}%, "
                      f"{100 * ref.start_spread:.2f}% |")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("--out", type=Path, default=Path("runs/bench/steady"))
    ap.add_argument("--groundtruth", nargs="+", default=["runs/groundtruth/*"],
                    help="the sweep directories of benchmarks/steady.py groundtruth")
    ap.add_argument("--phi", default="0.1,10,100,1000")
    ap.add_argument("--sizes", default="100,900")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--report-only", action="store_true")
    a = ap.parse_args(argv)
    sizes = parse_sizes(a.sizes)
    if not a.report_only:
        run_all(a.out, phi_values(a.phi), sizes, a.seeds, a.jobs)
    roots = [p for pattern in a.groundtruth for p in sorted(glob.glob(pattern))]
    refs = references(a.out, groundtruth_levels(roots), sizes)
    report(a.out, refs, sizes)


if __name__ == "__main__":
    main()
