"""What the long runs of benchmarks/measure/stiff_states.py say: the states, their occupancy and
residence times, the long-run means, the switching calibration
(src/bkflow/model/switching.json) and the coverage of the error that uses it, the
long-run curve (benchmarks/records/long_run_curve.csv) and the figure
(benchmarks/stiff_states.png).

    python -m benchmarks.report.stiff_states                  # all of it, from the records
    python -m benchmarks.report.stiff_states --figure-only    # only the figure

Every run's first TRANSIENT of its length is left out (the start's memory: the synchronized
start's coherence needs up to 2 x 10^5 time units to decay at phi = 1000). The long-run mean
of a layer (phi, N, seed: one disorder) is the time average over all its runs' kept blocks,
every start pooled; its standard error is that of the runs' means about it.

Windows. For each window length W of WINDOWS, windows are slid along every run's kept part
(start every W / 4); the relative variance of their means about the layer's long-run mean,
averaged over the layers at (phi, N), is the calibration's entry (observables: the stress
ratio, and mu_bar over the 1% slips). Coverage, leave one seed out: the calibration made
without a seed's runs gives each of its windows the interval mean +- 1.96 sqrt(V) mean; the
share that holds the seed's long-run mean is the coverage (the runs' own error estimate can
only widen the interval, so this is what the product reaches at least).
"""

from __future__ import annotations

import glob
import json
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd

from benchmarks.harness import RECORDS, parser
from benchmarks.measure.stiff_states import OUT
from benchmarks.report import stiff_states_figure
from bkflow.model.calibration import CALIBRATION_FILE, in_place, reread
from bkflow.observables import states, switching
from bkflow.observables.states import BLOCK_T, r_independent

#: the share of each run left out as the start's transient
TRANSIENT = 0.2
WINDOWS = (2e3, 5e3, 1e4, 2e4, 5e4, 1e5, 2e5, 5e5, 1e6, 2e6)
NAME = re.compile(r"N(\d+)_phi([\d.]+)_(\w+?)_s(\d+)_C([\d.]+)\.parquet$")
#: the long-run curve: per (N, phi) the seeds' mean of each layer's long-run mean, written from
#: the records (workflows/paper/reproduce.py draws it in fig2a_protocols)
CURVE = RECORDS / "long_run_curve.csv"


def load(root) -> pd.DataFrame:
    """One row per run: N, phi, start, seed, C, the kept blocks (DataFrame)."""
    rows = []
    for f in sorted(glob.glob(str(Path(root) / "*.parquet"))):
        m = NAME.search(f)
        if not m:
            continue
        rec = pd.read_parquet(f)
        n, phi, start, seed, c = m.groups()
        keep = rec.iloc[int(TRANSIENT * len(rec)):].reset_index(drop=True)
        rows.append({"N": int(n), "phi": float(phi), "start": start, "seed": int(seed),
                     "C": float(c), "t": float(rec.t1.iloc[-1]), "blocks": keep,
                     "whole": rec})
    return pd.DataFrame(rows)


def mu_bar(b: pd.DataFrame) -> float:
    n = b["nslip_0.01"].sum()
    return float(b["sfail_0.01"].sum() / n) if n else math.nan


def layer_means(runs: pd.DataFrame) -> dict:
    """(N, phi, seed) -> {"stress": long-run mean, "stress_se", "mu_bar", "T"}."""
    out = {}
    for key, g in runs.groupby(["N", "phi", "seed"]):
        allb = pd.concat(list(g.blocks), ignore_index=True)
        w = (allb.t1 - allb.t0).to_numpy()
        s = float(np.average(allb.s, weights=w))
        per = np.array([np.average(b.s, weights=b.t1 - b.t0) for b in g.blocks])
        se = float(per.std(ddof=1) / math.sqrt(len(per))) if len(per) > 1 else math.nan
        out[key] = {"stress": s, "stress_se": se, "mu_bar": mu_bar(allb), "T": float(w.sum()),
                    "runs": len(g)}
    return out


def windows_of(b: pd.DataFrame, W: float):
    """Means (stress, mu_bar) of windows of W time units slid along the blocks b (a start
    every W / 4: bkflow.observables.switching.slide)."""
    k = max(1, int(round(W / BLOCK_T)))
    stress = switching.slide(b.s, k)
    with np.errstate(invalid="ignore", divide="ignore"):
        mu = switching.slide(b["sfail_0.01"], k) / switching.slide(b["nslip_0.01"], k)
    return stress, mu


def window_table(runs: pd.DataFrame, means: dict, exclude_seed=None) -> dict:
    """{N: {"phi": [...], "windows": [...], "stress": [[...]], "mu_bar": [[...]]}}: the
    relative mean-square deviation of window means from the layer's long-run mean
    (bkflow.observables.switching.calibrate), the layers of a seed left out with
    ``exclude_seed``."""
    out = {}
    for n, gn in runs.groupby("N"):
        entry = {}
        for name, series in (("stress", lambda b: b.s.to_numpy()),
                             ("mu_bar", None)):
            layers = {}
            for (phi, seed), g in gn.groupby(["phi", "seed"]):
                if seed == exclude_seed:
                    continue
                lm = means[(n, phi, seed)]
                if name == "stress":
                    layers.setdefault(phi, []).append(
                        (lm["stress"], [series(b) for b in g.blocks]))
                else:
                    # mu_bar of a window: its slips' sigma_fail sum over their count
                    layers.setdefault(phi, []).append((lm["mu_bar"], [
                        (b["sfail_0.01"].to_numpy(), b["nslip_0.01"].to_numpy(float))
                        for b in g.blocks]))
            cal = switching.calibrate(layers, WINDOWS, BLOCK_T)
            entry.update(phi=cal["phi"], windows=cal["windows"])
            entry[name] = cal["table"]
        out[str(n)] = entry
    return out


def coverage(runs: pd.DataFrame, means: dict) -> pd.DataFrame:
    """Leave-one-seed-out coverage of mean +- 1.96 sqrt(V) mean, per (N, phi, W)."""

    rows = []
    seeds = sorted(runs.seed.unique())
    for seed in seeds:
        table = {"sizes": window_table(runs, means, exclude_seed=seed)}
        with in_place(table):
            for _, r in runs[runs.seed == seed].iterrows():
                lm = means[(r.N, r.phi, seed)]
                for W in WINDOWS:
                    s, m = windows_of(r.blocks, W)
                    if not len(s):
                        continue
                    vs = states.window_variance("stress", r.phi, r.N, W)
                    vm = states.window_variance("mu_bar", r.phi, r.N, W)
                    cov_s = np.abs(s - lm["stress"]) <= 1.96 * math.sqrt(vs) * np.abs(s)
                    ok = np.isfinite(m)
                    cov_m = np.abs(m[ok] - lm["mu_bar"]) <= 1.96 * math.sqrt(vm) * np.abs(m[ok])
                    rows.append({"N": r.N, "phi": r.phi, "W": W, "seed": seed,
                                 "n": len(s), "stress": cov_s.mean(), "mu_bar": cov_m.mean()})
    df = pd.DataFrame(rows)
    return df.groupby(["N", "phi", "W"]).apply(
        lambda g: pd.Series({"windows": g.n.sum(),
                             "stress": np.average(g.stress, weights=g.n),
                             "mu_bar": np.average(g.mu_bar, weights=g.n)}),
        include_groups=False).reset_index()


def occupancy(runs: pd.DataFrame) -> pd.DataFrame:
    """Per (N, phi): the quiet share of the kept blocks, each state's mean stress and mu_bar,
    and the residence times (mean length of an uninterrupted stretch of blocks in a state)."""
    rows = []
    for (n, phi), g in runs.groupby(["N", "phi"]):
        allb = pd.concat(list(g.blocks), ignore_index=True)
        quiet = allb.R < r_independent(n)
        res = {"quiet": [], "coherent": []}
        for b in g.blocks:
            q = (b.R < r_independent(n)).to_numpy()
            if not len(q):
                continue
            edges = np.flatnonzero(np.diff(q.astype(int))) + 1
            # stretches cut by the run's ends are left out (their length is unknown)
            for a, z in zip(edges[:-1], edges[1:]):
                res["quiet" if q[a] else "coherent"].append((z - a) * BLOCK_T)
        row = {"N": n, "phi": phi, "runs": len(g), "T": float((allb.t1 - allb.t0).sum()),
               "quiet": float(quiet.mean())}
        for name, m in (("quiet", quiet), ("coherent", ~quiet)):
            row[f"stress_{name}"] = float(allb.s[m].mean()) if m.any() else math.nan
            row[f"mu_bar_{name}"] = mu_bar(allb[m]) if m.any() else math.nan
            row[f"residence_{name}"] = float(np.mean(res[name])) if res[name] else math.nan
            row[f"stretches_{name}"] = len(res[name])
        rows.append(row)
    return pd.DataFrame(rows)


#: windows over which the memory threshold of chi is measured, and its margin
CHI_WINDOWS = (4e3, 1.6e4, 6.4e4)
CHI_MARGIN = 1.25


def window_chi(runs: pd.DataFrame) -> dict:
    """N -> the largest phase fluctuation chi = N (<|Z|^2> - |<Z>|^2) of any window (of
    CHI_WINDOWS, slid by half its length) of the runs' kept parts: no start's memory there."""
    out = {}
    for n, g in runs.groupby("N"):
        worst = 0.0
        for b in g.blocks:
            w = b.n.to_numpy(float)
            z2, zr, zi = (np.concatenate([[0], np.cumsum(w * b[c].to_numpy())])
                          for c in ("R2abs", "Zre", "Zim"))
            cw = np.concatenate([[0], np.cumsum(w)])
            for W in CHI_WINDOWS:
                k = int(round(W / BLOCK_T))
                if len(b) < k:
                    continue
                a = np.arange(0, len(b) - k + 1, max(1, k // 2))
                tot = cw[a + k] - cw[a]
                chi = n * ((z2[a + k] - z2[a]) / tot - ((zr[a + k] - zr[a]) / tot) ** 2
                           - ((zi[a + k] - zi[a]) / tot) ** 2)
                worst = max(worst, float(chi.max()))
        out[str(n)] = worst
    return out


#: the run lengths of the steady protocol's windows tested for the verdict (the product's
#: window [0.2 T, T] of a run from t = 0), and how far off the long-run mean a window called
#: steady may be before it is a false steady
VERDICT_T = (8e3, 16e3, 32e3, 64e3)
FALSE_STEADY_OFF = 0.005


def verdicts(runs: pd.DataFrame, means: dict) -> pd.DataFrame:
    """The verdict of bkflow.observables.states on windows [0.2 T, T] of the runs from the steady
    protocol's starts (random, partial) for T in VERDICT_T, read from the blocks (the trend
    test over 10 groups of blocks, chi from the blocks' moments, the composition, the
    calibrated switching against the blocks' own error); per (N, phi, T): the windows, the
    share of each verdict, the false-steady rate (windows called steady whose mean is more than
    FALSE_STEADY_OFF off the layer's long-run mean), and the coverage of the interval mean
    +- 1.96 err (err the larger of the blocks' own and the calibrated) of the long-run mean."""
    rows = []
    for _, r in runs[runs.start.isin(["random", "partial"])].iterrows():
        lm = means[(r.N, r.phi, r.seed)]
        rec = r.whole
        for T in VERDICT_T:
            kT = int(round(T / BLOCK_T))
            # the run's own first window, then windows as if runs began every T further on
            for a in range(0, len(rec) - kT + 1, kT):
                k0, k1 = a + int(round(0.2 * kT)), a + kT
                if k1 - k0 < 10:
                    continue
                rows.append(_verdict_row(r, lm, rec.iloc[k0:k1], T, a == 0))
    return _verdict_table(pd.DataFrame(rows))


def _verdict_row(r, lm, b: pd.DataFrame, T: float, first: bool) -> dict:
    """The verdict of one window (blocks ``b``) of run ``r`` of the layer ``lm``, as
    bkflow.observables.switching gives it from the blocks (``block_verdict``)."""
    v, mean, err = switching.block_verdict(b.t0, b.t1, b.s, b.R, b.R2abs, b.Zre, b.Zim, b.n,
                                        r.phi, r.N)
    return {"N": r.N, "phi": r.phi, "T": T, "verdict": v, "first": first,
            "off": abs(mean / lm["stress"] - 1),
            "covered": abs(mean - lm["stress"]) <= 1.96 * err}


def _verdict_table(df: pd.DataFrame) -> pd.DataFrame:
    out = []
    for (n, phi, T), g in df.groupby(["N", "phi", "T"]):
        steady = g[g.verdict == "steady"]
        out.append({"N": n, "phi": phi, "T": T, "windows": len(g),
                    "steady": len(steady) / len(g),
                    "switching": g.verdict.isin(states.SWITCHING).mean(),
                    "drifting": (g.verdict == "drifting").mean(),
                    "metastable": (g.verdict == "metastable").mean(),
                    "false_steady": float((~steady.covered).mean())
                    if len(steady) else math.nan,
                    "steady_off_05": float((steady.off > FALSE_STEADY_OFF).mean())
                    if len(steady) else math.nan,
                    "coverage": float(g.covered.mean())})
    return pd.DataFrame(out)


def ergodicity(runs: pd.DataFrame) -> pd.DataFrame:
    """The Thirumalai-Mountain fluctuation metric of each layer: the variance over its starts
    of their running time averages of the stress, d(t) (Thirumalai, Mountain and Kirkpatrick,
    PRA 39, 3563 (1989)); an ergodic layer's falls as 1/t. Per (N, phi): d at t / 4 and at t
    (t the shortest of the starts' kept lengths), their ratio (1/4 when ergodic), averaged
    over the layers (seeds) with all four starts."""
    rows = []
    for (n, phi, seed), g in runs.groupby(["N", "phi", "seed"]):
        if len(g) < 4:
            continue
        k = min(len(b) for b in g.blocks)
        if k < 8:
            continue
        avg = np.array([np.cumsum(b.s.to_numpy()[:k]) / np.arange(1, k + 1) for b in g.blocks])
        d = avg.var(axis=0, ddof=1)
        rows.append({"N": n, "phi": phi, "seed": seed, "t": k * BLOCK_T,
                     "d_quarter": d[k // 4 - 1], "d_end": d[-1],
                     "spread": math.sqrt(d[-1]) / float(avg[:, -1].mean())})
    df = pd.DataFrame(rows)
    if df.empty:
        return df
    g = df.groupby(["N", "phi"])
    out = g[["t", "d_quarter", "d_end", "spread"]].mean().reset_index()
    out["ratio"] = (g.apply(lambda x: (x.d_end / x.d_quarter).mean(),
                            include_groups=False)).to_numpy()
    return out


#: the paper's run lengths (its protocol: the synchronized start, a fixed length)
PAPER_T = (4e3, 16e3, 64e3)


def paper_points(runs: pd.DataFrame, means: dict) -> pd.DataFrame:
    """What the paper's stiff points are: per (N, phi >= 215, T), the window [0.2 T, T] of the
    synchronized start (its protocol) beside the states of the same layers: its mean stress and
    chi over the seeds, the long-run mean, each state's mean (blocks of every start after
    their transient), and the 99th percentile of a coherent block of the runs from the other
    starts (what the coherent state reaches). A window above that percentile, with chi above
    the memory threshold, is the synchronized start's transient, not a state of the layer."""
    rows = []
    for (n, phi), g in runs[runs.phi >= 215].groupby(["N", "phi"]):
        kept = pd.concat(list(g.blocks), ignore_index=True)
        quiet = kept.R < r_independent(n)
        others = pd.concat(list(g[g.start != "synchronized"].blocks), ignore_index=True)
        coh = others[others.R >= r_independent(n)].s
        for T in PAPER_T:
            vals, chis = [], []
            for _, r in g[g.start == "synchronized"].iterrows():
                k1 = int(round(T / BLOCK_T))
                b = r.whole.iloc[int(round(0.2 * k1)):k1]
                if len(b) < 1 or k1 > len(r.whole):
                    continue
                w = b.n.to_numpy(float)
                vals.append(float(np.average(b.s, weights=w)))
                chis.append(float(n * (np.average(b.R2abs, weights=w)
                                       - np.average(b.Zre, weights=w) ** 2
                                       - np.average(b.Zim, weights=w) ** 2)))
            if not vals:
                continue
            long_run = float(np.mean([means[(n, phi, s)]["stress"] for s in g.seed.unique()]))
            rows.append({"N": n, "phi": phi, "T": T, "seeds": len(vals),
                         "paper_mean": float(np.mean(vals)), "paper_chi": float(np.mean(chis)),
                         "long_run": long_run,
                         "quiet": float(kept.s[quiet].mean()) if quiet.any() else math.nan,
                         "coherent": float(kept.s[~quiet].mean()),
                         "coherent_p99": float(coh.quantile(0.99)) if len(coh) else math.nan,
                         "memory_chi": states.memory_chi(n)})
    return pd.DataFrame(rows)


def calibration(runs: pd.DataFrame, means: dict) -> dict:
    """The switching calibration that bkflow.observables.states reads
    (src/bkflow/model/switching.json)."""
    sizes = window_table(runs, means)
    occ = occupancy(runs)
    for n, size in sizes.items():
        size["quiet"] = [round(float(occ[(occ.N == int(n)) & (occ.phi == phi)].quiet.iloc[0]), 5)
                         for phi in size["phi"]]
    for n, worst in window_chi(runs).items():
        sizes[n]["memory_chi"] = round(CHI_MARGIN * worst, 2)
        sizes[n]["memory_chi_observed"] = round(worst, 3)
    # the words of the installed switching.json, which tests/test_results_blocks.py compares
    # whole with what the records give
    return {"comment": "written by benchmarks/report/stiff_states.py: the relative mean-square "
                       "deviation of window means from the layer's long-run mean "
                       "(bkflow.observables.states.window_variance), and the memory threshold "
                       "of chi",
            "transient": TRANSIENT, "block_t": BLOCK_T, "sizes": sizes}


def calibration_text(runs: pd.DataFrame, means: dict) -> str:
    return json.dumps(calibration(runs, means), indent=1) + "\n"


def curve_table(means: dict) -> pd.DataFrame:
    """The long-run curve from ``layer_means``: per (N, phi) the number of seeds, the mean over
    the seeds of each layer's long-run <sigma_x>/sigma_n and mu_bar, and their standard errors
    over the seeds (NaN with one seed)."""
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


def figure(root=OUT, out=stiff_states_figure.FIGURE) -> Path:
    """Draw and save the figure from the records in ``root``."""
    return stiff_states_figure.save(load(root), out)


def report(root=OUT) -> None:
    """Write the calibration and the long-run curve, print the tables, draw the figure."""
    runs = load(root)
    means = layer_means(runs)
    occ = occupancy(runs)
    CALIBRATION_FILE.write_text(calibration_text(runs, means))
    reread()
    print(f"wrote {CALIBRATION_FILE}")
    curve_table(means).to_csv(CURVE, index=False, float_format="%.10g")
    print(f"wrote {CURVE}")
    pd.set_option("display.width", 200)
    print(occ.round(5).to_string(index=False))
    lm = pd.DataFrame([{"N": k[0], "phi": k[1], "seed": k[2], **v} for k, v in means.items()])
    print(lm.round(5).to_string(index=False))
    print(coverage(runs, means).round(3).to_string(index=False))
    print(verdicts(runs, means).round(3).to_string(index=False))
    print(ergodicity(runs).to_string(index=False))
    print(paper_points(runs, means).round(5).to_string(index=False))
    print(f"wrote {stiff_states_figure.save(runs)}")


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--figure-only", action="store_true",
                    help="only the figure, benchmarks/stiff_states.png")
    a = ap.parse_args(argv)
    if a.figure_only:
        print(f"wrote {figure()}")
    else:
        report()


if __name__ == "__main__":
    main()
