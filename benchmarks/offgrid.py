"""Long runs off the calibrated grid: the held-out truth that the steady protocol's verdict and
estimate are judged on (benchmarks/verdict_offgrid.py reads them).

The switching calibration (src/bkflow/observables/switching.json) and the stop rule were made on
the model's defaults at N = 100 and 400 (benchmarks/stiff_states.py). Here the same long runs,
four starts each, are made where nothing was calibrated: other model parameters (gamma, k_e,
V_d) at N = 100, and another aspect (a square 10x10 lattice). N = 900 at the defaults is
benchmarks/stiff_states.py's own (``run --n 900``).

    python benchmarks/offgrid.py run [--t-end 2e5] [--cases all] [--shard I/K]
    python benchmarks/offgrid.py list

Each case records blocks of 1000 time units into benchmarks/records/offgrid/ (Parquet, as
``longrun.LongRun``); the name carries what differs from the defaults
(``N100_gamma0.1_phi1000_random_s1_C1.parquet``). Resumable: run the same command again.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))

from longrun import RECORDS, LongRun  # noqa: E402
from stiff_states import dt_factor  # noqa: E402

from bkflow.model.params import STARTS, RunSpec  # noqa: E402

OUT = RECORDS / "offgrid"
#: what differs from the model's defaults, and the lattice: name -> (Lx, Ly, {field: value})
VARIANTS = {
    "gamma0.1": (20, 5, {"gamma": 0.1}),
    "k_e20": (20, 5, {"k_e": 20.0}),
    "V_d0.05": (20, 5, {"V_d": 0.05}),
    "sq10x10": (10, 10, {}),
}
PHI = (10.0, 100.0, 1000.0)
SEEDS = (1, 2, 3)


def case_name(variant: str, spec: RunSpec) -> str:
    return (f"N{spec.N}_{variant}_phi{spec.phi:g}_{spec.start}_s{spec.seed}"
            f"_C{spec.dt_factor:g}")


def cases(variants=None, phis=PHI, seeds=SEEDS, starts=STARTS):
    """(variant, spec) of every case, phi by phi (the stiffest last: the longest)."""
    for phi in phis:
        for name in (variants or VARIANTS):
            Lx, Ly, fields = VARIANTS[name]
            for seed in seeds:
                for start in starts:
                    spec = RunSpec(phi=phi, Lx=Lx, Ly=Ly, seed=seed, start=start, **fields)
                    yield name, spec.replace(dt_factor=dt_factor(spec))


NAME = re.compile(r"N(\d+)_([\w.]+?)_phi([\d.]+)_(\w+?)_s(\d+)_C([\d.]+)\.parquet$")
#: the share of each run left out as its start's transient (as benchmarks/states_report.py)
TRANSIENT = 0.2


def load(root=OUT) -> pd.DataFrame:
    """One row per run: variant, N, phi, start, seed, C, its kept blocks and its whole
    record."""
    rows = []
    for f in sorted(Path(root).glob("*.parquet")):
        m = NAME.search(f.name)
        if not m:
            continue
        n, variant, phi, start, seed, c = m.groups()
        rec = pd.read_parquet(f)
        rows.append({"variant": variant, "N": int(n), "phi": float(phi), "start": start,
                     "seed": int(seed), "C": float(c), "t": float(rec.t1.iloc[-1]),
                     "blocks": rec.iloc[int(TRANSIENT * len(rec)):].reset_index(drop=True),
                     "whole": rec})
    return pd.DataFrame(rows)


def _chi(b: pd.DataFrame, n: int) -> float:
    w = b.n.to_numpy(float)
    return float(n * (np.average(b.R2abs, weights=w) - np.average(b.Zre, weights=w) ** 2
                      - np.average(b.Zim, weights=w) ** 2))


def truths(runs: pd.DataFrame | None = None) -> dict:
    """(variant, N, phi, seed) -> the layer's long-run means: {"stress", "mu_bar", "starts"
    (those pooled), "spread" (the largest relative difference of their means)}. Every start's
    kept blocks pooled, but a start whose kept part still holds the start's common phase
    (chi above bkflow's memory threshold: the synchronized start of a stiff layer) is left
    out: its numbers are its start's."""
    from bkflow.observables.states import memory_chi

    runs = load() if runs is None else runs
    out = {}
    for key, g in runs.groupby(["variant", "N", "phi", "seed"]):
        n = key[1]
        keep = [r for _, r in g.iterrows() if _chi(r.blocks, n) <= memory_chi(n)]
        if not keep:
            continue
        allb = pd.concat([r.blocks for r in keep], ignore_index=True)
        w = (allb.t1 - allb.t0).to_numpy()
        nslip = allb["nslip_0.01"].sum()
        per = [np.average(r.blocks.s, weights=r.blocks.t1 - r.blocks.t0) for r in keep]
        out[key] = {"stress": float(np.average(allb.s, weights=w)),
                    "mu_bar": float(allb["sfail_0.01"].sum() / nslip) if nslip else math.nan,
                    "starts": [r.start for r in keep],
                    "spread": float((max(per) - min(per)) / np.mean(per))}
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("--t-end", type=float, default=2e5)
    r.add_argument("--cases", default="all", help="variants, comma-separated, or all")
    r.add_argument("--shard", default="0/1")
    r.add_argument("--chunk", type=float, default=5e4)
    sub.add_parser("list")
    a = ap.parse_args(argv)
    variants = None if a.cmd == "list" or a.cases == "all" else a.cases.split(",")
    todo = list(cases(variants))
    if a.cmd == "list":
        for name, spec in todo:
            print(case_name(name, spec))
        return
    i, k = (int(v) for v in a.shard.split("/"))
    for name, spec in todo[i::k]:
        LongRun(spec, OUT / f"{case_name(name, spec)}.parquet", 1000.0, a.chunk).advance_to(
            a.t_end, log=lambda m: print(m, flush=True))


if __name__ == "__main__":
    main()
