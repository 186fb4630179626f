"""The steady state: long runs from every start as ground truth, the verdict calibrated on them,
and the start that forgets fastest (docs/model.md "Starting state", "Steady state").

    python benchmarks/steady.py groundtruth [--out runs/groundtruth] [--sizes 100,400,900]
                                            [--phi 0.1,1,10,30,100,300,1000] [--seeds 3]
    python benchmarks/steady.py report [DIR ...]    # the sweep directories of the runs

groundtruth
    One sweep per start (a fixed length, no stop rule) into OUT/START: the synchronized,
    stratified and random starts for --t-end (64000 time units), the partial start for
    --partial-t-end (32000), scene friction (the stress and phase series are all the verdict
    reads). About 5 CPU-hours at N = 100, 400 and 900.
report
    The long-run plateau of each (phi, N, seed): the mean of sigma_x/sigma_n over the last
    quarter of every run of at least PLATEAU_T_MIN time units, pooled over the starts (a last
    quarter that still holds the synchronized start's coherence, phase fluctuation above
    PLATEAU_CHI_MAX, is left out: that run has not reached its plateau); the spread of the
    starts' last quarters says how well the plateau itself is known.

    Every run is then cut as the steady protocol sees it: checks from STEADY_T_MIN every
    ADAPTIVE_CHUNK_T, each over the window [transient, T] of a run of length T. At each check
    the window's state (the trend test of bkflow.stationarity, the phase fluctuation of
    bkflow.phases) is computed from prefix sums, which is the same arithmetic summed in
    another order; a sample of checks is recomputed with bkflow's own functions and the
    number that agree is printed. A window called steady is false when its mean stress is off
    the plateau by more than 0.5%.

    - single runs: every run alone, stopping at its first check found steady with a drift
      bound <= STEADY_DRIFT_BOUND;
    - pairs, the steady protocol: a run from STEADY_START with its companion from
      STEADY_COMPANION (the same phi, N and seed), stopping at the first check where both
      are steady and their mean stresses agree within STEADY_AGREEMENT;
    - time to steady: per start (and for the pair), the first check found steady (with the
      pair's rule for the pair) whose mean is within 0.2% of the plateau, median over seeds.
"""

from __future__ import annotations

import argparse
import glob
import math
import os
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

from bkflow.grid import parse_sizes, phi_values, sweep_specs
from bkflow.params import (
    ADAPTIVE_CHUNK_T,
    STARTS,
    STEADY_AGREEMENT,
    STEADY_COMPANION,
    STEADY_DRIFT_BOUND,
    STEADY_START,
    STEADY_T_MIN,
    transient_step,
)
from bkflow.phases import COHERENT_FLUCTUATION, coherence, state
from bkflow.rundir import RunDir
from bkflow.stationarity import ALPHA, N_BLOCKS, stationarity
from bkflow.sweep import sweep

#: a run's last quarter counts towards the plateau only if the run is at least this long
PLATEAU_T_MIN = 60000.0
#: a last quarter whose contacts still move together this much has not reached the plateau
PLATEAU_CHI_MAX = 5.0
#: a window called steady is false when its mean is off the plateau by more than this
FALSE_STEADY = 0.005
#: the time to steady counts once a run is within this of its plateau
WITHIN = 0.002
#: checks recomputed with bkflow's own functions, per run
VERIFY_PER_RUN = 3


# --------------------------------------------------------------------------- ground truth
def groundtruth(out: str, sizes: str, phis: str, seeds: int, t_end: float,
                partial_t_end: float, jobs: int) -> None:
    for start in STARTS:
        length = partial_t_end if start == "partial" else t_end
        specs = sweep_specs(phi_values(phis), parse_sizes(sizes), seeds, t_end=length,
                            start=start, scene="friction")
        print(f"{start}: {len(specs)} runs of {length:g} time units", flush=True)
        sweep(specs, Path(out) / start, jobs=jobs, progress=False)


# --------------------------------------------------------------------------- one run's checks
def run_dirs(roots) -> list[str]:
    """Every finished run under the given sweep directories (their workspaces)."""
    found = []
    for root in roots:
        found += sorted(str(Path(p).parent) for p in
                        glob.glob(os.path.join(root, "workspace", "*", "meta.json")))
    return found


class _Prefix:
    """Window means of a series from its prefix sums."""

    def __init__(self, t, x):
        self.t = np.asarray(t, float)
        self.c = np.concatenate([[0.0], np.cumsum(x)])

    def mean(self, a: float, b: float) -> float:
        """The mean of the samples with a <= t <= b."""
        i = np.searchsorted(self.t, a, "left")
        j = np.searchsorted(self.t, b, "right")
        return (self.c[j] - self.c[i]) / (j - i) if j > i else math.nan

    def block_mean(self, a: float, b: float) -> float:
        """The mean of the samples with a <= t < b (bkflow.stationarity.block_means' bins)."""
        i = np.searchsorted(self.t, a, "left")
        j = np.searchsorted(self.t, b, "left")
        return (self.c[j] - self.c[i]) / (j - i) if j > i else math.nan


def _trend(p: _Prefix, t0: float, t1: float) -> tuple[bool, float]:
    """bkflow.stationarity.stationarity's test on [t0, t1] from prefix sums: (flat, drift
    bound)."""
    edges = np.linspace(t0, t1, N_BLOCKS + 1)
    means = np.array([p.block_mean(edges[k], edges[k + 1]) for k in range(N_BLOCKS - 1)]
                     + [p.mean(edges[-2], t1)])
    if not np.all(np.isfinite(means)):
        return False, math.nan
    fit = stats.linregress(0.5 * (edges[:-1] + edges[1:]), means)
    level = means.mean()
    drift, err = fit.slope * (t1 - t0) / level, fit.stderr * (t1 - t0) / abs(level)
    return (fit.pvalue >= ALPHA if err > 0 else fit.slope == 0), abs(drift) + 2 * err


def _checks(path: str) -> dict:
    """Every check of a run (window state, drift bound, mean stress, chi), and the last
    quarter; a few checks recomputed with bkflow's own functions."""
    rd = RunDir(path)
    spec = rd.spec()
    t, sigma = rd.read_stress()
    s = sigma / spec.sigma_n
    ph = rd.read_phase()
    tp, Z = ph["t"], ph["Z_re"] + 1j * ph["Z_im"]
    ps = _Prefix(t, s)
    pz, pzi, pz2 = _Prefix(tp, Z.real), _Prefix(tp, Z.imag), _Prefix(tp, np.abs(Z) ** 2)
    T_end = float(t[-1])
    rows = []
    T = STEADY_T_MIN
    while T <= T_end + 1e-9:
        T_last = t[np.searchsorted(t, T, "right") - 1]
        t0 = transient_step(spec.transient, int(round(T / spec.dt))) * spec.dt
        flat, bound = _trend(ps, t0, T_last)
        chi = spec.N * (pz2.mean(t0, T) - pz.mean(t0, T) ** 2 - pzi.mean(t0, T) ** 2)
        st = "drifting" if not flat else "metastable" if not chi <= COHERENT_FLUCTUATION \
            else "steady"
        rows.append((T, st, bound, ps.mean(t0, T), chi))
        T += ADAPTIVE_CHUNK_T
    # the same checks with bkflow's functions, on a sample
    rng = np.random.default_rng(abs(hash(path)) % 2**32)
    agree = 0
    for k in rng.choice(len(rows), size=min(VERIFY_PER_RUN, len(rows)), replace=False):
        T = rows[k][0]
        n, m = np.searchsorted(t, T, "right"), np.searchsorted(tp, T, "right")
        t0 = transient_step(spec.transient, int(round(T / spec.dt))) * spec.dt
        own = state(stationarity(t[:n], s[:n], t0), coherence(tp[:m], Z[:m], t0, spec.N))
        agree += own == rows[k][1]
    return {"phi": spec.phi, "N": spec.N, "seed": spec.seed, "start": spec.start,
            "t_end": T_end, "quarter_mean": ps.mean(0.75 * T_end, T_end),
            "quarter_chi": coherence(tp, Z, 0.75 * T_end, spec.N).fluctuation,
            "checks": pd.DataFrame(rows, columns=["T", "state", "bound", "mean", "chi"]),
            "verified": (agree, min(VERIFY_PER_RUN, len(rows)))}


def evaluate(roots, jobs: int) -> list[dict]:
    with ProcessPoolExecutor(jobs) as pool:
        return list(pool.map(_checks, run_dirs(roots), chunksize=1))


def plateaus(runs: list[dict]) -> pd.DataFrame:
    """The long-run plateau of each (phi, N, seed), pooled over the starts, and the spread
    of the starts' last quarters (relative)."""
    rows = {}
    for r in runs:
        if r["t_end"] < PLATEAU_T_MIN or not r["quarter_chi"] <= PLATEAU_CHI_MAX:
            continue
        rows.setdefault((r["phi"], r["N"], r["seed"]), []).append(r["quarter_mean"])
    out = [{"phi": k[0], "N": k[1], "seed": k[2], "plateau": float(np.mean(v)),
            "spread": float((max(v) - min(v)) / np.mean(v)), "starts": len(v)}
           for k, v in rows.items()]
    return pd.DataFrame(out).set_index(["phi", "N", "seed"]).sort_index()


# --------------------------------------------------------------------------- the rules
def _single_stop(c: pd.DataFrame):
    ok = c[(c.state == "steady") & (c.bound <= STEADY_DRIFT_BOUND)]
    return None if ok.empty else ok.iloc[0]


def _pair_checks(main: pd.DataFrame, comp: pd.DataFrame) -> pd.DataFrame:
    both = main.merge(comp, on="T", suffixes=("", "_c"))
    both["gap"] = both["mean"] / both["mean_c"] - 1
    both["ok"] = ((both.state == "steady") & (both.state_c == "steady")
                  & (both.bound <= STEADY_DRIFT_BOUND) & (both.bound_c <= STEADY_DRIFT_BOUND)
                  & (both.gap.abs() <= STEADY_AGREEMENT))
    return both


def tables(runs: list[dict], plat: pd.DataFrame):
    """(single-run stops, pair stops, time to steady)"""
    by = {}
    for r in sorted(runs, key=lambda r: r["t_end"]):  # the longest run of each start counts
        by[(r["phi"], r["N"], r["seed"], r["start"])] = r
    single, pairs, ttl = [], [], []
    for (phi, n, seed, start), r in by.items():
        if (phi, n, seed) not in plat.index:
            continue
        p = plat.loc[(phi, n, seed), "plateau"]
        c = r["checks"]
        stop = _single_stop(c)
        single.append({"phi": phi, "N": n, "seed": seed, "start": start,
                       "T": math.inf if stop is None else stop["T"],
                       "error": math.nan if stop is None else stop["mean"] / p - 1})
        ok = c[(c.state == "steady") & (c.bound <= STEADY_DRIFT_BOUND)
               & ((c["mean"] / p - 1).abs() <= WITHIN)]
        ttl.append({"phi": phi, "N": n, "seed": seed, "start": start,
                    "t_steady": math.inf if ok.empty else ok["T"].iloc[0],
                    "t_end": r["t_end"]})
        if start == STEADY_START and (phi, n, seed, STEADY_COMPANION) in by:
            both = _pair_checks(c, by[(phi, n, seed, STEADY_COMPANION)]["checks"])
            hit = both[both.ok]
            pairs.append({"phi": phi, "N": n, "seed": seed, "t_end": both["T"].max(),
                          "T": math.inf if hit.empty else hit["T"].iloc[0],
                          "error": math.nan if hit.empty else hit["mean"].iloc[0] / p - 1,
                          "gap": math.nan if hit.empty else hit.gap.iloc[0]})
            near = both[both.ok & ((both["mean"] / p - 1).abs() <= WITHIN)]
            ttl.append({"phi": phi, "N": n, "seed": seed,
                        "start": f"{STEADY_START} + {STEADY_COMPANION}",
                        "t_steady": math.inf if near.empty else near["T"].iloc[0],
                        "t_end": both["T"].max()})
    return pd.DataFrame(single), pd.DataFrame(pairs), pd.DataFrame(ttl)


# --------------------------------------------------------------------------- report
def _md(df: pd.DataFrame, index: bool = True) -> str:
    if index:
        df = df.reset_index()
    cells = [[f"{v:.4g}" if isinstance(v, float) else str(v) for v in row]
             for row in df.itertuples(index=False)]
    lines = ["| " + " | ".join(map(str, df.columns)) + " |", "|" + "---|" * len(df.columns)]
    return "\n".join(lines + ["| " + " | ".join(c) + " |" for c in cells])


def _rate(df: pd.DataFrame) -> str:
    stopped = df.dropna(subset=["error"])
    false = int((stopped.error.abs() > FALSE_STEADY).sum())
    return (f"{len(stopped)} of {len(df)} stop within their runs, {false} of them off the "
            f"plateau by more than {100 * FALSE_STEADY:g}% "
            f"({100 * false / max(len(stopped), 1):.1f}%)")


def report(runs: list[dict]) -> None:
    plat = plateaus(runs)
    agree = sum(r["verified"][0] for r in runs)
    total = sum(r["verified"][1] for r in runs)
    print(f"## Ground truth: {len(runs)} runs, {len(plat)} plateaus (phi, N, seed)\n")
    print(f"Checks recomputed with bkflow's own functions: {agree} of {total} agree with the "
          "prefix-sum arithmetic.\n")
    loose = plat[plat.spread > FALSE_STEADY].reset_index()
    print(f"Plateaus known to worse than {100 * FALSE_STEADY:g}% (the spread of the starts' "
          f"last quarters), {len(loose)} of {len(plat)}:\n")
    print(_md(loose, index=False) if len(loose) else "(none)")
    single, pairs, ttl = tables(runs, plat)
    print(f"\n### Single runs stopped at their first steady check (drift bound <= "
          f"{100 * STEADY_DRIFT_BOUND:g}%): {_rate(single)}\n")
    s = single.dropna(subset=["error"]).assign(false=lambda d: d.error.abs() > FALSE_STEADY)
    print(_md(s.groupby(["start", "N"]).agg(runs=("false", "size"), false=("false", "sum"),
                                            median_T=("T", "median"),
                                            largest_error=("error",
                                                           lambda e: float(e.abs().max())))))
    print(f"\n### The steady protocol: {STEADY_START} with a {STEADY_COMPANION} companion, "
          f"agreeing within {100 * STEADY_AGREEMENT:g}%: {_rate(pairs)}\n")
    p = pairs.assign(false=lambda d: d.error.abs() > FALSE_STEADY,
                     stopped=lambda d: np.isfinite(d["T"]))
    print(_md(p.groupby(["N", "phi"]).agg(pairs=("stopped", "size"),
                                          stopped=("stopped", "sum"), false=("false", "sum"),
                                          median_T=("T", "median"),
                                          largest_error=("error",
                                                         lambda e: float(e.abs().max())))))
    bad = pairs[pairs.error.abs() > FALSE_STEADY]
    if len(bad):
        print("\nthe false ones:\n")
        print(_md(bad, index=False))
    print(f"\n### Time to steady and within {100 * WITHIN:g}% of the plateau (median over "
          "seeds; inf: not within the run; the last column is the shortest run of the row)\n")
    table = ttl.groupby(["N", "phi", "start"]).t_steady.median().unstack("start")
    table["shortest run"] = ttl.groupby(["N", "phi"]).t_end.min()
    print(_md(table))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("what", choices=("groundtruth", "report"))
    ap.add_argument("dirs", nargs="*", help="sweep directories of the ground truth")
    ap.add_argument("--out", default="runs/groundtruth")
    ap.add_argument("--sizes", default="100,400,900")
    ap.add_argument("--phi", default="0.1,1,10,30,100,300,1000")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--t-end", type=float, default=64000.0)
    ap.add_argument("--partial-t-end", type=float, default=32000.0)
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args(argv)
    if a.what == "groundtruth":
        groundtruth(a.out, a.sizes, a.phi, a.seeds, a.t_end, a.partial_t_end, a.jobs)
        return
    roots = a.dirs or sorted(glob.glob(os.path.join(a.out, "*")))
    report(evaluate(roots, a.jobs))


if __name__ == "__main__":
    main()
