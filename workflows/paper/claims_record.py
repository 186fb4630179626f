"""The claims' record: each claim's statistics computed from the sweeps' tables (``record``),
by the tests claims.py states; reproduce.py writes it to ``workflows/paper/claims.json``, and
claims.py renders the documents' verdicts and tables from that record."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
from claims import ALPHA, APPEARS, DECIDING, PAPER_ORDER, REGIMES, SHAPES, critical, power_quantile


def _f(v) -> float | None:
    """A JSON-safe float (None for NaN or infinity)."""
    v = float(v)
    return v if math.isfinite(v) else None


def standard_error(x) -> float:
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    return float(np.std(x, ddof=1) / math.sqrt(len(x))) if len(x) > 1 else math.nan


def minimum(phi, y, e, seeds: int) -> dict:
    """Where one curve is lowest, and whether that is an interior minimum below both ends by
    more than ``critical`` combined errors, corrected for having picked it from every interior
    phi (``critical_one``: the uncorrected value, for a reader who fixed the phi beforehand);
    ``dip80``: the depth below the less certain end that the test finds with 80% power."""
    order = np.argsort(phi)
    phi, y, e = (np.asarray(a, float)[order] for a in (phi, y, e))
    ok = np.isfinite(y)
    # an unknown error (one seed) is no evidence: infinite, so that nothing is significant
    phi, y, e = phi[ok], y[ok], np.where(np.isfinite(e[ok]), e[ok], np.inf)
    if len(y) < 3:
        return {}
    i = int(np.argmin(y))
    comb = [math.hypot(e[k], e[i]) for k in (0, len(y) - 1)]
    z = [(y[k] - y[i]) / c if c > 0 else math.inf for k, c in zip((0, len(y) - 1), comb)]
    interior = 0 < i < len(y) - 1
    crit = critical(seeds, looks=len(y) - 2)
    return {"phi": _f(phi[i]), "min": _f(y[i]), "sem": _f(e[i]), "lo": _f(y[0]),
            "hi": _f(y[-1]), "z_lo": _f(z[0]) if interior else None,
            "z_hi": _f(z[1]) if interior else None, "interior": interior,
            "looks": len(y) - 2, "critical": _f(crit), "critical_one": _f(critical(seeds)),
            "non_monotonic": bool(interior and min(z) > crit),
            "dip80": _f((crit + power_quantile(seeds))
                        * max(math.hypot(e[0], e[i]), math.hypot(e[-1], e[i])))}


def _per_seed(runs: pd.DataFrame, field: str) -> pd.DataFrame:
    """Per (N, phi): the mean of ``field`` over seeds, its standard error and the seeds."""
    g = runs.groupby(["N", "phi"])[field]
    return pd.DataFrame({"mean": g.mean(), "sem": g.apply(standard_error),
                         "seeds": g.count()}).reset_index()


def claim1(runs: pd.DataFrame, mu_s: float) -> dict:
    """Non-monotonic mu_bar per N, at 1% and at the size-scaled threshold, and the depth of
    every point below mu_s (which a "40% below mu_s" does not discriminate)."""
    out = {}
    for field in ("mu_bar", "mu_bar_scaled", "mu_bar_large"):
        if field not in runs or runs[field].isna().all():
            continue
        t = _per_seed(runs, field)
        per = {}
        for n, g in t.groupby("N"):
            m = minimum(g.phi, g["mean"], g["sem"], int(g.seeds.min()))
            if m:
                m["seeds"] = int(g.seeds.min())
                m["below_mu_s"] = _f(1 - m["min"] / mu_s)
                per[str(int(n))] = m
        out[field] = per
        # how far below mu_s every point of this reading lies (numbers.md's table, per point)
        depth = 1 - runs.groupby(["N", "phi"])[field].mean() / mu_s
        out.setdefault("below_mu_s_range", {})[field] = [_f(depth.min()), _f(depth.max())]
    mins = out.get("mu_bar", {})
    ns = sorted(mins, key=int)
    # deeper with N is a statement about a dip: undecided (None) where a curve has none
    dips = [n for n in ns if mins[n]["non_monotonic"]]
    out["deeper_with_N"] = None if len(dips) < 2 or len(dips) < len(ns) else bool(all(
        mins[a]["min"] - mins[b]["min"] > critical(min(mins[a]["seeds"], mins[b]["seeds"]))
        * math.hypot(mins[a]["sem"], mins[b]["sem"]) for a, b in zip(ns, ns[1:])))
    stiff = runs[runs.phi >= 46]
    out["stiff_states"] = {k: int(v) for k, v in stiff.state.value_counts().items()}
    return out


def claim2(runs: pd.DataFrame) -> dict:
    """Psi(inf) at the ends of each curve; at phi >= 100, the largest difference between sizes
    (against the paper's resolution, PSI_SAME) and the most significant one (against the
    critical value corrected for the stiff phi it was picked from)."""
    t = _per_seed(runs, "psi_inf")
    ends = {str(int(n)): [_f(g.sort_values("phi")["mean"].iloc[0]),
                          _f(g.sort_values("phi")["mean"].iloc[-1])]
            for n, g in t.groupby("N")}
    worst, below_lower = _spread_across_sizes(t)
    stiff = t[t.phi >= 100]
    # the largest difference was picked from every pair of sizes at every stiff phi
    pairs = math.comb(stiff.N.nunique(), 2) if len(stiff) else 0
    worst["critical"] = _f(critical(int(stiff.seeds.min()) if len(stiff) else 0,
                                    looks=stiff.phi.nunique() * max(1, pairs)))
    worst["significant"] = bool(worst["z"] is not None and worst["critical"] is not None
                                and worst["z"] > worst["critical"])
    return {"ends": ends, "stiff_size_spread": worst,
            "soft_smaller_at_larger_N": [int(sum(below_lower)), len(below_lower)]}


def _spread_across_sizes(t: pd.DataFrame) -> tuple[dict, list]:
    """Psi(inf)'s differences between sizes (``t``: per N and phi, _per_seed's): at phi >=
    100 the largest one and its phi, and the most significant one (in combined errors) and its
    phi; below phi = 100, per phi whether the smallest N lies above the largest."""
    worst = {"z": None, "diff": None, "phi": None, "z_at": None}
    below_lower = []
    for phi, g in t.groupby("phi"):
        g = g.sort_values("N")
        if len(g) < 2:
            continue
        m, e = g["mean"].to_numpy(), g["sem"].to_numpy()
        i, j = int(np.argmax(m)), int(np.argmin(m))
        d = m[i] - m[j]
        z = d / math.hypot(e[i], e[j]) if math.hypot(e[i], e[j]) > 0 else math.inf
        if phi >= 100 and (worst["diff"] is None or d > worst["diff"]):
            worst.update(diff=_f(d), phi=_f(phi))
        if phi >= 100 and math.isfinite(z) and (worst["z"] is None or z > worst["z"]):
            worst.update(z=_f(z), z_at=_f(phi))
        if phi < 100:
            below_lower.append(bool(m[0] > m[-1]))
    return worst, below_lower


def claim3(res: pd.DataFrame) -> dict:
    out = {}
    for n, g in res.groupby("N"):
        g = g.reset_index(drop=True)

        def arg(f, fn, g=g):
            v = g[f]
            return _f(g.phi[getattr(v, fn)()]) if f in g and v.notna().any() else None
        ends = (_f(g.phi.min()), _f(g.phi.max()))
        out[str(int(n))] = {"interior": arg("lx_over_ly", "idxmax") not in ends
                            and arg("mu_bar", "idxmin") not in ends,
                            "lx_over_ly_max": arg("lx_over_ly", "idxmax"),
                            "mu_bar_min": arg("mu_bar", "idxmin"),
                            "mu_bar_large_max": arg("mu_bar_large", "idxmax"),
                            "lx_over_ly_peak": _f(g.lx_over_ly.max())}
    return out


def cluster_share(runs: pd.DataFrame, regime: str, large: bool = False) -> float:
    """The share of all slip clusters of ``runs`` that the regime rule calls ``regime``:
    each run's fraction weighted by its clusters (NaN without clusters)."""
    w = runs["n_clusters_large" if large else "n_clusters"].to_numpy(float)
    col = f"regime_fractions{'_large' if large else ''}[{regime}]"
    if col not in runs or not np.nansum(w) > 0:
        return math.nan
    return float(np.nansum(runs[col].to_numpy(float) * w) / np.nansum(w))


def claim4(runs: pd.DataFrame) -> dict:
    r = runs[(runs.Lx == 20) & (runs.Ly == 5)]
    shares = {f"{phi:g}": {k: _f(cluster_share(g, k)) for k in REGIMES}
              | {"clusters": int(g.n_clusters.sum())} for phi, g in r.groupby("phi")}
    appear = [k for k in REGIMES if any((s[k] or 0) >= APPEARS for s in shares.values())]
    peak = {k: float(max(shares, key=lambda p: shares[p][k] or 0)) for k in appear}
    seen = [k for k in PAPER_ORDER if k in peak]
    # strictly: two regimes most frequent at the same phi show no order between them
    pairs = [bool(peak[a] < peak[b]) for a, b in zip(seen, seen[1:])]
    in_order = len(seen) == len(PAPER_ORDER) and all(pairs)
    return {"shares": shares, "appear": appear, "peak_phi": peak, "paper_order_kept": in_order,
            "pairs_in_order": [int(sum(pairs)), len(pairs)]}


def claim5(runs: pd.DataFrame, sizes) -> dict:
    out = {}
    for lx, ly in sizes:
        s = runs[(runs.Lx == lx) & (runs.Ly == ly)]
        if not len(s):
            continue
        per_seed = [cluster_share(g, "DT") for _, g in s.groupby("seed")]
        share = cluster_share(s, "DT")
        crit = critical(len(per_seed))
        out[f"{lx}x{ly}"] = {"N": lx * ly, "clusters": int(s.n_clusters.sum()),
                             "DT": _f(share), "DT_sem": _f(standard_error(per_seed)),
                             "seeds": len(per_seed),
                             "W": _f(cluster_share(s, "W")),
                             "critical": _f(crit),
                             "upper": _f(share + crit * standard_error(per_seed))}
    return out


def shape_class(l_x, l_y, lx: int, ly: int) -> np.ndarray:
    """The class (``SHAPES``) of clusters of extents l_x, l_y on an lx x ly box: their regime
    (``bkflow.observables.clusters.regime`` of their box fractions, as claims 4 and 5 count
    them), C and W as "whole"."""
    from bkflow.model.lattice import box_fractions
    from bkflow.observables.clusters import regime

    fx, fy = box_fractions(l_x, l_y, (lx, ly))
    label = np.asarray(regime(np.atleast_1d(fx), np.atleast_1d(fy), math.nan), dtype=object)
    return np.where(label == "W", "whole", label)


def rectangle_extents(a: int, b: int, lx: int, ly: int) -> tuple[float, float]:
    """l_x and l_y (docs/model.md) of the a x b rectangle of sites on an lx x ly box."""
    from bkflow.observables.clusters import extent

    cols, rows = np.meshgrid(np.arange(a, dtype=float), np.arange(b, dtype=float))
    return extent(cols.ravel(), lx), extent(rows.ravel(), ly)


def cheapest_shape(n_c, delta, lx: int, ly: int) -> np.ndarray:
    """The class (``shape_class``) of the rectangle that holds n_c sites, a <= n_c columns by
    ceil(n_c / a) rows inside the box, whose Eq. 2 energy (k_b set to 1: it scales every
    shape alike) is lowest at mean slip delta: what the paper's energy argument predicts,
    classified by the rectangle's own extents as an observed cluster is by its."""
    from bkflow.observables.catalogue import eq2_estimate

    n_c, delta = np.asarray(n_c, float), np.asarray(delta, float)
    a = np.arange(1, lx + 1, dtype=float)[None, :]
    b = np.ceil(n_c[:, None] / a)
    e = eq2_estimate(1.0, np.broadcast_to(a, b.shape), b, delta[:, None], lx, ly)
    e = np.where((b <= ly) & (a <= n_c[:, None]), e, np.inf)   # every column holds a site
    k = np.argmin(e, axis=1)   # ties: the fewest columns
    rows = np.arange(len(n_c))
    aa, bb = a[0, k].astype(int), b[rows, k].astype(int)
    table = {}
    for key in set(zip(aa.tolist(), bb.tolist())):
        ex = rectangle_extents(*key, lx, ly)
        table[key] = shape_class([ex[0]], [ex[1]], lx, ly)[0] if key[0] * key[1] > 1 \
            else "DP"   # one site: no extent; the smallest patch
    return np.array([table[key] for key in zip(aa.tolist(), bb.tolist())], dtype=object)


def kappa(a, b) -> float:
    """Cohen's kappa of two classifications of the same items: their agreement beyond what
    their class frequencies give by chance, (p_o - p_e) / (1 - p_e); 1 when they agree on
    every item, 0 when no more than chance (NaN when chance alone makes them agree)."""
    a, b = np.asarray(a), np.asarray(b)
    if not len(a):
        return math.nan
    p_o = float(np.mean(a == b))
    p_e = float(sum(np.mean(a == k) * np.mean(b == k) for k in np.union1d(a, b)))
    return (p_o - p_e) / (1 - p_e) if p_e < 1 else math.nan


def claim6(clusters: pd.DataFrame) -> dict:
    """Per N and phi, the share of clusters whose shape is Eq. 2's cheapest for their size and
    slip, and the shares of each observed and predicted shape; clusters of the whole layer
    (n_c = N) are left out, since no other shape holds them."""
    out = {}
    clusters = clusters[clusters.n_c < clusters.N]   # a whole layer has no other shape
    for n, g in clusters.groupby("N"):
        lx, ly = int(g.Lx.iloc[0]), int(g.Ly.iloc[0])
        seen = shape_class(g.l_x, g.l_y, lx, ly)
        best = cheapest_shape(g.n_c, np.abs(g.slip), lx, ly)
        per = {}
        for phi in sorted(g.phi.unique()):
            m = (g.phi == phi).to_numpy()
            per[f"{phi:g}"] = {"clusters": int(m.sum()),
                               "cheapest": _f(np.mean(seen[m] == best[m])),
                               **{f"seen_{k}": _f(np.mean(seen[m] == k)) for k in SHAPES},
                               **{f"predicted_{k}": _f(np.mean(best[m] == k))
                                  for k in SHAPES}}
        # a shape the clusters take (APPEARS of them at some phi) that Eq. 2 never predicts
        never = [k for k in SHAPES
                 if max(v[f"seen_{k}"] or 0 for v in per.values()) >= APPEARS
                 and not any(v[f"predicted_{k}"] for v in per.values())]
        out[str(int(n))] = {"lattice": f"{lx}x{ly}", "clusters": int(len(g)),
                            "cheapest": _f(np.mean(seen == best)),
                            "kappa": _f(kappa(seen, best)), "never_predicted": never,
                            "per_phi": per}
    return out


def claim7(runs: pd.DataFrame) -> dict:
    v = runs.drop_power_law.value_counts()
    e = runs.drop_exponent[np.isfinite(runs.drop_exponent)]
    # Vuong's test: R < 0 favours the lognormal, significant at p < 0.1 (bkflow.observables.stress)
    lognormal = (runs.drop_vs_lognormal < 0) & (runs.drop_vs_lognormal_p < 0.1)
    return {"runs": int(len(runs)), **{k: int(v.get(k, 0)) for k in
                                       ("rejected", "plausible", "no fit")},
            "lognormal_favoured": int(lognormal.sum()),
            "exponent_range": [_f(e.min()), _f(e.max())] if len(e) else [None, None]}


#: the curve the paper's first-order scheme is compared with: the same protocol, length and
#: time step, integrated to second order
SECOND_ORDER, FIRST_ORDER = "paper, t_end = 16000", "paper, first-order scheme, t_end = 16000"


def scheme_bias(second: pd.DataFrame, first: pd.DataFrame) -> dict:
    """Does the paper's literal first-order scheme explain any of its non-monotonic curve?
    Per N: mu_bar of each scheme per phi (means and errors over seeds), their difference in
    combined errors, and each curve's dip test (``minimum``)."""
    out = {}
    a, b = _per_seed(second, "mu_bar"), _per_seed(first, "mu_bar")
    both = a.merge(b, on=["N", "phi"], suffixes=("_2", "_1"))
    for n, g in both.groupby("N"):
        g = g.sort_values("phi")
        diff = (g.mean_1 - g.mean_2).to_numpy()
        comb = np.hypot(g.sem_1, g.sem_2).to_numpy()
        seeds = int(min(g.seeds_1.min(), g.seeds_2.min()))
        out[str(int(n))] = {
            "phi": [_f(p) for p in g.phi], "second": [_f(v) for v in g.mean_2],
            "second_sem": [_f(v) for v in g.sem_2], "first": [_f(v) for v in g.mean_1],
            "first_sem": [_f(v) for v in g.sem_1],
            "z": [_f(d / c) if c > 0 else None for d, c in zip(diff, comb)],
            "critical": _f(critical(seeds, looks=len(g))),
            "dip_second": minimum(g.phi, g.mean_2, g.sem_2, seeds),
            "dip_first": minimum(g.phi, g.mean_1, g.sem_1, seeds)}
    return out


#: the steady curves the size trend is read on: the paper's sizes and the larger lattice
SIZE_CURVES = ("steady protocol", "steady protocol, N = 3600")


def size_trend(runs: pd.DataFrame, field: str = "mu_bar") -> dict:
    """How ``field`` of the steady state moves with N at each phi every size was run at: per
    N its mean over seeds and standard error, and the slope of the mean against log10 N
    (weighted least squares, the weights 1/sem^2, its error from those weights) with the
    slope's z against the critical value corrected for the phi tested; and per phi the
    quiet share of the runs' analysed windows (``quiet_share``) where recorded."""
    t = _per_seed(runs, field)
    common = sorted(set.intersection(*[set(g.phi) for _, g in t.groupby("N")]))
    out = {"phi": {}, "sizes": sorted(int(n) for n in t.N.unique())}
    looks = len(common)
    for phi in common:
        g = t[np.isclose(t.phi, phi)].sort_values("N")
        out["phi"][f"{phi:g}"] = _trend_at(g, looks)
    return out


def _trend_at(g: pd.DataFrame, looks: int) -> dict:
    """size_trend at one phi: ``g`` its means per N (_per_seed's, in order of N), ``looks``
    the phi tested."""
    x, y, e = np.log10(g.N.to_numpy(float)), g["mean"].to_numpy(), g["sem"].to_numpy()
    # the slope from the sizes with at least 3 seeds (an error over 2 seeds is one
    # difference: a t with one degree of freedom would decide nothing); the others shown
    ok = np.isfinite(e) & (e > 0) & (g.seeds.to_numpy() >= 3)
    slope, err, z = _weighted_slope(x[ok], y[ok], e[ok])
    seeds = int(g.seeds[ok].min()) if ok.any() else 0
    return {
        "fitted": [int(n) for n in g.N[ok]],
        "N": [int(n) for n in g.N], "mean": [_f(v) for v in y], "sem": [_f(v) for v in e],
        "seeds": [int(v) for v in g.seeds], "slope_per_decade": _f(slope) if slope is not None
        else None, "slope_err": _f(err) if err is not None else None,
        "z": _f(z) if z is not None else None,
        "critical": _f(critical(seeds, looks)),
        "falls": bool(z is not None and -z > critical(seeds, looks)),
        "rises": bool(z is not None and z > critical(seeds, looks)),
        "found80": _f((critical(seeds, looks) + power_quantile(seeds)) * err)
        if err is not None else None}


def _weighted_slope(x, y, e) -> tuple:
    """The slope of y against x by weighted least squares (the weights 1/e^2), its error from
    those weights, and its z: (None, None, None) with fewer than two points."""
    if len(x) < 2:
        return None, None, None
    w = 1 / e ** 2
    xm = np.sum(w * x) / np.sum(w)
    sxx = np.sum(w * (x - xm) ** 2)
    slope = float(np.sum(w * (x - xm) * y) / sxx)
    err = float(1 / math.sqrt(sxx))
    return slope, err, slope / err


def clusters_of(sweep_dir: Path, runs: pd.DataFrame) -> pd.DataFrame | None:
    """Every slip cluster of ``runs`` (Run.read_clusters), with its run's phi, Lx, Ly, N, seed."""
    from bkflow.store.rundir import sweep_run_dir

    parts = []
    for _, r in runs.iterrows():
        c = sweep_run_dir(sweep_dir, r.job).read_clusters()
        if c is not None and len(c):
            parts.append(c.assign(phi=r.phi, Lx=int(r.Lx), Ly=int(r.Ly), N=int(r.N),
                                  seed=int(r.seed)))
    return pd.concat(parts, ignore_index=True) if parts else None


def record(curves: dict, dirs: dict, aspect=None, aspect_sizes=(), provenance=None) -> dict:
    """The claims record: ``curves`` label -> (runs, results), ``dirs`` label -> the sweep's
    directory, ``aspect`` the aspect sweep's (runs, directory)."""
    rec = {"alpha": ALPHA, "deciding": list(DECIDING), "curves": {}, "provenance": provenance or {}}
    for label in DECIDING:
        if label not in curves:
            continue
        runs, res = curves[label]
        mu_s = float(runs.mu_s.iloc[0])
        c = {"runs": int(len(runs)), "seeds": int(runs.seed.nunique()),
             "states": {k: int(v) for k, v in runs.state.value_counts().items()},
             "claim1": claim1(runs, mu_s), "claim2": claim2(runs), "claim3": claim3(res),
             "claim4": claim4(runs), "claim7": claim7(runs)}
        cl = clusters_of(dirs[label], runs)
        if cl is not None:
            c["claim6"] = claim6(cl)
        rec["curves"][label] = c
    if aspect is not None:
        rec["claim5"] = claim5(aspect[0], aspect_sizes)
    steady = [curves[k][0] for k in SIZE_CURVES if k in curves]
    if steady:
        rec["sizes"] = size_trend(pd.concat(steady, ignore_index=True))
    if SECOND_ORDER in curves and FIRST_ORDER in curves:
        rec["scheme"] = scheme_bias(curves[SECOND_ORDER][0], curves[FIRST_ORDER][0])
    return rec

