"""The steady protocol's bias against the long-run truth, measured: the protocol's sweep of a
size, recorded (docs/steady.md; benchmarks/RESULTS.md, "The steady protocol against the long
runs").

    python -m benchmarks.measure.protocol_bias --n 100 [--phi 0.1,...] [--seeds 1,2,3]
        [--jobs 2] [--label NAME] [--set NAME=VALUE ...]

``bkflow sweep`` of the steady protocol (the default preset, scene friction: the friction
numbers are the same in every scene) into runs/protocol_bias/<label>/, its runs.csv recorded
as benchmarks/records/protocol_bias/<label>.csv with the bkflow version, the commit, the wall
time of the sweep and the machine's cores. Resumable: the same command again finishes what is
missing. The judgement against the long runs' truth: ``python -m
benchmarks.report.protocol_bias``.
"""

from __future__ import annotations

import math
import os
import subprocess
import time
from pathlib import Path

import pandas as pd

from benchmarks import harness
from benchmarks.harness import parser

RECORDS = harness.RECORDS / "protocol_bias"
WORK = Path(os.environ.get("BKFLOW_BENCH_WORK", "runs/protocol_bias"))
PAPER_PHI = "1e-1:1e3"
KEEP = ("phi", "N", "Lx", "Ly", "seed", "state", "estimate", "t_run", "mu_bar", "mu_bar_err",
        "mu_bar_run", "companion_mu_bar", "mean_stress_ratio", "mean_stress_ratio_err",
        "mean_stress_ratio_run", "companion_mean_stress_ratio", "t_needed", "wall_time_s",
        "k_e", "gamma", "V_d", "dt")


def _commit() -> str:
    """The commit of the bkflow that ran (the checkout its package was imported from), with
    "-dirty" where that checkout had changes not committed."""
    import bkflow

    where = Path(bkflow.__file__).parent
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=where,
                              capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "."],
                               cwd=where, capture_output=True, text=True).stdout.strip()
    except OSError:
        return ""
    return head + ("-dirty" if dirty else "")


def run(n: int | None, size: str | None, phi: str, seeds: str, jobs: int, label: str,
        sets: list) -> Path:
    """The protocol's sweep, recorded (see module doc)."""
    import bkflow
    from bkflow.cli.assignments import run_assignments
    from bkflow.model.params import size_from_n
    from bkflow.model.protocols import protocol_fields
    from bkflow.sweeps.grid import phi_values, sweep_specs
    from bkflow.sweeps.local import sweep

    lx, ly = size_from_n(n) if size is None else (int(v) for v in size.split("x"))
    phis = phi_values(phi, 3)
    fields = {**protocol_fields("steady"), "scene": "friction", **run_assignments(sets)}
    specs = sweep_specs(phis, [(lx, ly)], [int(s) for s in seeds.split(",")], **fields)
    out = WORK / label
    t0 = time.perf_counter()
    rep = sweep(specs, out, jobs=jobs, progress=False)
    wall = time.perf_counter() - t0
    runs = pd.read_csv(out / "runs.csv")
    keep = runs[[c for c in KEEP if c in runs.columns]].copy()
    keep["bkflow"] = bkflow.__version__
    keep["commit"] = _commit()
    keep["sweep_wall_s"] = wall if not rep.finished_before else math.nan
    keep["cores"] = jobs
    RECORDS.mkdir(parents=True, exist_ok=True)
    path = RECORDS / f"{label}.csv"
    keep.sort_values(["phi", "seed"]).to_csv(path, index=False)
    print(f"{path}: {len(keep)} runs, sweep {wall:.0f} s")
    return path


def main(argv=None) -> None:
    ap = parser(__doc__)
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--n", type=int)
    g.add_argument("--size")
    ap.add_argument("--phi", default=PAPER_PHI)
    ap.add_argument("--seeds", default="1,2,3")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--label")
    ap.add_argument("--set", action="append", default=[])
    a = ap.parse_args(argv)
    label = a.label or (f"N{a.n}" if a.n else a.size)
    run(a.n, a.size, a.phi, a.seeds, a.jobs, label, a.set)


if __name__ == "__main__":
    main()
