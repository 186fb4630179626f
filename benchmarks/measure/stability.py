"""Numerical stability: the dt-factor at which runs blow up, per phi, and one long run.

1. dt scan: for phi from 1e-1 to 1e4, runs of t_end time units (default 2000, scene
   friction, N = 100, seed 1) at increasing C until the engine stops the run (NaN, lost
   atoms, a bond past 10 l). The guard of bkflow.model.timestep (DT_FACTOR_MAX) is lifted for the
   scan only. Beside each stable run: its <sigma_x>/sigma_n relative to C = 0.1, so that
   "stable" and "accurate" are not confused.
2. Long run (``--long``): phi = 1e3, N = 100, C = 0.1, t_end = 16000 (1.01e7 steps), scene
   order: stays finite, the longest bond over the run (thermo), the drift of the centre of
   mass in y, and mu_bar of the first and second half.

    python -m benchmarks.measure.stability [--phi ...] [--c ...] [--t-end 2000] [--long]
"""

from __future__ import annotations

import tempfile
import time

import numpy as np

from benchmarks.harness import parser
from bkflow.lammps.engine import RunError, run
from bkflow.model import timestep
from bkflow.model.params import RunSpec
from bkflow.observables.stress import macroscopic_friction
from bkflow.store.layout import LOG
from bkflow.store.rundir import RunDir

PHIS = (0.1, 1.0, 10.0, 100.0, 1000.0, 10000.0)
CS = (0.1, 0.5, 1.0, 1.25, 1.5, 1.75, 1.9, 2.0, 2.1, 2.5)


def mean_stress(spec: RunSpec, out) -> float:
    """<sigma_x>/sigma_n after the run's transient."""
    t, s = RunDir(out).read_stress()
    late = t >= spec.transient * t[-1]
    return float(s[late].mean() / spec.sigma_n)


def scan(phis, cs, t_end, seed=1):
    timestep.DT_FACTOR_MAX = max(cs) + 1  # the scan looks past the guard on purpose
    rows = []
    for phi in phis:
        base = None
        for c in cs:
            spec = RunSpec(phi=phi, dt_factor=c, t_end=t_end, seed=seed, scene="friction")
            with tempfile.TemporaryDirectory() as d:
                t0 = time.perf_counter()
                try:
                    res = run(spec, d, progress=False)
                    ratio = mean_stress(spec, d)
                    base = ratio if c == cs[0] else base
                    rows.append((phi, c, "stable", time.perf_counter() - t0,
                                 ratio / base - 1 if base else float("nan"),
                                 res.meta["contact_breaks"], ""))
                except RunError as exc:
                    cause = str(exc).split(": ", 1)[-1].split(";")[0]
                    rows.append((phi, c, "blew up", time.perf_counter() - t0, float("nan"), 0,
                                 cause))
                    break  # larger C only gets worse
    return rows


def long_run(t_end=16000.0):
    spec = RunSpec(phi=1000.0, dt_factor=0.1, t_end=t_end, seed=1, scene="order")
    with tempfile.TemporaryDirectory() as d:
        res = run(spec, d, progress=False)
        rd = RunDir(d)
        log = rd.file(LOG).read_text().splitlines()
        longest = []
        for line in log:  # thermo rows: step time f_bk[1] f_bk[2] f_bk[3] f_bk[5] cpuremain
            parts = line.split()
            try:
                if len(parts) == 7 and parts[0].isdigit():
                    longest.append(float(parts[5]))  # f_bk[5], the longest bond
            except ValueError:
                continue
        f = rd.read_snapshots(spec.N)
        y_com = f.positions[:, :, 1].mean(axis=1)
        x_com = f.positions[:, :, 0].mean(axis=1)
        t, s = rd.read_stress()
        half = t[-1] / 2
        first = macroscopic_friction(t[t < half], s[t < half], spec.sigma_n,
                                     spec.slip_threshold_stress)
        second = macroscopic_friction(t[t >= half] - half, s[t >= half], spec.sigma_n,
                                      spec.slip_threshold_stress)
        return {
            "steps": spec.n_steps, "wall_s": res.meta["wall_time_s"],
            "finite": bool(np.isfinite(f.positions).all() and np.isfinite(s).all()),
            "longest_bond_max": max(longest), "longest_bond_last": longest[-1],
            "y_com_range": float(y_com.max() - y_com.min()),
            "y_com_drift": float(y_com[-1] - y_com[0]),
            "x_com_advance": float(x_com[-1] - x_com[0]), "plate_advance": spec.V_d * t[-1],
            "mu_bar_halves": (first.mu_bar, second.mu_bar),
            "mu_bar_err_halves": (first.mu_bar_err, second.mu_bar_err),
        }


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--phi", type=float, nargs="+", default=list(PHIS))
    ap.add_argument("--c", type=float, nargs="+", default=list(CS))
    ap.add_argument("--t-end", type=float, default=2000.0)
    ap.add_argument("--long", action="store_true", help="also the 1e7-step run at phi = 1e3")
    ap.add_argument("--no-scan", action="store_true", help="only the long run")
    a = ap.parse_args(argv)
    rows = [] if a.no_scan else scan(a.phi, sorted(a.c), a.t_end)
    print("| phi | C | outcome | wall | <sigma_x>/sigma_n vs C = 0.1 | contact breaks | cause |")
    print("|---|---|---|---|---|---|---|")
    for phi, c, outcome, wall, dev, breaks, cause in rows:
        print(f"| {phi:g} | {c:g} | {outcome} | {wall:.1f} s | "
              f"{'' if dev != dev else f'{100 * dev:+.2f}%'} | {breaks} | {cause} |")
    print()
    bound = {}
    for phi, c, outcome, *_ in rows:
        if outcome == "stable":
            bound[phi] = max(bound.get(phi, 0), c)
    print("largest stable C per phi: " + ", ".join(f"phi={p:g}: {c:g}" for p, c in bound.items()))
    if a.long:
        r = long_run()
        print("\nlong run, phi = 1e3, N = 100, C = 0.1:")
        for k, v in r.items():
            print(f"  {k}: {v}")


if __name__ == "__main__":
    main()
