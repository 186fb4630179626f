"""The stiff end over long runs: which long-lived states a layer visits, how long it stays in
each, and what its long-run mean is (docs/model.md, "Steady state" and the stiff end's states).

    python -m benchmarks.measure.stiff_states [--n 100] [--t-end 1e6]
        [--phi 30,100,215,464,1000] [--starts all] [--seeds 1,2,3] [--shard I/K]

One ``longrun.LongRun`` per (phi, start, seed) at the lattice of N particles: blocks of 1000
time units recorded in benchmarks/records/stiff_states/ (Parquet; --records another folder, as
benchmarks/records/truth/ for runs that only give a layer's long-run mean to
benchmarks/report/protocol_bias.py, not the calibration), resumable (run the same command
again to go on, or with a larger --t-end to extend every run). --shard I/K takes every K-th
case from the I-th: one process per core. Their tables, the figure and the switching
calibration bkflow installs: ``python -m benchmarks.report.stiff_states``.

The time step: dt = min(1 / omega_max, 0.1 / omega_c), omega_max^2 = 4 k_b + k_e + k_d + dk_d
(the bonds' fastest mode) and omega_c^2 = k_e + k_d + dk_d (the contacts' load cycle), i.e. the
stiff layers at C = dt omega_max = 1 (where the mean stress is the same as at C = 0.1 to 0.1%)
and the softer ones resolving the contacts as the default preset does at phi = 0.1.
"""

from __future__ import annotations

import math
from pathlib import Path

from benchmarks.harness import RECORDS, add_shard, floats, ints, parser, print_progress, shard
from benchmarks.measure.longrun import LongRun, case_name
from bkflow.model.params import STARTS, RunSpec, size_from_n

OUT = RECORDS / "stiff_states"
PHI = (30.0, 100.0, 215.0, 464.0, 1000.0)


def dt_factor(spec: RunSpec) -> float:
    """C = dt omega_max of dt = min(1 / omega_max, 0.1 / omega_c) (module doc)."""
    w_max = math.sqrt((4 * spec.k_b + spec.k_e + spec.k_d + spec.dk_d) / spec.mass)
    w_c = math.sqrt((spec.k_e + spec.k_d + spec.dk_d) / spec.mass)
    return round(min(1.0, 0.1 * w_max / w_c), 4)


def cases(n: int, phis, starts, seeds):
    Lx, Ly = size_from_n(n)
    for phi in phis:
        for seed in seeds:
            for start in starts:
                spec = RunSpec(phi=phi, Lx=Lx, Ly=Ly, seed=seed, start=start)
                yield spec.replace(dt_factor=dt_factor(spec))


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--t-end", type=float, default=1e6)
    ap.add_argument("--phi", type=floats, default=list(PHI))
    ap.add_argument("--starts", default="all")
    ap.add_argument("--seeds", type=ints, default=[1, 2, 3])
    add_shard(ap)
    ap.add_argument("--chunk", type=float, default=1e5)
    ap.add_argument("--records", default=None, help="the folder of the records (default "
                    "benchmarks/records/stiff_states, the calibration's; the long runs that "
                    "only give a layer's truth go to benchmarks/records/truth)")
    a = ap.parse_args(argv)
    starts = STARTS if a.starts == "all" else a.starts.split(",")
    out = OUT if a.records is None else Path(a.records)
    for spec in shard(cases(a.n, a.phi, starts, a.seeds), a.shard):
        LongRun(spec, out / f"{case_name(spec)}.parquet", 1000.0, a.chunk).advance_to(
            a.t_end, log=print_progress)


if __name__ == "__main__":
    main()
