"""The relaxation from the synchronized start, drawn from its record
(benchmarks/records/stationarity_relaxation.json, written by ``python -m
benchmarks.measure.stationarity relaxation``): benchmarks/stationarity_relaxation.png.

    python -m benchmarks.report.stationarity
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from benchmarks.harness import BENCH, parser
from benchmarks.measure.stationarity import RELAXATION_RECORD

#: the relaxation's figure (benchmarks/RESULTS.md, "Time to steady")
RELAXATION_FIGURE = BENCH / "stationarity_relaxation.png"


def read_relaxation_record(path: Path = RELAXATION_RECORD) -> tuple[pd.DataFrame, dict]:
    import json

    rec = json.loads(Path(path).read_text())
    curves = {(c["N"], c["phi"]): [(np.array(c["t"]), np.array(m)) for m in c["means"]]
              for c in rec["curves"]}
    return pd.DataFrame(rec["rows"]), curves


def relaxation_figure(df: pd.DataFrame, curves: dict, out: Path = RELAXATION_FIGURE):
    """Left: the block means of the stress from the synchronized start at the smallest N (mean
    over seeds). Right: per N, the medians over seeds of tau and t_equil against phi; a t_equil
    of 0 (no transient detected) cannot sit on the log axis and is drawn on its lower edge."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with plt.rc_context({"font.size": 8}):
        fig, (a, b) = plt.subplots(1, 2, figsize=(8.5, 3.6), layout="constrained")
        _relaxation_curves(a, df, curves)
        _relaxation_times(b, df)
        fig.legend(*b.get_legend_handles_labels(), loc="outside right center", frameon=False,
                   fontsize=7)
        fig.savefig(out, dpi=150)
    return fig


def _relaxation_curves(ax, df: pd.DataFrame, curves: dict) -> None:
    n0 = df.N.min()
    for (n, phi), cs in sorted(curves.items()):
        if n != n0 or phi not in (0.1, 10.0, 100.0, 1000.0):
            continue
        ax.plot(cs[0][0], np.mean([m for _, m in cs], axis=0), lw=0.9, label=f"phi = {phi:g}")
    ax.set_xlabel("t (time units)")
    ax.set_ylabel(rf"block mean of $\sigma_x/\sigma_n$ ({df.seed.nunique()} seeds)")
    ax.set_title(f"synchronized start, N = {n0}", fontsize=9)
    ax.legend(frameon=False, fontsize=7, loc="upper right", bbox_to_anchor=(1, 0.9), ncols=2)


def _relaxation_times(ax, df: pd.DataFrame) -> None:
    meds = {n: g.groupby("phi")[["tau", "t_equil"]].median() for n, g in df.groupby("N")}
    positive = [v for m in meds.values() for c in ("tau", "t_equil")
                for v in m[c].to_numpy() if np.isfinite(v) and v > 0]
    lo = 10 ** np.floor(np.log10(min(positive) / 2)) if positive else 1.0
    for (n, med), mk in zip(meds.items(), "os^D"):
        ax.plot(med.index, med.tau, mk + "-", lw=0.8, label=f"tau, N = {n}")
        te = med.t_equil.where(med.t_equil > 0)
        line, = ax.plot(med.index, te, mk + ":", mfc="none", lw=0.8, label=f"t_equil, N = {n}")
        zero = med.index[med.t_equil == 0]
        if len(zero):
            ax.plot(zero, np.full(len(zero), lo), "v", color=line.get_color(), ms=6, ls="",
                    clip_on=False, label=f"t_equil = 0, N = {n} (drawn on the lower edge)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylim(lo, None)
    ax.set_xlabel(r"$\phi$")
    ax.set_ylabel("relaxation time (time units; median over seeds)")
    ax.set_title("relaxation of the stress from the synchronized start", fontsize=9)


def main(argv=None) -> None:
    parser(__doc__).parse_args(argv)
    relaxation_figure(*read_relaxation_record())
    print(f"wrote {RELAXATION_FIGURE}")


if __name__ == "__main__":
    main()
