"""Claim 6, the paper's energy argument, measured (``energy_argument``): per slip cluster its
shape and the change of the bonds' energy against Eq. 2, and where transverse slips overtake
row slips against where Eq. 2 places it; its tables in numbers.md (``energy_numbers``) and its
figure (``energy_figure``)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
from claims import SHAPES
from claims_record import shape_class
from paper_figures import write_figure
from paper_sweeps import CURVES, sweep_tables

from bkflow.figures.style import new_figures
from bkflow.store.rundir import sweep_run_dir

#: the curves the energy argument is measured on (claim 6): both protocols, every N
ENERGY_CURVES = ("paper, t_end = 16000", "steady protocol")


def slip_threshold(lx: int, ly: int) -> float:
    """The mean slip delta above which Eq. 2 makes a transverse slip (one column spanning y:
    n_x = 1, n_y = Ly) cheaper than a row slip (one row spanning x: n_x = Lx, n_y = 1):
    Lx ((delta^2 + 1)^(1/2) - 1)^2 = Ly delta^2, delta* = 2a / (1 - a^2) with a = (Ly/Lx)^(1/2)
    (l = 1; infinite when Lx <= Ly: rows are then never cheaper)."""
    a = math.sqrt(ly / lx)
    return 2 * a / (1 - a * a) if a < 1 else math.inf


def cluster_rows(out: Path, label: str) -> pd.DataFrame | None:
    """Every slip cluster after the transient of one curve's runs (RunDir.read_clusters), with
    the run's phi, Lx, Ly, N and seed, and its shape: claims.py's class (its regime from its
    extents, as claims 4, 5 and 6 count it; C and W one class, "whole")."""
    name, where = CURVES[label]
    t = sweep_tables(out, name, where)
    if t is None:
        return None
    parts = []
    for _, r in t[0].iterrows():
        # clusters.csv, or the run's reduced record of them (the default scene keeps that)
        c = sweep_run_dir(out / name, r.job).read_clusters()
        if c is None or "eq2_estimate" not in c or not len(c):
            continue
        c = c.assign(phi=r.phi, Lx=int(r.Lx), Ly=int(r.Ly), N=int(r.N), seed=int(r.seed))
        parts.append(c)
    if not parts:
        return None
    c = pd.concat(parts, ignore_index=True)
    c["shape"] = ""
    for (lx, ly), k in c.groupby(["Lx", "Ly"]).groups.items():
        c.loc[k, "shape"] = shape_class(c.l_x[k], c.l_y[k], int(lx), int(ly))
    return c


def _log_crossing(phi, a, b) -> float:
    """The phi (interpolated in log phi) where a - b changes sign going down in phi from its
    largest value (a > b at the top), NaN when it never does."""
    order_ = np.argsort(phi)[::-1]
    x, d = np.log10(np.asarray(phi, float)[order_]), (np.asarray(a) - np.asarray(b))[order_]
    for k in range(1, len(x)):
        if d[k - 1] > 0 >= d[k]:
            return float(10 ** (x[k - 1] + (x[k] - x[k - 1]) * d[k - 1] / (d[k - 1] - d[k])))
    return math.nan


def energy_argument(out: Path) -> dict:
    """Claim 6 measured, per curve of ENERGY_CURVES and N: per phi the clusters' shapes, their
    mean slip, and the bond energy change of the bonds touching each cluster against Eq. 2;
    where transverse slips overtake row slips, and where Eq. 2 places it (the median slip of
    the clusters reaching delta*)."""
    from scipy.stats import spearmanr

    found = {}
    for label in ENERGY_CURVES:
        c = cluster_rows(out, label)
        if c is None:
            continue
        for n, g in c.groupby("N"):
            lx, ly = int(g.Lx.iloc[0]), int(g.Ly.iloc[0])
            per = []
            for phi, h in g.groupby("phi"):
                e = h[h.eq2_estimate > 0]
                per.append({"phi": phi, "clusters": len(h),
                            **{k: float((h["shape"] == k).mean()) for k in SHAPES},
                            "slip_median": float(h.slip.median()),
                            "with_perimeter": len(e),
                            "ratio_median": float((e.bond_change / e.eq2_estimate).median())
                            if len(e) else math.nan})
            per = pd.DataFrame(per)
            e = g[g.eq2_estimate > 0]
            rho = spearmanr(e.bond_change, e.eq2_estimate) if len(e) > 2 else None
            found[label, n] = {
                "lattice": f"{lx}x{ly}", "per_phi": per, "clusters": len(g),
                "with_perimeter": len(e),
                "spearman": (float(rho.statistic), float(rho.pvalue)) if rho else
                (math.nan, math.nan),
                "ratio_median": float((e.bond_change / e.eq2_estimate).median())
                if len(e) else math.nan,
                "ratio_iqr": tuple(float(q) for q in np.quantile(
                    e.bond_change / e.eq2_estimate, [0.25, 0.75])) if len(e) else
                (math.nan, math.nan),
                "negative": float((e.bond_change < 0).mean()) if len(e) else math.nan,
                "delta_star": slip_threshold(lx, ly),
                "crossover_observed": _log_crossing(per.phi, per.LC, per.DT),
                "crossover_argument": _log_crossing(per.phi, slip_threshold(lx, ly),
                                                    per.slip_median),
                "clusters_table": g}
    return found


def energy_numbers(found: dict) -> list[str]:
    lines = ["", "## The energy argument (claim 6)", "",
             "Per slip cluster after the transient (clusters.csv): `bond_change`, the energy of "
             "the bonds touching the cluster at the slip's minimum minus at its maximum, against "
             "Eq. 2 from the cluster's columns n_x, rows n_y and mean slip delta (clusters "
             "spanning both axes have no perimeter: Eq. 2 = 0, left out of the ratio). Shapes: "
             "the clusters' regimes (claims 4 and 6 count them alike): whole (C or W), LC "
             "(spans x, not y), DP and DT (x not spanned; f_x >= f_y, f_x < f_y). Crossovers: "
             "the phi (log-interpolated) below which DT clusters outnumber LC clusters "
             "(observed) and below which the clusters' median slip exceeds delta*, where Eq. 2 "
             "makes one transverse column cheaper than one row (the argument).", "",
             "| curve | N | clusters | with a perimeter | bond change / Eq. 2 (median, IQR) | "
             "bond change < 0 | Spearman rho (p) | delta* | crossover observed | "
             "crossover by Eq. 2 |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for (label, n), f in found.items():
        lo, hi = f["ratio_iqr"]
        rho, p = f["spearman"]
        lines.append(f"| {label} | {n} | {f['clusters']} | {f['with_perimeter']} | "
                     f"{f['ratio_median']:.3g} ({lo:.3g} - {hi:.3g}) | "
                     f"{100 * f['negative']:.0f}% | {rho:.2f} ({p:.1e}) | "
                     f"{f['delta_star']:.2f} | {f['crossover_observed']:.3g} | "
                     f"{f['crossover_argument']:.3g} |")
    for (label, n), f in found.items():
        if n != 100:
            continue
        lines += ["", f"{label}, N = 100: per phi", "",
                  "| phi | clusters | whole | LC | DP | DT | median slip | "
                  "bond change / Eq. 2 |", "|---|---|---|---|---|---|---|---|"]
        for r in f["per_phi"].itertuples():
            lines.append(f"| {r.phi:g} | {r.clusters} | {r.whole:.2f} | {r.LC:.2f} | "
                         f"{r.DP:.2f} | {r.DT:.2f} | {r.slip_median:.3g} | "
                         f"{r.ratio_median:.3g} |")
    return lines


#: the energy figure's shapes: colour (Okabe and Ito's palette), marker and words
SHAPE_STYLE = {"LC": ("#0072B2", "o", "LC (spans x, not y)"),
               "DT": ("#D55E00", "s", r"DT (x not spanned, $f_x < f_y$)")}
#: the energy figure's curves: line style
ENERGY_LINES = {"steady protocol": "-", "paper, t_end = 16000": ":"}


def _log_limits(*arrays) -> tuple[float, float]:
    """Decade limits that hold every positive value of ``arrays``."""
    v = np.concatenate([np.asarray(a, float) for a in arrays])
    v = v[np.isfinite(v) & (v > 0)]
    if not len(v):
        return 1e-6, 1e3
    return 10.0 ** math.floor(math.log10(v.min())), 10.0 ** math.ceil(math.log10(v.max()))


def energy_figure(found: dict, figs: Path) -> Path | None:
    """Claim 6: (a) each cluster's bond energy change against Eq. 2, coloured by phi, every
    cluster with a perimeter: those whose bond energy rose above, those whose bond energy fell
    below (the size of the fall, on the same log axes), so that none is left off a log axis;
    what has no place on either (no perimeter: Eq. 2 = 0; no change) is counted in the
    figure. (b) the share of LC and DT clusters (claims 4 and 6's classes) against phi at
    N = 100 under both protocols; (c) their median slip over delta*, the slip above which
    Eq. 2 makes a transverse slip cheaper than a row (the argument's crossover at 1)."""
    if not found:
        return None
    plt = new_figures()
    fig = plt.figure(figsize=(8.6, 6.0))
    grid = fig.add_gridspec(2, 2, width_ratios=(1.15, 1))
    up = fig.add_subplot(grid[0, 0])
    down = fig.add_subplot(grid[1, 0], sharex=up)
    share = fig.add_subplot(grid[0, 1])
    slip = fig.add_subplot(grid[1, 1], sharex=share)
    g = pd.concat([f["clusters_table"] for f in found.values()], ignore_index=True)
    e = g[g.eq2_estimate > 0]
    rose, fell = e[e.bond_change > 0], e[e.bond_change < 0]
    n_zero = len(e) - len(rose) - len(fell)
    lim = _log_limits(e.eq2_estimate, rose.bond_change, -fell.bond_change)
    norm = matplotlib_lognorm(0.1, 1000.0)
    # the densest phi lowest is not needed: the colour is phi, each point translucent
    for ax, part, y in ((up, rose, rose.bond_change), (down, fell, -fell.bond_change)):
        sc = ax.scatter(part.eq2_estimate, y, c=part.phi, norm=norm, cmap="viridis", s=2,
                        marker="o", alpha=0.5, lw=0, rasterized=True)
        ax.plot(lim, lim, "k--", lw=0.8)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(*lim)
        ax.set_ylim(*lim)
    up.tick_params(labelbottom=False)
    up.set_ylabel(r"bond energy rose by ($k_d l^2$)")
    down.set_ylabel(r"bond energy fell by ($k_d l^2$)")
    down.set_xlabel(r"Eq. 2 from $n_x$, $n_y$, $\delta$ ($k_d l^2$)")
    per = 100 / max(len(e), 1)
    up.set_title(f"(a) the bond energy rose: {len(rose)} clusters, {per * len(rose):.0f}% of "
                 f"the {len(e)}\nwith a perimeter; dashed: measured = Eq. 2", fontsize=7.5)
    down.set_title(f"the bond energy fell: {len(fell)} clusters ({per * len(fell):.0f}%), "
                   "where Eq. 2 only adds", fontsize=7.5)
    left = len(g) - len(e)
    # inside the axes, below the points: what no log axis can hold, and why
    down.text(0.02, 0.98, f"not drawn: {left} of all {len(g)} clusters "
              f"({100 * left / max(len(g), 1):.0f}%),\nwhich span both axes: no perimeter, "
              "Eq. 2 = 0" + (f"; {n_zero} changed by exactly 0" if n_zero else "")
              + "\n(both protocols' clusters, every N)", transform=down.transAxes,
              fontsize=7, va="top", ha="left")
    cb = fig.colorbar(sc, ax=[up, down], aspect=60, fraction=0.05, pad=0.01)
    cb.set_label(r"$\phi$")
    for (label, n), f in found.items():
        if n != 100:
            continue
        per = f["per_phi"]
        ls = ENERGY_LINES.get(label, "-")
        for shape, (colour, marker, _) in SHAPE_STYLE.items():
            share.plot(per.phi, per[shape], ls=ls, marker=marker, ms=3.5, color=colour, lw=1.1)
        slip.plot(per.phi, per.slip_median / f["delta_star"], ls=ls, marker="o", ms=3,
                  color="0.25", lw=1.0)
    slip.axhline(1.0, color="0.5", lw=0.8, ls="--")
    slip.text(0.98, 0.95, "above 1, Eq. 2 makes a transverse slip cheaper than a row",
              transform=slip.transAxes, ha="right", va="top", fontsize=7, color="0.3")
    share.set_xscale("log")
    slip.set_yscale("log")
    share.tick_params(labelbottom=False)
    slip.set_xlabel(r"$\phi$")
    share.set_ylabel("share of the clusters")
    slip.set_ylabel(r"median slip / $\delta^*$")
    share.set_title("(b) N = 100 (20x5): the share of every cluster in a regime (claim 4's)",
                    fontsize=7.5)
    slip.set_title(r"(c) N = 100: the clusters' median slip over $\delta^*$ (Eq. 2's "
                   "crossover)", fontsize=7.5)
    slip.set_ylim(top=max(2.0, slip.get_ylim()[1]))
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], color=c, marker=m, ms=3.5, ls="none")
               for c, m, _ in SHAPE_STYLE.values()]
    labels = [w for *_, w in SHAPE_STYLE.values()]
    for label, ls in ENERGY_LINES.items():
        if any(lab == label for lab, _ in found):
            handles.append(Line2D([], [], color="0.25", ls=ls, lw=1.1))
            labels.append(label.replace("paper, t_end = 16000",
                                        "paper's protocol, t_end = 16000"))
    fig.legend(handles, labels, loc="outside lower center", ncol=4, frameon=False,
               fontsize=7)
    return write_figure(fig, figs / "energy_argument.png")


def matplotlib_lognorm(lo: float, hi: float):
    from matplotlib.colors import LogNorm

    return LogNorm(lo, hi)


