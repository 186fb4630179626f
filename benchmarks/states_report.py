"""What the long runs of benchmarks/stiff_states.py say: the states, their occupancy and
residence times, the long-run means, the switching calibration (src/bkflow/switching.json)
and the coverage of the error that uses it. ``python benchmarks/stiff_states.py report``.

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

from bkflow import states
from bkflow.states import BLOCK_T, CALIBRATION, r_independent

#: the share of each run left out as the start's transient
TRANSIENT = 0.2
WINDOWS = (2e3, 5e3, 1e4, 2e4, 5e4, 1e5, 2e5, 5e5)
NAME = re.compile(r"N(\d+)_phi([\d.]+)_(\w+?)_s(\d+)_C([\d.]+)\.parquet$")


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
                     "C": float(c), "t": float(rec.t1.iloc[-1]), "blocks": keep})
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
    every W / 4: bkflow.states.slide)."""
    k = max(1, int(round(W / BLOCK_T)))
    stress = states.slide(b.s, k)
    with np.errstate(invalid="ignore", divide="ignore"):
        mu = states.slide(b["sfail_0.01"], k) / states.slide(b["nslip_0.01"], k)
    return stress, mu


def window_table(runs: pd.DataFrame, means: dict, exclude_seed=None) -> dict:
    """{N: {"phi": [...], "windows": [...], "stress": [[...]], "mu_bar": [[...]]}}: the
    relative mean-square deviation of window means from the layer's long-run mean
    (bkflow.states.calibrate), the layers of a seed left out with ``exclude_seed``."""
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
            cal = states.calibrate(layers, WINDOWS, BLOCK_T)
            entry.update(phi=cal["phi"], windows=cal["windows"])
            entry[name] = cal["table"]
        out[str(n)] = entry
    return out


def coverage(runs: pd.DataFrame, means: dict) -> pd.DataFrame:
    """Leave-one-seed-out coverage of mean +- 1.96 sqrt(V) mean, per (N, phi, W)."""
    from bkflow import states

    rows = []
    seeds = sorted(runs.seed.unique())
    for seed in seeds:
        table = {"sizes": window_table(runs, means, exclude_seed=seed)}
        states.calibration.cache_clear()
        original = states.calibration
        states.calibration = lambda table=table: table  # noqa: E731
        try:
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
        finally:
            states.calibration = original
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


def report(root) -> None:
    runs = load(root)
    means = layer_means(runs)
    sizes = window_table(runs, means)
    occ = occupancy(runs)
    for n, size in sizes.items():
        size["quiet"] = [round(float(occ[(occ.N == int(n)) & (occ.phi == phi)].quiet.iloc[0]), 5)
                         for phi in size["phi"]]
    for n, worst in window_chi(runs).items():
        sizes[n]["memory_chi"] = round(CHI_MARGIN * worst, 2)
        sizes[n]["memory_chi_observed"] = round(worst, 3)
    table = {"comment": "written by benchmarks/stiff_states.py report: the relative mean-square "
                        "deviation of window means from the layer's long-run mean "
                        "(bkflow.states.window_variance), and the memory threshold of chi",
             "transient": TRANSIENT, "block_t": BLOCK_T, "sizes": sizes}
    CALIBRATION.write_text(json.dumps(table, indent=1) + "\n")
    print(f"wrote {CALIBRATION}")
    pd.set_option("display.width", 200)
    print(occ.round(5).to_string(index=False))
    lm = pd.DataFrame([{"N": k[0], "phi": k[1], "seed": k[2], **v} for k, v in means.items()])
    print(lm.round(5).to_string(index=False))
    print(coverage(runs, means).round(3).to_string(index=False))
