"""The time step at the stiff end: does C = dt omega_max change the states a layer visits, the
time it spends in each, and each state's mean? And how far is the long runs' own step (the
ground truth's, C = 1 at phi >= 464) from dt -> 0?

    python -m benchmarks.measure.step_states [--phi 464,1000] [--c 0.5,1.5] [--seeds 1,2,3]
                                             [--t-end 1e6] [--shard I/K]

One ``longrun.LongRun`` per (phi, C, seed) at N = 100 from the random start, recorded in blocks
of 1000 time units into benchmarks/records/step_states/ (resumable). C = 1 is the first
--t-end of benchmarks/measure/stiff_states.py's own runs of the same seeds (the same layer and
start: the pairs differ in C alone). The report: ``python -m benchmarks.report.step_states``.
"""

from __future__ import annotations

from benchmarks.harness import RECORDS, add_shard, floats, ints, parser, print_progress, shard
from benchmarks.measure.longrun import LongRun, case_name
from bkflow.model.params import RunSpec, size_from_n

OUT = RECORDS / "step_states"
N = 100
PHI = (464.0, 1000.0)
C = (0.5, 1.5)


def run(phis, cs, seeds, t_end, shard_spec="0/1") -> None:
    lx, ly = size_from_n(N)
    todo = [RunSpec(phi=phi, Lx=lx, Ly=ly, seed=seed, start="random", dt_factor=c)
            for phi in phis for c in cs for seed in seeds]
    for spec in shard(todo, shard_spec):
        LongRun(spec, OUT / f"{case_name(spec)}.parquet", 1000.0, 1e5).advance_to(
            t_end, log=print_progress)


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--phi", type=floats, default=list(PHI))
    ap.add_argument("--c", type=floats, default=list(C))
    ap.add_argument("--seeds", type=ints, default=[1, 2, 3])
    ap.add_argument("--t-end", type=float, default=1e6)
    add_shard(ap)
    a = ap.parse_args(argv)
    run(a.phi, a.c, a.seeds, a.t_end, a.shard)


if __name__ == "__main__":
    main()
