"""Convergence order in dt of sigma_x (deterministic runs, one seed, no statistics).

Runs one lattice at dt-factors C = C0 / 2^k and compares the stress series with the smallest
C's. The sampling interval is set to one step of the largest C, so every run samples sigma_x
at exactly the same times. Two windows: up to t = 20, before any contact breaks (the drive
needs t ~ mu_s sigma_n / (k_d^i V_d) >= 25 to load the first contact), where the integrator
is smooth; and up to t = 150, through the first slips, where the reset rule enters. The error
is max |sigma_x - sigma_x,ref| over the window, and |<sigma_x> -
<sigma_x>_ref| / sigma_n over it; the order is the slope of log(error) against log(C).

    python -m benchmarks.measure.convergence [--phi 10] [--size 20x5] [--levels 6]
        [--contact-rule reset|reset/step|coulomb] [--damping implicit|half]
"""

from __future__ import annotations

import math
import tempfile

import numpy as np

from benchmarks.harness import parser
from bkflow.cli.assignments import parse_size
from bkflow.lammps.engine import run
from bkflow.model.params import CONTACT_RULES, DAMPING_MODES, RunSpec
from bkflow.store.rundir import RunDir

C0 = 0.4


def series(phi, size, c, t_end, stress_every, contact_rule=RunSpec.contact_rule,
           damping=RunSpec.damping):
    lx, ly = size
    spec = RunSpec(phi=phi, Lx=lx, Ly=ly, dt_factor=c, t_end=t_end, stress_every=stress_every,
                   scene="friction", contact_rule=contact_rule, damping=damping)
    with tempfile.TemporaryDirectory() as d:
        res = run(spec, d, progress=False)
        t, s = RunDir(d).read_stress()
    return t, s, res.meta["contact_breaks"]


def study(phi, size, levels, windows=(20.0, 150.0), contact_rule=RunSpec.contact_rule,
          damping=RunSpec.damping):
    every = RunSpec(phi=phi, dt_factor=C0).dt  # one step of the largest C: common sample times
    cs = [C0 / 2 ** k for k in range(levels)]
    c_ref = C0 / 2 ** (levels + 2)
    t_end = max(windows)
    sigma_n = RunSpec.sigma_n
    ref_t, ref_s, ref_breaks = series(phi, size, c_ref, t_end, every, contact_rule, damping)
    out = []
    for c in cs:
        t, s, breaks = series(phi, size, c, t_end, every, contact_rule, damping)
        n = min(len(t), len(ref_t))
        assert np.allclose(t[:n], ref_t[:n], rtol=1e-9, atol=1e-9), "sampling times differ"
        row = {"C": c, "breaks": breaks}
        for w in windows:
            m = t[:n] <= w
            d = s[:n][m] - ref_s[:n][m]
            row[f"max_{w:g}"] = float(np.abs(d).max())
            row[f"mean_{w:g}"] = float(abs(d.mean()) / sigma_n)
        out.append(row)
    return out, c_ref, ref_breaks


def slope(cs, errs):
    cs, errs = np.asarray(cs), np.asarray(errs)
    ok = errs > 0
    return float(np.polyfit(np.log(cs[ok]), np.log(errs[ok]), 1)[0]) if ok.sum() >= 2 else math.nan


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--phi", type=float, nargs="+", default=[10.0])
    ap.add_argument("--size", default="20x5")
    ap.add_argument("--levels", type=int, default=6)
    ap.add_argument("--contact-rule", choices=CONTACT_RULES, default=RunSpec.contact_rule)
    ap.add_argument("--damping", choices=DAMPING_MODES, default=RunSpec.damping)
    a = ap.parse_args(argv)
    size = parse_size(a.size)
    for phi in a.phi:
        rows, c_ref, ref_breaks = study(phi, size, a.levels, contact_rule=a.contact_rule,
                                        damping=a.damping)
        print(f"phi = {phi:g}, {a.size}, contact rule {a.contact_rule}, damping {a.damping}; "
              f"reference C = {c_ref:g} "
              f"({ref_breaks} contact breaks by t = 150)\n")
        print("| C | breaks by t=150 | max err t<=20 | mean err t<=20 | max err t<=150 | "
              "mean err t<=150 |")
        print("|---|---|---|---|---|---|")
        for r in rows:
            print(f"| {r['C']:g} | {r['breaks']} | {r['max_20']:.2e} | {r['mean_20']:.2e} | "
                  f"{r['max_150']:.2e} | {r['mean_150']:.2e} |")
        cs = [r["C"] for r in rows]
        print("\norder (slope of log error vs log C): " + ", ".join(
            f"{k}: {slope(cs, [r[k] for r in rows]):.2f}"
            for k in ("max_20", "mean_20", "max_150", "mean_150")) + "\n")


if __name__ == "__main__":
    main()
