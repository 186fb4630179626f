"""The steady state: long runs from every start as ground truth, the verdict calibrated on them,
and the start that forgets fastest (docs/model.md "Starting state", "Steady state").

    python benchmarks/steady.py groundtruth [--out runs/groundtruth] [--sizes 100,400,900]
                                            [--phi 0.1,1,10,30,100,300,1000] [--seeds 3]
    python benchmarks/steady.py verdict DIR [DIR ...]       # the sweep directories of the runs
    python benchmarks/steady.py starts DIR [DIR ...]

groundtruth
    One sweep per start (``--protocol paper --start S``: a fixed length, no stop rule) into
    OUT/S: the synchronized, stratified and random starts run for --t-end (64000 time units),
    the partial start for --partial-t-end (32000), scene friction (the stress and phase series
    are all the verdict reads). About 5 CPU-hours at N = 100, 400 and 900.
verdict
    The long-run plateau of each (phi, N, seed): the mean of sigma_x/sigma_n over the last
    quarter of every run of at least PLATEAU_T_MIN time units from any start, pooled over the
    starts (a run whose last quarter still holds the synchronized start's coherence, phase
    fluctuation above 5, is left out: it has not reached its plateau); the spread of the starts'
    last quarters says how well the plateau itself is known. Then every run is cut as an
    adaptive run would see it: windows [transient, T] at T = 1000 .. 32000 (A), and the checks
    of the steady protocol, the first at STEADY_T_MIN and then every ADAPTIVE_CHUNK_T, the run
    stopping at the first that finds it steady with a drift bound <= STEADY_DRIFT_BOUND (B).
    Each window's state comes from bkflow's own functions (bkflow.stationarity.stationarity,
    bkflow.phases.coherence and state), so what is measured is what bkflow does. A window
    called steady is false when its mean stress is off the plateau by more than 0.5%.
starts
    Per start, phi and N: the time until a run is steady and within 0.2% of its plateau (the
    first check of (B) where both hold), median over seeds.
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

from bkflow.grid import parse_sizes, phi_values, sweep_specs
from bkflow.params import (
    ADAPTIVE_CHUNK_T,
    STARTS,
    STEADY_DRIFT_BOUND,
    STEADY_T_MIN,
    transient_step,
)
from bkflow.phases import coherence, state
from bkflow.rundir import RunDir
from bkflow.stationarity import stationarity
from bkflow.sweep import sweep

#: a run's last quarter counts towards the plateau only if the run is at least this long
PLATEAU_T_MIN = 32000.0
#: a last quarter whose contacts still move together this much has not reached the plateau
PLATEAU_CHI_MAX = 5.0
#: windows of (A)
LADDER = (1000.0, 2000.0, 4000.0, 8000.0, 16000.0, 32000.0)
#: a window called steady is false when its mean is off the plateau by more than this
FALSE_STEADY = 0.005
#: the time to steady counts once a run is within this of its plateau
WITHIN = 0.002


# --------------------------------------------------------------------------- ground truth
def groundtruth(out: str, sizes: str, phis: str, seeds: int, t_end: float,
                partial_t_end: float, jobs: int) -> None:
    for start in STARTS:
        length = partial_t_end if start == "partial" else t_end
        specs = sweep_specs(phi_values(phis), parse_sizes(sizes), seeds, t_end=length,
                            start=start, scene="friction")
        print(f"{start}: {len(specs)} runs of {length:g} time units", flush=True)
        sweep(specs, Path(out) / start, jobs=jobs, progress=False)


# --------------------------------------------------------------------------- reading runs
def run_dirs(roots) -> list[str]:
    """Every finished run under the given sweep directories (their workspaces)."""
    found = []
    for root in roots:
        found += sorted(str(Path(p).parent) for p in
                        glob.glob(os.path.join(root, "workspace", "*", "meta.json")))
    return found


def _series(path: str):
    rd = RunDir(path)
    spec = rd.spec()
    t, sigma = rd.read_stress()
    ph = rd.read_phase()
    return spec, t, sigma / spec.sigma_n, ph["t"], ph["Z_re"] + 1j * ph["Z_im"]


def _window_state(spec, t, s, tp, Z, T):
    """What bkflow says of the run cut at time T: (state, drift bound, mean, chi)."""
    n = int(np.searchsorted(t, T, side="right"))
    m = int(np.searchsorted(tp, T, side="right"))
    t0 = transient_step(spec.transient, int(round(T / spec.dt))) * spec.dt
    trend = stationarity(t[:n], s[:n], t0)
    contacts = coherence(tp[:m], Z[:m], t0, spec.N)
    late = t[:n] >= t0
    return (state(trend, contacts), trend.drift_bound, float(s[:n][late].mean()),
            contacts.fluctuation)


def _quarter(path: str) -> dict:
    """A run's last quarter: its mean stress and phase fluctuation."""
    spec, t, s, tp, Z = _series(path)
    T_end = float(t[-1])
    return {"path": path, "phi": spec.phi, "N": spec.N, "seed": spec.seed,
            "start": spec.start, "t_end": T_end,
            "quarter_mean": float(s[t >= 0.75 * T_end].mean()),
            "quarter_chi": coherence(tp, Z, 0.75 * T_end, spec.N).fluctuation}


def plateaus(quarters: list[dict]) -> pd.DataFrame:
    """The long-run plateau of each (phi, N, seed), pooled over the starts, and the spread
    of the starts' last quarters (relative)."""
    rows = {}
    for r in quarters:
        if r["t_end"] < PLATEAU_T_MIN or not r["quarter_chi"] <= PLATEAU_CHI_MAX:
            continue
        rows.setdefault((r["phi"], r["N"], r["seed"]), []).append(r["quarter_mean"])
    out = [{"phi": k[0], "N": k[1], "seed": k[2], "plateau": float(np.mean(v)),
            "spread": float((max(v) - min(v)) / np.mean(v)), "starts": len(v)}
           for k, v in rows.items()]
    return pd.DataFrame(out).set_index(["phi", "N", "seed"]).sort_index()


def _checks(job: tuple[dict, float]) -> dict:
    """One run cut as the steady protocol would see it: its ladder windows (A), its first
    check found steady (B), and its first check found steady within WITHIN of the plateau
    (the time to steady); checks stop once both are found."""
    r, p = job
    spec, t, s, tp, Z = _series(r["path"])
    T_end = float(t[-1])
    ladder = [(T, *_window_state(spec, t, s, tp, Z, T)) for T in LADDER if T <= T_end]
    stop = hit = None
    T = STEADY_T_MIN
    while T <= T_end and (stop is None or hit is None):
        st, bound, mean, chi = _window_state(spec, t, s, tp, Z, T)
        if st == "steady" and bound <= STEADY_DRIFT_BOUND:
            stop = stop or (T, mean, chi)
            if abs(mean / p - 1) <= WITHIN:
                hit = T
        T += ADAPTIVE_CHUNK_T
    return {**r, "ladder": ladder, "stop": stop, "t_steady": math.inf if hit is None else hit}


def evaluate(roots, jobs: int) -> tuple[list[dict], pd.DataFrame]:
    paths = run_dirs(roots)
    with ProcessPoolExecutor(jobs) as pool:
        quarters = list(pool.map(_quarter, paths, chunksize=1))
        plat = plateaus(quarters)
        todo = [(q, plat.loc[(q["phi"], q["N"], q["seed"]), "plateau"]) for q in quarters
                if (q["phi"], q["N"], q["seed"]) in plat.index]
        return list(pool.map(_checks, todo, chunksize=1)), plat


def verdict_tables(runs: list[dict], plat: pd.DataFrame):
    """(A) every ladder window, (B) the steady protocol's stop of each run, with their
    errors against the plateau."""
    A, B = [], []
    for r in runs:
        p = plat.loc[(r["phi"], r["N"], r["seed"]), "plateau"]
        base = {"phi": r["phi"], "N": r["N"], "seed": r["seed"], "start": r["start"]}
        for T, st, _bound, mean, chi in r["ladder"]:
            A.append({**base, "T": T, "state": st, "error": mean / p - 1, "chi": chi})
        stop = r["stop"]
        B.append({**base, "T": math.nan if stop is None else stop[0],
                  "error": math.nan if stop is None else stop[1] / p - 1,
                  "chi": math.nan if stop is None else stop[2]})
    return pd.DataFrame(A), pd.DataFrame(B)


def time_to_steady(runs: list[dict]) -> pd.DataFrame:
    return pd.DataFrame([{"phi": r["phi"], "N": r["N"], "seed": r["seed"],
                          "start": r["start"], "t_steady": r["t_steady"],
                          "t_end": r["t_end"]} for r in runs])


def _md(df: pd.DataFrame, index: bool = True) -> str:
    if index:
        df = df.reset_index()
    cells = [[f"{v:.4g}" if isinstance(v, float) else str(v) for v in row]
             for row in df.itertuples(index=False)]
    lines = ["| " + " | ".join(map(str, df.columns)) + " |", "|" + "---|" * len(df.columns)]
    return "\n".join(lines + ["| " + " | ".join(c) + " |" for c in cells])


def _false(df: pd.DataFrame) -> tuple[int, int]:
    steady = df.dropna(subset=["error"])
    return int((steady.error.abs() > FALSE_STEADY).sum()), len(steady)


def report_verdict(runs, plat) -> None:
    A, B = verdict_tables(runs, plat)
    print(f"## Ground truth: {len(runs)} runs, {len(plat)} plateaus (phi, N, seed)\n")
    print("Plateaus known to worse than 0.5% (the spread of the starts' last quarters):\n")
    loose = plat[plat.spread > FALSE_STEADY]
    print(_md(loose) if len(loose) else "(none)")
    stA = A[A.state == "steady"]
    f, n = _false(stA)
    print(f"\n(A) windows [0.2 T, T] at T = {', '.join(f'{x:g}' for x in LADDER)}: "
          f"{len(stA)} of {len(A)} called steady, {f} of them off the plateau by more than "
          f"{100 * FALSE_STEADY:g}% ({100 * f / max(n, 1):.1f}%)\n")
    print(_md(A.groupby(["start", "state"]).size().unstack(fill_value=0)))
    f, n = _false(B)
    print(f"\n(B) the steady protocol's stop (the first check from t = {STEADY_T_MIN:g} "
          f"found steady with a drift bound <= {100 * STEADY_DRIFT_BOUND:g}%): {n} of "
          f"{len(B)} runs stop, {f} of them off by more than {100 * FALSE_STEADY:g}% "
          f"({100 * f / max(n, 1):.1f}%)\n")
    B = B.dropna(subset=["error"])
    by = B.assign(false=B.error.abs() > FALSE_STEADY).groupby(["start", "N"]).agg(
        runs=("false", "size"), false=("false", "sum"),
        median_T=("T", "median"), max_error=("error", lambda e: float(e.abs().max())))
    print(_md(by))
    bad = B[B.error.abs() > FALSE_STEADY]
    if len(bad):
        print("\nthe false ones:\n")
        print(_md(bad, index=False))


def report_starts(runs) -> None:
    df = time_to_steady(runs)
    table = (df.groupby(["N", "phi", "start"]).t_steady.median().unstack("start"))
    print("## Time to steady and within 0.2% of the plateau (median over seeds; inf: not "
          "within the run)\n")
    print(_md(table))
    worst = df.groupby(["start", "N"]).t_steady.agg(lambda x: float(np.max(x)))
    print("\nthe longest over phi and seeds:\n")
    print(_md(worst.unstack("N")))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=("groundtruth", "verdict", "starts"))
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
    runs, plat = evaluate(roots, a.jobs)
    if a.what == "verdict":
        report_verdict(runs, plat)
    else:
        report_starts(runs)


if __name__ == "__main__":
    main()
