"""Adaptive run length (--target-error) against the fixed-length preset of the same accuracy.

For each phi: fixed runs of the ``default`` preset (the paper's protocol: its time step and
t_end, from the synchronized start, no companion), one per seed, give mu_bar
with a mean standard error E, the preset's accuracy at that phi; adaptive runs of the same
seeds with ``--target-error E`` (cap: 4 x that t_end) stop as soon as their own error is
below E. Reported per phi (mean over seeds): the fixed run's length
and wall time, the adaptive run's, and the time saved. Runs alternate fixed / adaptive in one
process (the machine is shared: the ratio is the result).

    python -m benchmarks.measure.adaptive [--phi 0.1 10 1000] [--seeds 3] [--preset default]
"""

from __future__ import annotations

import tempfile

import numpy as np

from benchmarks.harness import parser
from bkflow.analysis.summary import analyze
from bkflow.lammps.engine import run
from bkflow.model.params import RunSpec
from bkflow.model.protocols import protocol_fields
from bkflow.model.timestep import ACCURACY


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--phi", type=float, nargs="+", default=[0.1, 10.0, 1000.0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--preset", default="default", choices=sorted(ACCURACY))
    a = ap.parse_args(argv)
    t_end = ACCURACY[a.preset].t_end
    print(f"preset {a.preset}: its time step, t_end = {t_end:g}; adaptive cap {4 * t_end:g}; "
          f"scene friction, N = 100, seeds 1..{a.seeds}\n")
    print("| phi | target E (fixed runs' mean error) | fixed: t_end, wall | adaptive: t_run "
          "(range), wall, error | wall saved | target reached |")
    print("|---|---|---|---|---|---|")
    for phi in a.phi:
        fixed_runs = []
        for seed in range(1, a.seeds + 1):
            fixed = RunSpec(phi=phi, seed=seed, scene="friction",
                            **protocol_fields("paper", a.preset))
            with tempfile.TemporaryDirectory() as d:
                wall = run(fixed, d, progress=False).meta["wall_time_s"]
                fixed_runs.append((fixed, wall, analyze(d)["mu_bar_err"]))
        # the preset's accuracy at this phi: its mean error over seeds
        target = float(np.mean([e for _, _, e in fixed_runs]))
        rows = []
        for fixed, wall_f, _ in fixed_runs:
            adapt = fixed.replace(t_end=4 * t_end, target_error=target)
            with tempfile.TemporaryDirectory() as d:
                meta = run(adapt, d, progress=False).meta
            ad = meta["adaptive"]
            rows.append((wall_f, ad["t_run"], meta["wall_time_s"], ad["mu_bar_err_at_stop"],
                         ad["reached"]))
        wf, tr, wa, ea, ok = (np.array(x, dtype=float) for x in zip(*rows))
        print(f"| {phi:g} | {target:.2g} | {t_end:g}, {wf.mean():.2f} s | {tr.mean():.0f} "
              f"({tr.min():.0f}-{tr.max():.0f}), {wa.mean():.2f} s, {ea.mean():.2g} | "
              f"{100 * (1 - wa.sum() / wf.sum()):+.0f}% | {int(ok.sum())}/{len(ok)} |",
              flush=True)


if __name__ == "__main__":
    main()
