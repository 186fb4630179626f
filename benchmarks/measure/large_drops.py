"""Stress drops of a large layer at the fixed and at the size-scaled slip threshold.

    python -m benchmarks.measure.large_drops            # runs (resumes) the sweep, then the record
    python -m benchmarks.measure.large_drops --again    # the record again from the finished runs

At N = 100 the drops above 1% of mu_s sigma_n span about one decade, too little for any test
to decide a power law. This runs the steady protocol at N = 14400 (240x60; phi = 0.1, 10,
100, 1000, 2 seeds, at most t = 16000, scene friction: the turning points the drops are read
from are recorded down to the size-scaled threshold, 1% x 100/N) and reads every run's drops
at both thresholds with the analysis's own functions (bkflow.observables.reduced events, the
transient, bkflow.analysis.summary.drop_result: Clauset et al.'s test and the lognormal comparison).
The record, benchmarks/records/large_drops.json, fills REPRODUCTION.md's block `large-drops`
(benchmarks/documents/steady.py).
"""

from __future__ import annotations

import math
import subprocess
import sys

from benchmarks.harness import BKFLOW, RECORDS, ROOT, parser, write_json

OUT = ROOT / "runs" / "large_drops"
RECORD = RECORDS / "large_drops.json"
SWEEP = ["sweep", "--phi", "0.1,10,100,1000", "--sizes", "240x60", "--seeds", "2",
         "--t-end", "16000", "--scene", "friction"]


def _f(v):
    v = float(v)
    return v if math.isfinite(v) else None


def drops_at(rd, spec, fraction: float) -> dict:
    """The drops after the transient of one run at ``fraction`` of mu_s sigma_n, and the
    analysis's power-law test of them."""
    import numpy as np

    from bkflow.analysis.summary import drop_result, transient_time
    from bkflow.model.settings import AnalysisSettings

    settings = AnalysisSettings(slip_threshold=fraction).resolved(spec)
    red = rd.read_reduced(spec)
    events = red.events(fraction * spec.mu_s * spec.sigma_n)
    t0 = transient_time(spec, settings, math.nan)
    late = events.after(t0)
    d = np.asarray(late.drop, float)
    test = drop_result(settings, late).test
    return {"threshold": fraction, "drops": int(len(d)),
            "decades": _f(np.log10(d.max() / d.min())) if len(d) > 1 else None,
            "alpha": _f(test.fit.alpha), "p": _f(test.p), "verdict": test.verdict,
            "lognormal_R": _f(test.lognormal_R), "lognormal_p": _f(test.lognormal_p),
            "preferred": test.preferred}


def record() -> dict:
    from bkflow.model.params import SCALED_N
    from bkflow.store.provenance import record as provenance
    from bkflow.store.rundir import sweep_run_dir
    from bkflow.store.tables import read_tables

    runs, _ = read_tables(OUT)
    rows = []
    for _, r in runs.sort_values(["phi", "seed"]).iterrows():
        rd = sweep_run_dir(OUT, r.job)
        spec = rd.spec()
        fixed = float(spec.slip_threshold)
        rows.append({"phi": float(r.phi), "seed": int(r.seed), "N": int(r.N),
                     "t_run": float(r.t_run), "state": str(r.state),
                     "fixed": drops_at(rd, spec, fixed),
                     "scaled": drops_at(rd, spec, fixed * min(1.0, SCALED_N / spec.N))})
    return {"command": "bkflow " + " ".join(SWEEP), "runs": rows, "provenance": provenance()}


def main(argv=None) -> int:
    ap = parser(__doc__)
    ap.add_argument("--again", action="store_true", help="the record again, no sweep")
    a = ap.parse_args(argv)
    if not a.again:
        subprocess.run([BKFLOW, *SWEEP, "--out", str(OUT)], check=True)
    write_json(RECORD, record())
    print(f"wrote {RECORD}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
