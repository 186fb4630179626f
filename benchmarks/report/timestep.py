"""The work-precision of the time step from benchmarks/measure/timestep.py's records: the bias
of the steady observables against dt, per (N, phi, C), and what each accuracy preset's rule
gives.

    python -m benchmarks.report.timestep [--n 100,400]

Per run: <sigma_x>/sigma_n and mu_bar (the 1% slips) over the blocks after the first 20%.
Per (N, phi, C): the bias against the reference C of that phi (benchmarks/measure/timestep.py's
C_REF_SOFT or C_REF_STIFF), relative, the mean over seeds of the paired difference (the same
seed: the same disorder and start), with its standard error over seeds; and where the reference
itself sits
(omega_c dt, the contacts' resolution, beside C = omega_max dt).
"""

from __future__ import annotations

import glob
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd

from benchmarks.harness import ints, parser
from benchmarks.measure.timestep import OUT
from bkflow.model.params import RunSpec, size_from_n
from bkflow.model.timestep import ACCURACY, omega_contact, omega_max, time_step

NAME = re.compile(r"N(\d+)_phi([\d.]+)_random_s(\d+)_C([\d.]+)\.parquet$")
TRANSIENT = 0.2


def load(root) -> pd.DataFrame:
    rows = []
    for f in sorted(glob.glob(str(Path(root) / "*.parquet"))):
        m = NAME.search(f)
        if not m:
            continue
        n, phi, seed, c = m.groups()
        rec = pd.read_parquet(f)
        b = rec.iloc[int(TRANSIENT * len(rec)):]
        w = (b.t1 - b.t0).to_numpy()
        rows.append({"N": int(n), "phi": float(phi), "seed": int(seed), "C": float(c),
                     "T": float(rec.t1.iloc[-1]),
                     "stress": float(np.average(b.s, weights=w)),
                     "mu_bar": float(b["sfail_0.01"].sum() / b["nslip_0.01"].sum())})
    return pd.DataFrame(rows)


def spec_of(n: int, phi: float, c: float | None = None, preset: str = "default") -> RunSpec:
    lx, ly = size_from_n(n)
    return RunSpec(phi=phi, Lx=lx, Ly=ly, accuracy=preset, dt_factor=c)


def bias(runs: pd.DataFrame) -> pd.DataFrame:
    """Per (N, phi, C): the relative bias of both observables against the phi's smallest C,
    mean over seeds and its standard error; omega_c dt; the steps per time unit."""
    rows = []
    for (n, phi), g in runs.groupby(["N", "phi"]):
        ref_c = g.C.min()
        ref = g[g.C == ref_c].set_index("seed")
        for c, gc in g.groupby("C"):
            gc = gc.set_index("seed")
            seeds = gc.index.intersection(ref.index)
            if not len(seeds):
                continue
            spec = spec_of(n, phi, c)
            row = {"N": n, "phi": phi, "C": c, "reference": c == ref_c, "seeds": len(seeds),
                   "wc_dt": spec.dt * spec.omega_contact, "dt": spec.dt,
                   "steps_per_t": 1 / spec.dt}
            for obs in ("stress", "mu_bar"):
                d = (gc.loc[seeds, obs] / ref.loc[seeds, obs] - 1).to_numpy()
                row[f"{obs}_bias"] = float(d.mean())
                row[f"{obs}_se"] = float(d.std(ddof=1) / math.sqrt(len(d))) if len(d) > 1 \
                    else math.nan
            rows.append(row)
    return pd.DataFrame(rows)


def at_step(table: pd.DataFrame, n: int, phi: float, dt: float, obs: str) -> tuple:
    """The bias of ``obs`` at time step ``dt`` (N = n, phi): measured at that step where a run
    was (within 0.5%: benchmarks/measure/timestep.py runs each preset's own step), else
    interpolated linearly in dt between the measured steps of that phi, flagged; (bias, its
    standard error, measured)."""
    g = table[(table.N == n) & np.isclose(table.phi, phi)].sort_values("dt")
    hit = g[np.isclose(g.dt, dt, rtol=5e-3)]
    if len(hit):
        r = hit.iloc[0]
        return float(r[f"{obs}_bias"]), float(r[f"{obs}_se"]), True
    if dt <= g.dt.iloc[0]:
        return 0.0, 0.0, False
    if dt > g.dt.iloc[-1]:
        return math.nan, math.nan, False
    b = float(np.interp(dt, g.dt, g[f"{obs}_bias"]))
    se = float(np.interp(dt, g.dt, g[f"{obs}_se"]))   # NaN where a neighbour has none
    return b, se, False


def verdict(bias: float, se: float, target: float) -> str:
    """Whether a measured bias meets a target: "meets" (|bias| <= target), "within noise"
    (|bias| - 2 se <= target: not shown to exceed it, but the runs cannot tell), "unresolved"
    (beyond the target with no standard error: one seed), "fails"."""
    if abs(bias) <= target:
        return "meets"
    if not math.isfinite(se):
        return "unresolved"   # one seed: no error to tell noise from bias
    if abs(bias) - 2 * se <= target:
        return "within noise"
    return "fails"


def presets(table: pd.DataFrame) -> pd.DataFrame:
    """Per preset, N and phi measured, before (dt = OLD_C / omega_max) and after (the rule):
    dt as C and omega_c dt, the cost in steps per time unit, the bias of each observable at
    that step (its standard error; measured or interpolated) and the verdict against the
    preset's target (``verdict``, the worse of the two observables)."""
    rank = {"meets": 0, "within noise": 1, "unresolved": 1, "fails": 2}
    rows = []
    for name, p in ACCURACY.items():
        for (n, phi), _ in table.groupby(["N", "phi"]):
            for rule in ("before", "after"):
                spec = (spec_of(n, phi, c=OLD_C[name]) if rule == "before"
                        else spec_of(n, phi, preset=name))
                row = {"preset": name, "rule": rule, "target": p.dt_error, "N": n, "phi": phi,
                       "C": spec.dt * spec.omega_max, "wc_dt": spec.dt * spec.omega_contact,
                       "steps_per_t": 1 / spec.dt}
                worst, measured = "meets", True
                for obs in ("stress", "mu_bar"):
                    b, se, hit = at_step(table, n, phi, spec.dt, obs)
                    row[f"{obs}_bias"], row[f"{obs}_se"] = b, se
                    v = verdict(b, se, p.dt_error) if not math.isnan(b) else "fails"
                    worst = max(worst, v, key=rank.get)
                    measured &= hit
                row["measured"] = measured
                row["verdict"] = worst
                rows.append(row)
    return pd.DataFrame(rows)


#: the presets' C of the rule before (dt = C / omega_max at every phi)
OLD_C = {"fast": 0.2, "default": 0.1, "precise": 0.05}


def best_constants(table: pd.DataFrame, target: float, c_stable_max: float = 1.9) -> tuple:
    """The largest (c_contact, c_stable) of the rule dt = min(c_contact / omega_c, c_stable /
    omega_max) whose interpolated |bias| stays within ``target`` at every (N, phi) measured,
    for both observables: c_stable first (the largest C measured within target at the
    stiffest phi), then c_contact."""
    def fine(cc, cs):
        for (n, phi), _ in table.groupby(["N", "phi"]):
            lx, ly = size_from_n(n)
            s = RunSpec(phi=phi, Lx=lx, Ly=ly)
            dt = time_step(ACCURACY["default"]._replace(c_contact=cc, c_stable=cs),
                           omega_max(s.k_b, s.k_e, s.k_d, s.dk_d, s.mass),
                           omega_contact(s.k_e, s.k_d, s.dk_d, s.mass))
            for obs in ("stress", "mu_bar"):
                b, _, _ = at_step(table, n, phi, dt, obs)
                if not abs(b) <= target:
                    return False
        return True

    grid_s = np.round(np.arange(0.5, c_stable_max + 1e-9, 0.1), 2)
    grid_c = np.round(np.arange(0.02, 0.4 + 1e-9, 0.01), 3)
    best = (math.nan, math.nan)
    for cs in grid_s[::-1]:
        if fine(grid_c[0], cs):
            for cc in grid_c[::-1]:
                if fine(cc, cs):
                    return (float(cc), float(cs))
    return best


def report(root=OUT, sizes=(100, 400)) -> None:
    runs = load(root)
    runs = runs[runs.N.isin(sizes)]
    table = bias(runs)
    pd.set_option("display.width", 220)
    print(table.round(5).to_string(index=False))
    print(presets(table).round(5).to_string(index=False))
    for name, p in ACCURACY.items():
        print(name, p.dt_error, "largest constants within target:",
              best_constants(table, p.dt_error))


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--n", type=ints, default=[100, 400], help="the sizes N (default 100,400)")
    report(OUT, ap.parse_args(argv).n)


if __name__ == "__main__":
    main()
