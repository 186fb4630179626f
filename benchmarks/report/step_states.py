"""The time step at the stiff end, from the records of benchmarks/measure/step_states.py (and
C = 1 from benchmarks/measure/stiff_states.py's).

    python -m benchmarks.report.step_states

Per phi and C, over the seeds (the first 20% of each run left out): the quiet share, the
residence times, each state's mean stress and mu_bar and the whole run's, as differences from
C = 1 paired by seed; and each state's mean extrapolated to dt -> 0 from C = 0.5 and 1
(velocity Verlet's bias falls as dt^2: x(0) = (4 x(0.5) - x(1)) / 3), whence the step bias of
the ground truth. benchmarks/documents/ renders the table (block ``step-states``).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from benchmarks.harness import parser
from benchmarks.measure import stiff_states
from benchmarks.measure.step_states import OUT, PHI, N
from benchmarks.report.stiff_states import NAME

#: the share of each run left out as the start's transient
TRANSIENT = 0.2


def records(t_end: float = 1e6) -> pd.DataFrame:
    """One row per (phi, C, seed): the kept blocks of its first ``t_end`` time units (C = 1
    from benchmarks/records/stiff_states)."""
    rows = []
    for root in (OUT, stiff_states.OUT):
        for f in sorted(root.glob(f"N{N}_phi*_random_s*_C*.parquet")):
            m = NAME.search(f.name)
            if not m:
                continue
            n, phi, start, seed, c = m.groups()
            phi, c = float(phi), float(c)
            if phi not in PHI or (root != OUT and c != 1.0):
                continue
            rec = pd.read_parquet(f)
            rec = rec[rec.t1 <= t_end * (1 + 1e-6)]
            if rec.t1.iloc[-1] < 0.99 * t_end:
                continue
            rows.append({"phi": phi, "C": c, "seed": int(seed),
                         "blocks": rec.iloc[int(TRANSIENT * len(rec)):].reset_index(drop=True)})
    return pd.DataFrame(rows)


def _stats(b: pd.DataFrame) -> dict:
    """A run's quiet share, residence times and each state's means (the rules of
    benchmarks/report/stiff_states.py)."""
    from bkflow.observables.states import r_independent

    quiet = (b.R < r_independent(N)).to_numpy()
    out = {"quiet": float(quiet.mean())}
    edges = np.flatnonzero(np.diff(quiet.astype(int))) + 1
    stretches = {True: [], False: []}
    for a, z in zip(edges[:-1], edges[1:]):
        stretches[bool(quiet[a])].append((z - a) * 1000.0)
    for name, m in (("quiet", quiet), ("coherent", ~quiet), ("all", np.ones_like(quiet))):
        sub = b[m]
        n = sub["nslip_0.01"].sum()
        out[f"s_{name}"] = float(sub.s.mean()) if len(sub) else math.nan
        out[f"mu_{name}"] = float(sub["sfail_0.01"].sum() / n) if n else math.nan
    out["res_quiet"] = float(np.mean(stretches[True])) if stretches[True] else math.nan
    out["res_coherent"] = float(np.mean(stretches[False])) if stretches[False] else math.nan
    return out


def table(t_end: float = 1e6) -> pd.DataFrame:
    """Per (phi, C): the seeds, the mean of each statistic over them, and the paired
    difference of each mean from C = 1 (relative) with its standard error."""
    recs = records(t_end)
    if recs.empty:
        return pd.DataFrame()
    stats = pd.DataFrame([{"phi": r.phi, "C": r.C, "seed": r.seed, **_stats(r.blocks)}
                          for _, r in recs.iterrows()])
    rows = []
    for (phi, c), g in stats.groupby(["phi", "C"]):
        ref = stats[(stats.phi == phi) & (stats.C == 1.0)].set_index("seed")
        g = g.set_index("seed")
        # the seeds every C of this phi has: the pairs, and C = 1's row over the same seeds
        common = set.intersection(*(set(x.seed) for _, x in stats[stats.phi == phi]
                                    .groupby("C")))
        seeds = sorted(set(g.index) & set(ref.index) & common)
        row = {"phi": phi, "C": c, "seeds": len(seeds)}
        for k in ("quiet", "res_quiet", "res_coherent"):
            row[k] = float(g.loc[seeds, k].mean())
            row[f"{k}_sd"] = float(g.loc[seeds, k].std(ddof=1)) if len(seeds) > 1 else math.nan
        for k in ("s_quiet", "s_coherent", "s_all", "mu_quiet", "mu_coherent", "mu_all"):
            row[k] = float(g.loc[seeds, k].mean())
            d = (g.loc[seeds, k] / ref.loc[seeds, k] - 1).dropna()
            row[f"d_{k}"] = float(d.mean()) if len(d) else math.nan
            row[f"d_{k}_se"] = float(d.std(ddof=1) / math.sqrt(len(d))) if len(d) > 1 else math.nan
        rows.append(row)
    return pd.DataFrame(rows)


def extrapolated(t: pd.DataFrame) -> pd.DataFrame:
    """Per phi and statistic: the bias of C = 1 against dt -> 0, from the paired differences
    at C = 0.5 (x(0) = (4 x(0.5) - x(1)) / 3, so x(1) / x(0) - 1 = -4/3 d(0.5) to first
    order), with its standard error."""
    rows = []
    for phi, g in t.groupby("phi"):
        half = g[g.C == 0.5]
        if half.empty:
            continue
        h = half.iloc[0]
        row = {"phi": phi}
        for k in ("s_quiet", "s_coherent", "s_all", "mu_quiet", "mu_coherent", "mu_all"):
            row[k] = -4.0 / 3.0 * h[f"d_{k}"]
            row[f"{k}_se"] = 4.0 / 3.0 * h[f"d_{k}_se"]
        rows.append(row)
    return pd.DataFrame(rows)


def main(argv=None) -> None:
    parser(__doc__).parse_args(argv)
    pd.set_option("display.width", 200)
    print(table().round(5).to_string())
    print(extrapolated(table()).round(5).to_string())


if __name__ == "__main__":
    main()
