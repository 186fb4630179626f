"""Steady state or transient: how long a stiff layer remembers the paper's synchronized
start, what a stationary result costs from each start, and whether the error bars are honest.

    python -m benchmarks.measure.stationarity relaxation [--out runs/paper/paper]
        [--sizes 20x5,40x10]
    python -m benchmarks.measure.stationarity cost [--steady DIR] [--sync DIR]
        [--phi 10,100,1000]
    python -m benchmarks.measure.stationarity calibration [--steady runs/paper/steady]
    python -m benchmarks.measure.stationarity all

relaxation
    Synchronized start, t_end = 16000 (the default C), seeds 1..3, 13 phi from 1e-1 to 1e3, at
    N = 100 and 400: the stress's block means over time (40 blocks), and two relaxation
    times of <sigma_x>: ``tau``, fitted to the block means from t = 400 on as
    s_inf + A exp(-t / tau) (scipy.optimize.curve_fit, weighted equally), and ``t_equil``,
    Chodera's equilibration detection (bkflow.observables.stationarity.equilibration_time), both
    on the block means the run kept (its scene's blocks.npy, about 20 time units each) where
    it kept no raw series. The same specs as reproduce.py's "paper" protocol: pointed at its
    directory, nothing is run again. Writes the record
    benchmarks/records/stationarity_relaxation.json, from which ``python -m
    benchmarks.report.stationarity`` draws benchmarks/stationarity_relaxation.png and
    benchmarks/documents/ renders its table.
cost
    Until stationary (bkflow run --until-stationary) from each start, N = 100, 3 seeds: the
    length each run needed and its LAMMPS wall time, mean over seeds (the random start capped
    at 32000, the synchronized at 64000: reproduce.py's "steady" and "sync_steady").
calibration
    The error of a correlated mean on AR(1) series with known answers (n = 100, 400, 1000;
    rho = 0 .. 0.9; 2000 series each): the mean estimate over the true error, for bkflow's
    estimator (bkflow.observables.stationarity.mean_error) and for the blocking it replaced; and on
    real runs, the scatter of mu_bar over seeds against the runs' own errors (the ratio is 1 for
    calibrated errors of independent seeds).
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from benchmarks.harness import RECORDS, parser
from bkflow.cli.assignments import parse_sizes
from bkflow.observables.stationarity import block_means, equilibration_time, mean_error
from bkflow.store.rundir import RunDir
from bkflow.store.tables import read_tables
from bkflow.sweeps.grid import phi_values, sweep_specs
from bkflow.sweeps.local import sweep
from bkflow.sweeps.project import open_project

#: the relaxation's record (benchmarks/RESULTS.md, "Time to steady"; its figure is
#: benchmarks/report/stationarity.py's)
RELAXATION_RECORD = RECORDS / "stationarity_relaxation.json"


# --------------------------------------------------------------------------- relaxation
def _tau(tc, means, t_fit=400.0):
    from scipy.optimize import curve_fit

    keep = tc >= t_fit
    x, y = tc[keep], means[keep]
    if len(x) < 5:
        return math.nan, math.nan
    s_inf, a0 = y[-5:].mean(), y[0] - y[-5:].mean()
    try:
        warnings.simplefilter("ignore")  # an undetermined covariance is judged by amp below
        (s, a, tau), cov = curve_fit(lambda t, s, a, tau: s + a * np.exp(-t / tau), x, y,
                                     p0=(s_inf, a0, 2000.0), maxfev=20000)
    except RuntimeError:
        return math.nan, math.nan
    amp = a / s
    # no relaxation to speak of (below 0.2% of the stress), or a fit that ran away
    if not (tau > 0) or tau > 1e6 or not 2e-3 < abs(amp) < 1:
        return math.nan, float(amp) if abs(amp) < 1 else math.nan
    return float(tau), float(amp)


def relaxation(out: str, sizes: str, seeds: int, jobs: int) -> pd.DataFrame:
    specs = sweep_specs(phi_values("1e-1:1e3"), parse_sizes(sizes), seeds, t_end=16000.0)
    sweep(specs, out, jobs=jobs, progress=False)
    project = open_project(out, create=False)
    rows, curves = [], {}
    for spec in specs:
        run = RunDir(project.open_job(spec.to_dict()).path)
        # the paper protocol's scene keeps block means (blocks.npy, about 20 time units each),
        # not the raw series: both curves and t_equil are taken from what the run kept
        t, s = run.read_stress() if run.keeps_raw_stress() else run.read_reduced(spec).series()[:2]
        tc, m = block_means(t, s / spec.sigma_n, 0.0, 40)
        tau, amp = _tau(tc, m)
        rows.append({"N": spec.N, "phi": spec.phi, "seed": spec.seed, "tau": tau,
                     "amplitude": amp, "t_equil": equilibration_time(t, s),
                     "late_mean": float(m[-10:].mean())})
        curves.setdefault((spec.N, spec.phi), []).append((tc, m))
    df = pd.DataFrame(rows)
    write_relaxation_record(df, curves)
    print(f"wrote {RELAXATION_RECORD}; its figure: python -m benchmarks.report.stationarity")
    return df


def write_relaxation_record(df: pd.DataFrame, curves: dict, path: Path = RELAXATION_RECORD):
    """What the figure draws: the rows (per run) and each (N, phi)'s block means per seed."""
    import json

    rec = {"rows": json.loads(df.to_json(orient="records")),
           "curves": [{"N": int(n), "phi": float(phi), "t": [float(v) for v in cs[0][0]],
                       "means": [[float(v) for v in m] for _, m in cs]}
                      for (n, phi), cs in sorted(curves.items())]}
    path.write_text(json.dumps(rec) + "\n")


# --------------------------------------------------------------------------- cost
def cost(steady: str, sync: str, phis: str, seeds: int, jobs: int) -> pd.DataFrame:
    """Until steady (single runs, no companion) at N = 100 from the random start (cap 32000)
    and the synchronized one (cap 64000): what benchmarks/RESULTS.md's "Time to steady" quotes
    (the long runs of benchmarks/measure/stiff_states.py measure the starts' memory from
    t = 0)."""
    for start, out, cap in (("random", steady, 32000.0), ("synchronized", sync, 64000.0)):
        sweep(sweep_specs(phi_values(phis), [(20, 5)], seeds, t_end=cap, start=start,
                          until_steady=True, companion=None), out, jobs=jobs, progress=False)
    frames = []
    for out in (steady, sync):
        runs, _ = read_tables(out)
        frames.append(runs[(runs.Lx == 20) & (runs.Ly == 5) & runs.until_steady.astype(bool)
                           & runs.phi.isin(phi_values(phis))])
    runs = pd.concat(frames)
    return (runs.groupby(["phi", "start"])
            .agg(seeds=("seed", "count"), t_run=("t_run", "mean"), t_run_max=("t_run", "max"),
                 wall_s=("wall_time_s", "mean"), steady=("state", lambda x: (x == "steady").mean()),
                 mu_bar=("mu_bar", "mean"), mu_bar_large=("mu_bar_large", "mean"),
                 mean_stress_ratio=("mean_stress_ratio", "mean"))
            .reset_index())


# --------------------------------------------------------------------------- calibration
def _blocking(x, min_blocks=4):
    """bkflow's former estimator (Flyvbjerg-Petersen blocking, level by Jonsson's M-test),
    kept here only to show what it gave."""
    from scipy.stats import chi2

    var, gam, nk, b = [], [], [], np.asarray(x, float)
    while True:
        m = len(b)
        mu = b.mean()
        var.append(b.var())
        gam.append(float(np.sum((b[:-1] - mu) * (b[1:] - mu)) / m))
        nk.append(m)
        if m // 2 < max(2, min_blocks):
            break
        b = 0.5 * (b[0:m - m % 2:2] + b[1:m - m % 2:2])
    var, gam, nk = map(np.array, (var, gam, nk))
    with np.errstate(divide="ignore", invalid="ignore"):
        terms = np.where(var > 0, nk * (gam / var) ** 2, 0.0)
    stat = np.cumsum(terms[::-1])[::-1]
    level = next((j for j in range(len(nk)) if stat[j] < chi2.ppf(0.99, len(nk) - j)),
                 len(nk) - 1)
    return math.sqrt(var[level] / (nk[level] - 1))


def calibration(steady: str | None) -> tuple[pd.DataFrame, pd.DataFrame | None]:
    rng = np.random.default_rng(2024)
    rows = []
    for n in (100, 400, 1000):
        for rho in (0.0, 0.2, 0.5, 0.8, 0.9):
            e = rng.standard_normal((2000, n))
            x = np.empty_like(e)
            x[:, 0] = e[:, 0] / math.sqrt(1 - rho ** 2)
            for i in range(1, n):
                x[:, i] = rho * x[:, i - 1] + e[:, i]
            k = np.arange(1, n)
            truth = math.sqrt((n + 2 * np.sum((n - k) * rho ** k)) / (1 - rho ** 2)) / n
            rows.append({"n": n, "rho": rho,
                         "mean_error / truth": np.mean([mean_error(s).error for s in x]) / truth,
                         "blocking / truth": np.mean([_blocking(s) for s in x]) / truth})
    ar = pd.DataFrame(rows)
    real = None
    if steady and Path(steady, "runs.csv").exists():
        runs, _ = read_tables(steady)
        g = runs.groupby(["Lx", "Ly", "phi"])
        real = pd.DataFrame({
            "seeds": g.mu_bar.count(),
            "sd over seeds": g.mu_bar.std(ddof=1),
            "mean within-run error": g.mu_bar_err.mean()}).reset_index()
        real["ratio"] = real["sd over seeds"] / real["mean within-run error"]
    return ar, real


def _md(df: pd.DataFrame, index: bool = True) -> str:
    """A DataFrame as a markdown table (pandas' to_markdown needs tabulate)."""
    if index:
        df = df.reset_index()
    cells = [[f"{v:.4g}" if isinstance(v, float) else str(v) for v in row]
             for row in df.itertuples(index=False)]
    lines = ["| " + " | ".join(map(str, df.columns)) + " |", "|" + "---|" * len(df.columns)]
    return "\n".join(lines + ["| " + " | ".join(c) + " |" for c in cells])


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("what", choices=("relaxation", "cost", "calibration", "all"))
    ap.add_argument("--out", default=None, help="sweep directory (default per study)")
    ap.add_argument("--sizes", default="20x5,40x10")
    ap.add_argument("--phi", default="10,100,1000")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--steady", default="runs/paper/steady",
                    help="the random-start sweep until stationary (reproduce.py's 'steady')")
    ap.add_argument("--sync", default="runs/paper/sync_steady",
                    help="the synchronized-start sweep until stationary ('sync_steady')")
    a = ap.parse_args(argv)
    pd.set_option("display.width", 160)
    if a.what in ("relaxation", "all"):
        df = relaxation(a.out or "runs/paper/paper", a.sizes, a.seeds, a.jobs)
        print("## Relaxation from the synchronized start (median over seeds)\n")
        print(_md(df.groupby(["N", "phi"])[["tau", "amplitude", "t_equil", "late_mean"]]
                  .median()))
    if a.what in ("cost", "all"):
        print("\n## Cost to a stationary result (until stationary, N = 100)\n")
        print(_md(cost(a.steady, a.sync, a.phi, a.seeds, a.jobs), index=False))
    if a.what in ("calibration", "all"):
        ar, real = calibration(a.steady)
        print("\n## Calibration of the error of a mean (AR(1), 2000 series each)\n")
        print(_md(ar, index=False))
        if real is not None:
            print("\n## Real runs: scatter of mu_bar over seeds / within-run error\n")
            print(_md(real, index=False))


if __name__ == "__main__":
    main()
