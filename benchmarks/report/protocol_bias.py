"""The steady protocol's bias against the long-run truth: seed by seed, and for the seed means,
at every size (docs/steady.md; benchmarks/RESULTS.md, "The steady protocol against the long
runs").

    python -m benchmarks.report.protocol_bias

A bias from the start has one sign for every seed: no average over seeds removes it and no
error of a run covers it. So the protocol is judged here the only way that shows it: its
estimate for a layer (phi, N, seed: one disorder) against that layer's own long-run mean,
measured on runs 10-100 times longer (benchmarks/measure/stiff_states.py,
benchmarks/measure/offgrid.py, every start pooled after its first 20%), and the mean of those
differences over the seeds. The protocol's records are benchmarks/measure/protocol_bias.py's.

Per record, size and phi: the seeds with a long-run truth, the verdicts, the mean run length,
the seed mean of the relative bias of <sigma_x>/sigma_n and of mu_bar (the reported estimate,
and the main run's alone), the largest |bias| / reported error, and the coverage of estimate
+- 1.96 error; and the rates of false verdicts (``verdict_class``). benchmarks/documents/
renders them (blocks ``protocol-bias``, ``protocol-offgrid``).
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pandas as pd

from benchmarks import harness
from benchmarks.harness import parser
from benchmarks.measure import offgrid
from benchmarks.measure.protocol_bias import RECORDS
from benchmarks.report.stiff_states import layer_means, load
from bkflow.observables.states import memory_chi

OFFGRID_NAME = re.compile(r"N(\d+)_([\w.]+?)_phi([\d.]+)_(\w+?)_s(\d+)_C([\d.]+)\.parquet$")
#: the share of each run left out as its start's transient (as benchmarks/report/stiff_states.py)
OFFGRID_TRANSIENT = 0.2


def load_offgrid(root=offgrid.OUT) -> pd.DataFrame:
    """One row per run: variant, N, phi, start, seed, C, its kept blocks and its whole
    record."""
    rows = []
    for f in sorted(Path(root).glob("*.parquet")):
        m = OFFGRID_NAME.search(f.name)
        if not m:
            continue
        n, variant, phi, start, seed, c = m.groups()
        rec = pd.read_parquet(f)
        rows.append({"variant": variant, "N": int(n), "phi": float(phi), "start": start,
                     "seed": int(seed), "C": float(c), "t": float(rec.t1.iloc[-1]),
                     "blocks": rec.iloc[int(OFFGRID_TRANSIENT * len(rec)):].reset_index(drop=True),
                     "whole": rec})
    return pd.DataFrame(rows)


def _chi(b: pd.DataFrame, n: int) -> float:
    w = b.n.to_numpy(float)
    return float(n * (np.average(b.R2abs, weights=w) - np.average(b.Zre, weights=w) ** 2
                      - np.average(b.Zim, weights=w) ** 2))


def offgrid_truths(runs: pd.DataFrame | None = None) -> dict:
    """(variant, N, phi, seed) -> the layer's long-run means: {"stress", "mu_bar", "starts"
    (those pooled), "spread" (the largest relative difference of their means)}. Every start's
    kept blocks pooled, but a start whose kept part still holds the start's common phase
    (chi above bkflow's memory threshold: the synchronized start of a stiff layer) is left
    out: its numbers are its start's."""
    runs = load_offgrid() if runs is None else runs
    out = {}
    for key, g in runs.groupby(["variant", "N", "phi", "seed"]):
        n = key[1]
        keep = [r for _, r in g.iterrows() if _chi(r.blocks, n) <= memory_chi(n)]
        if not keep:
            continue
        allb = pd.concat([r.blocks for r in keep], ignore_index=True)
        w = (allb.t1 - allb.t0).to_numpy()
        nslip = allb["nslip_0.01"].sum()
        per = [np.average(r.blocks.s, weights=r.blocks.t1 - r.blocks.t0) for r in keep]
        out[key] = {"stress": float(np.average(allb.s, weights=w)),
                    "mu_bar": float(allb["sfail_0.01"].sum() / nslip) if nslip else math.nan,
                    "starts": [r.start for r in keep],
                    "spread": float((max(per) - min(per)) / np.mean(per))}
    return out


# ------------------------------------------------------------------------- the truth
def truths() -> dict:
    """(N, phi, seed, variant) -> the layer's long-run means {"stress", "mu_bar"}: at the
    model's defaults (variant "") every start's record of benchmarks/records/stiff_states
    (and, at the phi the calibration did not run, benchmarks/records/truth: the random and
    partial starts, 2 x 10^5 time units) pooled after its first 20%
    (benchmarks/report/stiff_states.py's ``layer_means``); off the grid those of
    benchmarks/measure/offgrid.py (``offgrid_truths``)."""
    out = {}
    for root in ("truth", "stiff_states"):   # the calibration's records where both have one
        if (harness.RECORDS / root).is_dir():
            for (n, phi, seed), m in layer_means(load(harness.RECORDS / root)).items():
                out[(n, float(phi), seed, "")] = m
    if offgrid.OUT.is_dir():
        for (variant, n, phi, seed), m in offgrid_truths().items():
            out[(n, float(phi), seed, variant)] = m
    return out


def _variant(label: str) -> str:
    """The off-grid variant of a record (its label, benchmarks/measure/offgrid.py's
    VARIANTS), or "" at the model's defaults."""
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


def main(argv=None) -> None:
    parser(__doc__).parse_args(argv)
    rows = bias_rows()
    print(markdown(aggregate(rows)))
    for label, d in rows.groupby("record"):
        print(label, rates(d))


if __name__ == "__main__":
    main()
