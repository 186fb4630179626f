"""The stiff end over long runs: which long-lived states a layer visits, how long it stays in
each, and what its long-run mean is (docs/model.md, "Steady state" and the stiff end's states).

    python benchmarks/stiff_states.py run [--n 100] [--t-end 1e6] [--phi 30,100,215,464,1000]
                                          [--starts all] [--seeds 1,2,3] [--shard I/K]
    python benchmarks/stiff_states.py report      # tables and the figure from the records
    python benchmarks/stiff_states.py figure      # only the figure (benchmarks/states_figure.py)

run
    One ``longrun.LongRun`` per (phi, start, seed) at the lattice of N particles: blocks of
    1000 time units recorded in benchmarks/records/stiff_states/ (Parquet; --records another
    folder, as benchmarks/records/truth/ for runs that only give a layer's long-run mean to
    benchmarks/protocol_bias.py, not the calibration), resumable (run
    the same command again to go on, or with a larger --t-end to extend every run). --shard
    I/K takes every K-th case from the I-th: one process per core.
report
    See ``bkflow.observables.states`` for the classification; prints the tables of
    benchmarks/RESULTS.md.

The time step: dt = min(1 / omega_max, 0.1 / omega_c), omega_max^2 = 4 k_b + k_e + k_d + dk_d
(the bonds' fastest mode) and omega_c^2 = k_e + k_d + dk_d (the contacts' load cycle), i.e. the
stiff layers at C = dt omega_max = 1 (where the mean stress is the same as at C = 0.1 to 0.1%)
and the softer ones resolving the contacts as the default preset does at phi = 0.1.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from longrun import RECORDS, LongRun, case_name  # noqa: E402

from bkflow.model.params import STARTS, RunSpec, size_from_n  # noqa: E402

OUT = RECORDS / "stiff_states"
#: the long-run curve: per (N, phi) the seeds' mean of each layer's long-run mean, written by
#: ``report`` from the records (workflows/paper/reproduce.py draws it in fig2a_protocols)
CURVE = RECORDS / "long_run_curve.csv"
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


def curve_table(means: dict):
    """The long-run curve from ``states_report.layer_means``: per (N, phi) the number of seeds,
    the mean over the seeds of each layer's long-run <sigma_x>/sigma_n and mu_bar, and their
    standard errors over the seeds (NaN with one seed)."""
    import pandas as pd

    df = pd.DataFrame([{"N": k[0], "phi": k[1], "seed": k[2], **v} for k, v in means.items()])
    rows = []
    for (n, phi), h in df.groupby(["N", "phi"]):
        k = len(h)
        row = {"N": int(n), "phi": float(phi), "seeds": k}
        for obs in ("stress", "mu_bar"):
            row[obs] = float(h[obs].mean())
            row[obs + "_se"] = float(h[obs].std(ddof=1) / math.sqrt(k)) if k > 1 else math.nan
        rows.append(row)
    return pd.DataFrame(rows)


def _floats(text):
    return [float(v) for v in text.split(",")]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("--n", type=int, default=100)
    r.add_argument("--t-end", type=float, default=1e6)
    r.add_argument("--phi", type=_floats, default=list(PHI))
    r.add_argument("--starts", default="all")
    r.add_argument("--seeds", default="1,2,3")
    r.add_argument("--shard", default="0/1")
    r.add_argument("--chunk", type=float, default=1e5)
    r.add_argument("--records", default=None, help="the folder of the records (default "
                   "benchmarks/records/stiff_states, the calibration's; the long runs that "
                   "only give a layer's truth go to benchmarks/records/truth)")
    sub.add_parser("report")
    sub.add_parser("figure", help="only the figure benchmarks/stiff_states.png")
    a = ap.parse_args(argv)
    if a.cmd == "run":
        starts = STARTS if a.starts == "all" else a.starts.split(",")
        seeds = [int(s) for s in a.seeds.split(",")]
        i, k = (int(v) for v in a.shard.split("/"))
        todo = list(cases(a.n, a.phi, starts, seeds))[i::k]
        out = OUT if a.records is None else Path(a.records)
        for spec in todo:
            LongRun(spec, out / f"{case_name(spec)}.parquet", 1000.0, a.chunk).advance_to(
                a.t_end, log=lambda m: print(m, flush=True))
    elif a.cmd == "figure":
        from states_figure import figure

        print(f"wrote {figure(OUT)}")
    else:
        from states_report import layer_means, load, report

        report(OUT)
        curve_table(layer_means(load(OUT))).to_csv(CURVE, index=False, float_format="%.10g")
        print(f"wrote {CURVE}")


if __name__ == "__main__":
    main()
