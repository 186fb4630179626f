"""Long runs off the calibrated grid: the held-out truth that the steady protocol's verdict and
estimate are judged on (benchmarks/report/protocol_bias.py reads them).

The switching calibration (src/bkflow/model/switching.json) and the stop rule were made on
the model's defaults at N = 100 and 400 (benchmarks/measure/stiff_states.py). Here the same
long runs, four starts each, are made where nothing was calibrated: other model parameters
(gamma, k_e, V_d) at N = 100, and another aspect (a square 10x10 lattice). N = 900 at the
defaults is benchmarks/measure/stiff_states.py's own (``--n 900``).

    python -m benchmarks.measure.offgrid run [--t-end 2e5] [--cases all] [--shard I/K]
    python -m benchmarks.measure.offgrid list

Each case records blocks of 1000 time units into benchmarks/records/offgrid/ (Parquet, as
``longrun.LongRun``); the name carries what differs from the defaults
(``N100_gamma0.1_phi1000_random_s1_C1.parquet``). Resumable: run the same command again.
"""

from __future__ import annotations

from benchmarks.harness import RECORDS, add_shard, parser, print_progress, shard
from benchmarks.measure.longrun import LongRun
from benchmarks.measure.stiff_states import dt_factor
from bkflow.model.params import STARTS, RunSpec

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


def main(argv=None) -> None:
    ap = parser(__doc__)
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run", allow_abbrev=False)
    r.add_argument("--t-end", type=float, default=2e5)
    r.add_argument("--cases", default="all", help="variants, comma-separated, or all")
    add_shard(r)
    r.add_argument("--chunk", type=float, default=5e4)
    sub.add_parser("list", allow_abbrev=False)
    a = ap.parse_args(argv)
    variants = None if a.cmd == "list" or a.cases == "all" else a.cases.split(",")
    todo = list(cases(variants))
    if a.cmd == "list":
        for name, spec in todo:
            print(case_name(name, spec))
        return
    for name, spec in shard(todo, a.shard):
        LongRun(spec, OUT / f"{case_name(name, spec)}.parquet", 1000.0, a.chunk).advance_to(
            a.t_end, log=print_progress)


if __name__ == "__main__":
    main()
