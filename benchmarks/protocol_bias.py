"""The steady protocol's bias against the long-run truth: seed by seed, and for the seed means,
at every size (docs/steady.md; benchmarks/RESULTS.md, "The steady protocol against the long
runs").

A bias from the start has one sign for every seed: no average over seeds removes it and no
error of a run covers it. So the protocol is judged here the only way that shows it: its
estimate for a layer (phi, N, seed: one disorder) against that layer's own long-run mean,
measured on runs 10-100 times longer (benchmarks/stiff_states.py, benchmarks/offgrid.py,
every start pooled after its first 20%), and the mean of those differences over the seeds.

    python benchmarks/protocol_bias.py run --n 100 [--phi 0.1,...] [--seeds 1,2,3] [--jobs 2]
                                           [--label NAME] [--set NAME=VALUE ...]
    python benchmarks/protocol_bias.py report

run
    ``bkflow sweep`` of the steady protocol (the default preset, scene friction: the friction
    numbers are the same in every scene) into runs/protocol_bias/<label>/, its runs.csv
    recorded as benchmarks/records/protocol_bias/<label>.csv with the bkflow version, the
    commit, the wall time of the sweep and the machine's cores. Resumable: the same command
    again finishes what is missing.
report
    Per record, size and phi: the seeds with a long-run truth, the verdicts, the mean run
    length, the seed mean of the relative bias of <sigma_x>/sigma_n and of mu_bar (the
    reported estimate, and the main run's alone), the largest |bias| / reported error, and the
    coverage of estimate +- 1.96 error; and the rates of false verdicts (``verdict_class``).
    benchmarks/results_blocks.py renders them (blocks ``protocol-bias``, ``protocol-offgrid``).
"""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

RECORDS = HERE / "records" / "protocol_bias"
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


# ------------------------------------------------------------------------- the truth
def truths() -> dict:
    """(N, phi, seed, variant) -> the layer's long-run means {"stress", "mu_bar"}: at the
    model's defaults (variant "") every start's record of benchmarks/records/stiff_states
    (and, at the phi the calibration did not run, benchmarks/records/truth: the random and
    partial starts, 2 x 10^5 time units) pooled after its first 20%
    (states_report.layer_means); off the grid those of benchmarks/offgrid.py
    (``offgrid.truths``)."""
    import offgrid
    from states_report import layer_means, load

    out = {}
    for root in ("truth", "stiff_states"):   # the calibration's records where both have one
        if (HERE / "records" / root).is_dir():
            for (n, phi, seed), m in layer_means(load(HERE / "records" / root)).items():
                out[(n, float(phi), seed, "")] = m
    if offgrid.OUT.is_dir():
        for (variant, n, phi, seed), m in offgrid.truths().items():
            out[(n, float(phi), seed, variant)] = m
    return out


def _variant(label: str) -> str:
    """The off-grid variant of a record (its label, benchmarks/offgrid.py's VARIANTS), or ""
    at the model's defaults."""
    import offgrid

    return label if label in offgrid.VARIANTS else ""


#: an estimate within this of its layer's long-run mean (relative) is right: a verdict of
#: memory or drift on it is a false alarm; one further off, and beyond 1.96 of its own error,
#: is wrong: a verdict that calls it settled (steady, or the states it visited) is false
TOLERANCE = 0.005


def verdict_class(row: dict) -> str:
    """What a run's verdict was, judged by its layer's long-run truth: "false metastable"
    (a start said to be remembered where neither run of the pair lies further than TOLERANCE
    from the truth), "false drifting" (on numbers within TOLERANCE of it), "false steady" (a
    settled verdict, steady or the states visited, on numbers further off than TOLERANCE and
    beyond 1.96 of their errors), or "right"."""
    off = max(abs(row["b_stress"]), abs(row["b_mu"]))
    missed = off > TOLERANCE and max(abs(row["z_stress"]), abs(row["z_mu"])) > 1.96
    state = row["state"]
    if state == "metastable":
        legs = max(abs(row["b_stress_run"]), abs(row.get("b_stress_companion", math.nan)))
        return "false metastable" if legs <= TOLERANCE else "right"
    if state == "drifting":
        return "false drifting" if off <= TOLERANCE else "right"
    return "false steady" if missed else "right"


def rates(d: pd.DataFrame) -> dict:
    """The share of each false verdict among the runs of ``d`` (bias_rows)."""
    n = len(d)
    return {k: float((d.verdict_class == k).sum() / n) if n else math.nan
            for k in ("false metastable", "false drifting", "false steady")}


def bias_table(records=None) -> pd.DataFrame:
    """Per record, N and phi: the protocol's estimate against the long-run truth (module
    doc)."""
    return aggregate(bias_rows(records))


def bias_rows(records=None) -> pd.DataFrame:
    """One row per recorded run with a long-run truth: its relative biases, z-scores and
    verdict class."""
    truth = truths()
    rows = []
    for path in sorted(records or RECORDS.glob("*.csv")):
        df = pd.read_csv(path)
        for _, r in df.iterrows():
            key = (int(r.N), float(r.phi), int(r.seed), _variant(path.stem))
            t = truth.get(key)
            if t is None:
                t = next((v for k, v in truth.items() if k[0] == key[0] and k[2] == key[2]
                          and k[3] == key[3] and math.isclose(k[1], key[1], rel_tol=5e-3)),
                         None)
            if t is None:
                continue
            rows.append({"record": path.stem, "N": int(r.N), "phi": float(r.phi),
                         "seed": int(r.seed), "state": r.state, "t_run": r.t_run,
                         "b_stress": r.mean_stress_ratio / t["stress"] - 1,
                         "b_stress_run": r.get("mean_stress_ratio_run",
                                               r.mean_stress_ratio) / t["stress"] - 1,
                         "b_mu": r.mu_bar / t["mu_bar"] - 1,
                         "b_mu_run": r.get("mu_bar_run", r.mu_bar) / t["mu_bar"] - 1,
                         "b_stress_companion": r.get("companion_mean_stress_ratio",
                                                     math.nan) / t["stress"] - 1,
                         "z_stress": (r.mean_stress_ratio - t["stress"]) / r.mean_stress_ratio_err,
                         "z_mu": (r.mu_bar - t["mu_bar"]) / r.mu_bar_err})
            rows[-1]["verdict_class"] = verdict_class(rows[-1])
    return pd.DataFrame(rows)


def aggregate(d: pd.DataFrame) -> pd.DataFrame:
    """``bias_rows`` per record, N and phi."""
    if d.empty:
        return d

    def agg(g):
        return pd.Series({
            "seeds": len(g), "states": ", ".join(sorted(set(g.state))),
            "t_run": g.t_run.mean(),
            "bias_stress": g.b_stress.mean(), "bias_stress_se": g.b_stress.std(ddof=1)
            / math.sqrt(len(g)) if len(g) > 1 else math.nan,
            "bias_stress_run": g.b_stress_run.mean(),
            "bias_mu": g.b_mu.mean(), "bias_mu_se": g.b_mu.std(ddof=1) / math.sqrt(len(g))
            if len(g) > 1 else math.nan,
            "bias_mu_run": g.b_mu_run.mean(),
            "max_z": float(np.nanmax(np.abs(np.r_[g.z_stress, g.z_mu]))),
            "false": int((g.verdict_class != "right").sum()),
            "covered": float(np.mean(np.r_[np.abs(g.z_stress) <= 1.96,
                                           np.abs(g.z_mu) <= 1.96]))})

    return d.groupby(["record", "N", "phi"]).apply(agg, include_groups=False).reset_index()


def pct(v: float, se: float = math.nan) -> str:
    """A relative bias in percent, with its standard error where there is one."""
    if not math.isfinite(v):
        return "n/a"
    return f"{100 * v:+.2f}%" + (f" +- {100 * se:.2f}%" if math.isfinite(se) else "")


def markdown(t: pd.DataFrame) -> str:
    lines = ["| record | N | phi | seeds | verdicts | mean t_run | <sigma_x>/sigma_n: bias "
             "(run alone) | mu_bar: bias (run alone) | largest abs(z) | covered |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for _, r in t.iterrows():
        lines.append(f"| {r.record} | {r.N} | {r.phi:g} | {r.seeds} | {r.states} | "
                     f"{r.t_run:.3g} | {pct(r.bias_stress, r.bias_stress_se)} "
                     f"({pct(r.bias_stress_run)}) | {pct(r.bias_mu, r.bias_mu_se)} "
                     f"({pct(r.bias_mu_run)}) | {r.max_z:.1f} | {r.covered:.2f} |")
    return "\n".join(lines)


def before_after(rows: pd.DataFrame) -> str:
    """Per size and phi: the protocol now (records ``N<n>``, ``N<n>_...``: more seeds) beside
    the one before this estimator (records ``before_N<n>...``: bkflow 0.5.0's rule, its main
    run's numbers), on the same seeds and the same truth."""
    def by_size(d):   # every record of a size at the defaults (more seeds: N100_seeds456)
        return aggregate(d.assign(record=[f"N{n}" for n in d.N]))

    now = by_size(rows[rows.record.str.match(r"^N\d+(_|$)")])
    was = by_size(rows[rows.record.str.match(r"^before_N\d+(_|$)")])
    was = {(r.N, round(r.phi, 6)): r for _, r in was.iterrows()} if len(was) else {}
    lines = ["| N | phi | seeds | verdicts | mean t_run, before / now | <sigma_x>/sigma_n bias, "
             "before / now | mu_bar bias, before / now | largest abs(z) now | covered now |",
             "|---|---|---|---|---|---|---|---|---|"]
    for _, r in now.iterrows():
        b = was.get((r.N, round(r.phi, 6)))
        lines.append(
            f"| {r.N} | {r.phi:g} | {r.seeds} | {r.states} | "
            f"{'n/a' if b is None else format(b.t_run, '.3g')} / {r.t_run:.3g} | "
            f"{'n/a' if b is None else pct(b.bias_stress, b.bias_stress_se)} / "
            f"{pct(r.bias_stress, r.bias_stress_se)} | "
            f"{'n/a' if b is None else pct(b.bias_mu, b.bias_mu_se)} / "
            f"{pct(r.bias_mu, r.bias_mu_se)} | {r.max_z:.1f} | {r.covered:.2f} |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    g = r.add_mutually_exclusive_group(required=True)
    g.add_argument("--n", type=int)
    g.add_argument("--size")
    r.add_argument("--phi", default=PAPER_PHI)
    r.add_argument("--seeds", default="1,2,3")
    r.add_argument("--jobs", type=int, default=2)
    r.add_argument("--label")
    r.add_argument("--set", action="append", default=[])
    sub.add_parser("report")
    a = ap.parse_args(argv)
    if a.cmd == "run":
        label = a.label or (f"N{a.n}" if a.n else a.size)
        run(a.n, a.size, a.phi, a.seeds, a.jobs, label, a.set)
        return
    rows = bias_rows()
    print(markdown(aggregate(rows)))
    for label, d in rows.groupby("record"):
        print(label, rates(d))


if __name__ == "__main__":
    main()
