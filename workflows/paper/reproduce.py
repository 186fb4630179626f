"""Reproduce the paper's claims with one command, under its protocol and in the steady state.

    python workflows/paper/reproduce.py [--out runs/paper] [--jobs J] [--seeds 3]
        [--protocols paper,steady,steady_3600,sync_steady,aspect] [--figures DIR]
        [--numbers FILE]

Every sweep uses the default time step (the default accuracy preset's) and the default scene,
seeds 1..3, 13 phi from 1e-1 to 1e3 (3 per decade) unless said otherwise; each goes into OUT/<name>:

paper        the paper's protocol (bkflow run --protocol paper): the synchronized start
             (every contact formed at t = 0) run for a finite length, t_end = 1000, 4000 and
             16000, at N = 100, 400, 900 (20x5, 40x10, 60x15): how the curves move with run
             length, and which of their points are metastable.
steady       the steady protocol (bkflow run, the default): each run from the random start
             beside its companion from the partial start, until both are steady and agree
             within 0.5%, capped at the default preset's cap (the main command's), at N = 100,
             400, 900 (--sizes: which of them; at N = 100 the README's sweep).
steady_3600  the same at N = 3600 (120x30), beyond the paper, one phi per decade, 2 seeds,
             capped at 16000.
sync_steady  the synchronized start beside its partial companion until steady (cap 64000) at
             N = 100, phi = 10, 100, 1000: does the paper's start reach the same steady state?
aspect       the aspect-ratio check ("with Lx <= Ly the DT regime does not appear"): N = 100
             on 20x5, 10x10 and 5x20, and N = 400 on 40x10, 20x20 and 10x40 (every side
             even), the paper's protocol, t_end = 8000.

Then the figures (``bkflow plot`` of each protocol, and the comparisons below) as PNG into
workflows/paper/figures/, and workflows/paper/numbers.md: every number REPRODUCTION.md cites,
computed from the sweeps' tables. Finished runs are never redone: re-running resumes, and a
changed analysis re-analyses without running LAMMPS.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from bkflow import io
from bkflow.clusters import box_fractions
from bkflow.grid import phi_values, sweep_specs
from bkflow.params import PAPER_SIZES, AnalysisSettings, RunSpec, protocol_fields
from bkflow.plot import STATE_FILL, STYLE, SweepData, _style, cluster_scatter, plot, state_handles
from bkflow.rundir import sweep_run_dir
from bkflow.sweep import available_cores, fmt_duration, sweep
from bkflow.tables import SETTINGS_FILE, read_tables

HERE = Path(__file__).resolve().parent
PHI = "1e-1:1e3"
#: the aspect-ratio check: N = 100 as the paper, and N = 400 with every side even (an odd
#: side's whole-box extent is shorter, so claim 5 is also decided where parity plays no part)
ASPECT_SIZES = [(20, 5), (10, 10), (5, 20), (40, 10), (20, 20), (10, 40)]
#: the paper's protocol: the synchronized start run for a finite length, at three lengths
PAPER_LENGTHS = (1000.0, 4000.0, 16000.0)
#: the steady protocol as the main command runs it (bkflow sweep's default cap: the stiff
#: layers' pairs that have not agreed by then end metastable, with the bracket of their two
#: starts); at N = 100 these are the very runs of the README's `bkflow sweep --phi 1e-1:1e3`
STEADY_CAP = protocol_fields("steady")["t_end"]
#: beyond the paper: N = 3600 in the steady state, one phi per decade, a shorter cap
LARGE_SIZE, LARGE_PHI, LARGE_CAP = (120, 30), "1e-1,1,10,100,1e3", 16000.0
#: the synchronized start beside its companion until steady, on a few points: does the
#: paper's start reach the same steady state?
SYNC_STEADY_PHI, SYNC_STEADY_CAP = "10,100,1e3", 64000.0


def protocols(seeds: int, dt_factor: float,
              sizes=(100, 400, 900)) -> dict[str, list[RunSpec]]:
    """Every sweep of the reproduction: name -> its RunSpecs (the directory OUT/name);
    ``sizes``: the N of the paper's grid to run (paper and steady protocols)."""
    grid_sizes = [PAPER_SIZES[n] for n in sizes]
    grid = phi_values(PHI)
    paper = protocol_fields("paper", dt_factor=dt_factor)
    steady = protocol_fields("steady", dt_factor=dt_factor)
    return {
        "paper": [s for t_end in PAPER_LENGTHS for s in
                  sweep_specs(grid, grid_sizes, seeds, **{**paper, "t_end": t_end})],
        "steady": sweep_specs(grid, grid_sizes, seeds, **{**steady, "t_end": STEADY_CAP}),
        "steady_3600": sweep_specs(phi_values(LARGE_PHI), [LARGE_SIZE], min(seeds, 2),
                                   **{**steady, "t_end": LARGE_CAP}),
        "sync_steady": sweep_specs(phi_values(SYNC_STEADY_PHI), [PAPER_SIZES[100]], seeds,
                                   **{**steady, "start": "synchronized",
                                      "t_end": SYNC_STEADY_CAP}),
        "aspect": sweep_specs(grid, ASPECT_SIZES, seeds, **paper),
    }


def run_sweep(name, specs, jobs, out):
    print(f"{name}: {len(specs)} runs into {out}", flush=True)
    rep = sweep(specs, out, jobs=jobs)
    print(f"{name}: {len(rep.finished)} run(s) in {fmt_duration(rep.wall_time_s)}, "
          f"{rep.finished_before} finished earlier, {len(rep.failed)} failed", flush=True)
    for job, msg in rep.failed.items():
        print(f"  failed {job}: {msg}", file=sys.stderr)
    return rep


def _pm(v, e, fmt=".4f"):
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "n/a"
    # the error to two significant digits: ± 0.0000 would hide how small it is
    return f"{v:{fmt}} ± {e:.2g}" if e == e else f"{v:{fmt}}"


def cluster_share(runs: pd.DataFrame, regime: str) -> float:
    """The share of all slip clusters of ``runs`` that the regime rule calls ``regime``:
    each run's fraction weighted by its number of clusters (NaN without clusters)."""
    w = runs.n_clusters.to_numpy(dtype=float)
    col = f"regime_fractions[{regime}]"
    if col not in runs or not w.sum() > 0:
        return math.nan
    return float(np.nansum(runs[col].to_numpy(dtype=float) * w) / w.sum())


def span_fraction(sweep_dir: Path) -> float:
    """The fraction of the box from which the sweep's analysis counts an axis as spanned."""
    settings = io.read_json(Path(sweep_dir) / SETTINGS_FILE)
    return AnalysisSettings.from_dict(settings).span_fraction


#: the curves compared in the figures and tables: label -> (protocol directory, selection)
CURVES = {
    "paper, t_end = 1000": ("paper", {"t_end": 1000.0}),
    "paper, t_end = 4000": ("paper", {"t_end": 4000.0}),
    "paper, t_end = 16000": ("paper", {"t_end": 16000.0}),
    "steady protocol": ("steady", {}),
    "steady protocol, N = 3600": ("steady_3600", {}),
    "synchronized start until steady": ("sync_steady", {}),
}
#: (field, its name in numbers.md, its axis label in the figures)
OBSERVABLES = (("mu_bar", "mu_bar (slips above 1% of mu_s sigma_n)",
                r"$\overline{\mu}$ (slips above 1% of $\mu_s\sigma_n$)"),
               ("mu_bar_large", "mu_bar (large drops: drop > mean drop)",
                r"$\overline{\mu}$ (large drops: drop > mean drop)"),
               ("mean_stress_ratio", "<sigma_x>/sigma_n", r"$\langle\sigma_x\rangle/\sigma_n$"))


def _tables(out: Path, name: str, where: dict | None = None):
    """(runs, results) of a protocol's sweep, restricted to ``where``; None when not run."""
    try:
        runs, res = read_tables(out / name)
    except (FileNotFoundError, pd.errors.EmptyDataError):
        return None
    for k, v in (where or {}).items():
        runs, res = runs[np.isclose(runs[k], v)], res[np.isclose(res[k], v)]
    return (runs, res) if len(runs) else None


def curves(out: Path) -> dict:
    """label -> (runs, results) of every curve that has been run."""
    found = {}
    for label, (name, where) in CURVES.items():
        t = _tables(out, name, where)
        if t is not None:
            found[label] = t
    return found


def minimum(g: pd.DataFrame, field: str) -> dict:
    """Where ``field`` of one curve (one N, sorted by phi) is lowest, and whether that
    minimum is an interior one below both ends by more than two combined errors."""
    g = g.sort_values("phi").reset_index(drop=True)
    y, e = g[field].to_numpy(float), g[f"{field}_sem"].to_numpy(float)
    e = np.where(np.isfinite(e), e, 0.0)
    i = int(np.nanargmin(y))
    below = [(y[k] - y[i]) / math.hypot(e[k], e[i]) if math.hypot(e[k], e[i]) > 0 else math.inf
             for k in (0, len(y) - 1)]
    return {"phi": g.phi[i], "min": y[i], "sem": e[i], "lo": y[0], "lo_sem": e[0],
            "hi": y[-1], "hi_sem": e[-1], "z_lo": below[0], "z_hi": below[1],
            "interior": 0 < i < len(y) - 1,
            "non_monotonic": 0 < i < len(y) - 1 and min(below) > 2,
            "depth": max(y[0], y[-1]) - y[i]}


NOTHING = "nothing new to run or analyse"


def numbers(out: Path, wall: dict) -> str:
    """The tables REPRODUCTION.md cites, as markdown."""
    cs = curves(out)
    lines = ["# Numbers of the reproduction (generated by workflows/paper/reproduce.py)", "",
             "Errors are standard errors over seeds. `state` is a point's: steady when every "
             "seed's run was steady over its analysed window, metastable when one was (a flat "
             "stress that still remembers its start, or a pair whose two starts disagree), "
             "drifting otherwise (docs/model.md \"Steady state\"); the counts are "
             "steady/drifting/metastable runs.",
             "This invocation: " + (", ".join(f"{k} {v}" for k, v in wall.items()) + " wall"
                                    if wall else NOTHING)
             + " (runs finished earlier are not redone; REPRODUCTION.md gives each "
             "protocol's time from scratch).", "",
             "## The runs", "",
             "| curve | runs | steady | drifting | metastable | t_run (min - max) | "
             "LAMMPS core-seconds |",
             "|---|---|---|---|---|---|---|"]
    for label, (runs, _) in cs.items():
        n = runs.state.value_counts()
        lines.append(f"| {label} | {len(runs)} | {n.get('steady', 0)} | "
                     f"{n.get('drifting', 0)} | {n.get('metastable', 0)} | "
                     f"{runs.t_run.min():.0f} - {runs.t_run.max():.0f} | "
                     f"{runs.wall_time_s.sum():.0f} |")

    for field, title, _ in OBSERVABLES:
        lines += ["", f"## {title}: minimum against the ends", "",
                  "non-monotonic = the lowest point is interior and below both ends by more "
                  "than 2 combined standard errors (z_lo, z_hi).", "",
                  "| curve | N | phi at min | min | 1 - min/mu_s | lowest phi | highest phi | z_lo "
                  "| z_hi | non-monotonic |", "|---|---|---|---|---|---|---|---|---|---|"]
        for label, (_, res) in cs.items():
            for n, g in res.groupby("N"):
                if field not in g or g[field].isna().all():
                    continue
                m = minimum(g, field)
                mu_s = float(g.mu_s.iloc[0])
                lines.append(f"| {label} | {n} | {m['phi']:g} | {_pm(m['min'], m['sem'])} | "
                             f"{1 - m['min'] / mu_s:.3f} | {_pm(m['lo'], m['lo_sem'])} | "
                             f"{_pm(m['hi'], m['hi_sem'])} | {m['z_lo']:.1f} | "
                             f"{m['z_hi']:.1f} | {'yes' if m['non_monotonic'] else 'no'} |")

    lines += ["", "## Per phi: every curve", "",
              "| curve | N | phi | state (s/d/m) | t_run | mu_bar | mu_bar (large) | "
              "<sigma_x>/sigma_n | Psi(inf) | <l_x>/<l_y> | <l_x>/<l_y> (large) | regime | "
              "t_equil |", "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for label, (_, res) in cs.items():
        for _, r in res.sort_values(["N", "phi"]).iterrows():
            lines.append(
                f"| {label} | {r.N} | {r.phi:g} | {r.state} ({r.n_steady}/{r.n_drifting}/"
                f"{r.n_metastable}) | "
                f"{r.t_run:.0f} | {_pm(r.mu_bar, r.mu_bar_sem)} | "
                f"{_pm(r.mu_bar_large, r.mu_bar_large_sem)} | "
                f"{_pm(r.mean_stress_ratio, r.mean_stress_ratio_sem)} | "
                f"{_pm(r.psi_inf, r.psi_inf_sem, '.3f')} | "
                f"{_pm(r.lx_over_ly, r.lx_over_ly_sem, '.2f')} | "
                f"{_pm(r.lx_over_ly_large, r.lx_over_ly_large_sem, '.2f')} | {r.regime} | "
                f"{r.t_equil:.0f} |")

    lines += ["", "## Psi(inf): spread across N", "",
              "| curve | phi | " + " | ".join(f"N={n}" for n in (100, 400, 900, 3600))
              + " | max - min |", "|---|---|---|---|---|---|---|"]
    for label, (_, res) in cs.items():
        for phi, g in res.groupby("phi"):
            g = g.set_index("N")
            cells = [(_pm(g.psi_inf[n], g.psi_inf_sem[n], ".3f") if n in g.index else "")
                     for n in (100, 400, 900, 3600)]
            lines.append(f"| {label} | {phi:g} | " + " | ".join(cells)
                         + f" | {g.psi_inf.max() - g.psi_inf.min():.3f} |")

    lines += ["", "## Where <l_x>/<l_y> peaks and mu_bar dips", "",
              "| curve | N | phi at max <l_x>/<l_y> | phi at max (large slips) | phi at min mu_bar "
              "| phi at min mu_bar (large) | phi at min <sigma_x>/sigma_n |",
              "|---|---|---|---|---|---|---|"]
    for label, (_, res) in cs.items():
        for n, g in res.groupby("N"):
            def arg(f, fn, g=g):
                v = g[f]
                return f"{g.phi[getattr(v, fn)()]:g}" if v.notna().any() else "n/a"
            lines.append(f"| {label} | {n} | {arg('lx_over_ly', 'idxmax')} | "
                         f"{arg('lx_over_ly_large', 'idxmax')} | {arg('mu_bar', 'idxmin')} | "
                         f"{arg('mu_bar_large', 'idxmin')} | "
                         f"{arg('mean_stress_ratio', 'idxmin')} |")

    lines += ["", "## Regimes: share of slip clusters (all seeds), N = 100 (20x5)", "",
              "The parity-free rule of bkflow.clusters.regime: each extent against the whole "
              "box's own on its side; a slip spanning both axes is C in a crystalline layer and "
              "W otherwise, never DP or DT. 'x not spanned' = DP + DT.", "",
              "| curve | phi | C | W | LC | DP | DT | x not spanned | clusters |",
              "|---|---|---|---|---|---|---|---|---|"]
    for label, (runs, _) in cs.items():
        r100 = runs[(runs.Lx == 20) & (runs.Ly == 5)]
        for phi, g in r100.groupby("phi"):
            fr = [cluster_share(g, k) for k in ("C", "W", "LC", "DP", "DT")]
            fr.append(fr[3] + fr[4])
            lines.append(f"| {label} | {phi:g} | " + " | ".join(f"{f:.2f}" for f in fr)
                         + f" | {g.n_clusters.sum():.0f} |")

    sync = _tables(out, "sync_steady")
    steady = _tables(out, "steady")
    if sync is not None:
        lines += ["", "## One steady state from both starts? (N = 100, until steady)", "",
                  "| phi | start | state | t_run (mean, max) | mu_bar | mu_bar (large) | "
                  "<sigma_x>/sigma_n | difference / combined error (<sigma_x>) |",
                  "|---|---|---|---|---|---|---|---|"]
        for phi, g in sync[1].groupby("phi"):
            rnd = steady[1][(steady[1].N == 100) & np.isclose(steady[1].phi, phi)] \
                if steady is not None else pd.DataFrame()
            for start, r in (("synchronized", g.iloc[0]),
                             ("random (the steady protocol)", rnd.iloc[0] if len(rnd)
                              else None)):
                if r is None:
                    continue
                runs = (sync[0] if start == "synchronized" else steady[0])
                rr = runs[(runs.N == 100) & np.isclose(runs.phi, phi)]
                diff = ""
                if start != "synchronized":
                    s0 = g.iloc[0]
                    d = r.mean_stress_ratio - s0.mean_stress_ratio
                    err = math.hypot(r.mean_stress_ratio_sem, s0.mean_stress_ratio_sem)
                    diff = f"{d / err:.1f}"
                lines.append(f"| {phi:g} | {start} | {r.state} | "
                             f"{rr.t_run.mean():.0f}, {rr.t_run.max():.0f} | "
                             f"{_pm(r.mu_bar, r.mu_bar_sem)} | "
                             f"{_pm(r.mu_bar_large, r.mu_bar_large_sem)} | "
                             f"{_pm(r.mean_stress_ratio, r.mean_stress_ratio_sem)} | {diff} |")

    aspect = _tables(out, "aspect")
    if aspect is not None:
        lines += aspect_numbers(out / "aspect", aspect[0])
    found = energy_argument(out)
    if found:
        lines += energy_numbers(found)
    return "\n".join(lines) + "\n"


def aspect_numbers(aspect_dir: Path, a: pd.DataFrame) -> list[str]:
    out = ["", "## Aspect ratio (t_end = 8000): share of DT clusters", "",
           "| phi | " + " | ".join(f"{lx}x{ly} (Lx/Ly = {lx / ly:g})" for lx, ly in ASPECT_SIZES)
           + " |", "|---|" + "---|" * len(ASPECT_SIZES)]
    for phi, g in a.groupby("phi"):
        cells = []
        for lx, ly in ASPECT_SIZES:
            share = cluster_share(g[(g.Lx == lx) & (g.Ly == ly)], "DT")
            cells.append("n/a" if math.isnan(share) else f"{share:.2f}")
        out.append(f"| {phi:g} | " + " | ".join(cells) + " |")
    tot = []
    for lx, ly in ASPECT_SIZES:
        s = a[(a.Lx == lx) & (a.Ly == ly)]
        tot.append(f"{cluster_share(s, 'DT'):.3f} of {s.n_clusters.sum():.0f}")
    out.append("| all phi | " + " | ".join(tot) + " |")
    span = span_fraction(aspect_dir)
    out += ["", "## Aspect ratio: cluster shapes over all phi and seeds", "",
            "DT and 'spans both axes' by the parity-free rule (bkflow.clusters.regime: each "
            f"extent against the whole box's own on its side, spanning from {span:g}); a slip "
            "that spans both axes is C or W, never DT.", "",
            "| size | clusters | DT | x not spanned (DP + DT) | spans both axes | "
            "l_y > l_x (absolute) |", "|---|---|---|---|---|---|"]
    for lx, ly in ASPECT_SIZES:
        s = a[(a.Lx == lx) & (a.Ly == ly)]
        tables = [c for c in (sweep_run_dir(aspect_dir, j).read_clusters() for j in s.job)
                  if c is not None]
        if not tables or not sum(map(len, tables)):
            out.append(f"| {lx}x{ly} | 0 | n/a | n/a | n/a | n/a |")
            continue
        c = pd.concat(tables)
        fx, fy = box_fractions(c.l_x, c.l_y, (lx, ly))
        out.append(f"| {lx}x{ly} | {len(c)} | {cluster_share(s, 'DT'):.3f} | "
                   f"{(fx < span).mean():.3f} | "
                   f"{((fx >= span) & (fy >= span)).mean():.3f} | "
                   f"{(c.l_y > c.l_x).mean():.3f} |")
    return out


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
    """Every slip cluster after the transient of one curve's runs (their clusters.csv), with
    the run's phi, Lx, Ly, N and seed, and its shape: `row` (spans x, not y), `transverse`
    (spans y, not x), `whole` (both) or `patch` (neither)."""
    name, where = CURVES[label]
    t = _tables(out, name, where)
    if t is None:
        return None
    parts = []
    for _, r in t[0].iterrows():
        rd = sweep_run_dir(out / name, r.job)
        if not rd.file("clusters.csv").exists():
            continue
        c = pd.read_csv(rd.file("clusters.csv"))
        if "eq2_estimate" not in c or not len(c):
            continue
        c = c.assign(phi=r.phi, Lx=int(r.Lx), Ly=int(r.Ly), N=int(r.N), seed=int(r.seed))
        parts.append(c)
    if not parts:
        return None
    c = pd.concat(parts, ignore_index=True)
    sx, sy = c.n_x == c.Lx, c.n_y == c.Ly
    c["shape"] = np.select([sx & ~sy, sy & ~sx, sx & sy], ["row", "transverse", "whole"],
                           "patch")
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
                            **{k: float((h["shape"] == k).mean())
                               for k in ("row", "transverse", "whole", "patch")},
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
                "crossover_observed": _log_crossing(per.phi, per.row, per.transverse),
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
             "row (spans x only), transverse (spans y only), whole, patch. Crossovers: the phi "
             "(log-interpolated) below which transverse clusters outnumber row clusters "
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
                  "| phi | clusters | row | transverse | whole | patch | median slip | "
                  "bond change / Eq. 2 |", "|---|---|---|---|---|---|---|---|"]
        for r in f["per_phi"].itertuples():
            lines.append(f"| {r.phi:g} | {r.clusters} | {r.row:.2f} | {r.transverse:.2f} | "
                         f"{r.whole:.2f} | {r.patch:.2f} | {r.slip_median:.3g} | "
                         f"{r.ratio_median:.3g} |")
    return lines


def energy_figure(found: dict, figs: Path) -> Path | None:
    """Claim 6: (a) each cluster's bond energy change against Eq. 2, by phi; (b) the share of
    row and transverse clusters against phi at N = 100 under both protocols, with the median
    slip against delta* (the argument's crossover)."""
    if not found:
        return None
    plt = _style()
    fig, (a, b) = plt.subplots(1, 2, figsize=(8.6, 3.6), layout="constrained")
    norm = matplotlib_lognorm(0.1, 1000.0)
    for (label, _n), f in found.items():
        g = f["clusters_table"]
        e = g[(g.eq2_estimate > 0) & (g.bond_change > 0)]
        sc = a.scatter(e.eq2_estimate, e.bond_change, c=e.phi, norm=norm, cmap="viridis", s=3,
                       marker="o" if label.startswith("steady") else "^", alpha=0.5, lw=0)
    lim = [1e-6, 1e3]
    a.plot(lim, lim, "k--", lw=0.8, label="measured = Eq. 2")
    a.set_xscale("log")
    a.set_yscale("log")
    a.set_xlim(*lim)
    a.set_ylim(*lim)
    a.set_xlabel(r"Eq. 2 from $n_x$, $n_y$, $\delta$ ($k_d l^2$)")
    a.set_ylabel(r"bond energy change of the cluster ($k_d l^2$)")
    a.legend(frameon=False, loc="upper left", fontsize=7,
             title="o steady protocol, ^ paper's (t_end = 16000)", title_fontsize=7)
    cb = fig.colorbar(sc, ax=a)
    cb.ax.set_title(r"$\phi$", fontsize=9)
    neg = np.mean([float(f["negative"]) for f in found.values()])
    a.set_title(f"every cluster with a perimeter (Eq. 2 > 0); the {100 * neg:.0f}% whose\n"
                "bond energy fell in the slip cannot be shown on log axes", fontsize=7)
    b2 = b.twinx()
    for (label, n), f in found.items():
        if n != 100:
            continue
        per = f["per_phi"]
        ls = "-" if label.startswith("steady") else ":"
        b.plot(per.phi, per.row, ls, marker="o", ms=3, color="C0",
               label=f"row ({label})")
        b.plot(per.phi, per.transverse, ls, marker="s", ms=3, color="C3",
               label=f"transverse ({label})")
        b2.plot(per.phi, per.slip_median / f["delta_star"], ls, color="0.4", lw=0.8)
    b2.axhline(1.0, color="0.4", lw=0.6, ls="--")
    b2.set_yscale("log")
    b2.set_ylabel(r"median slip / $\delta^*$ (grey)")
    b.set_xscale("log")
    b.set_xlabel(r"$\phi$")
    b.set_ylabel("share of the clusters")
    b.legend(frameon=False, fontsize=6.5, loc="center left")
    b.set_title(r"N = 100 (20x5); grey: median slip / $\delta^*$ (solid steady, dotted "
                "paper's)", fontsize=7)
    return _write(fig, figs / "energy_argument.png")


def matplotlib_lognorm(lo: float, hi: float):
    from matplotlib.colors import LogNorm

    return LogNorm(lo, hi)


def protocols_figure(out: Path, figs: Path) -> Path | None:
    """mu_bar, mu_bar over large drops and <sigma_x>/sigma_n against phi, one column per N,
    one curve per protocol and run length; markers by state (bkflow.plot.STATE_FILL)."""
    cs = curves(out)
    if not cs:
        return None
    plt = _style()
    ns = sorted({int(n) for _, res in cs.values() for n in res.N})
    fig, axes = plt.subplots(len(OBSERVABLES), len(ns), figsize=(3.0 * len(ns), 7.2),
                             squeeze=False, sharex=True)
    colours = dict(zip(CURVES, ("tab:orange", "tab:red", "darkred", "tab:blue", "tab:cyan",
                                "tab:green")))
    for col, n in enumerate(ns):
        for row, (field, _, title) in enumerate(OBSERVABLES):
            ax = axes[row, col]
            for label, (_, res) in cs.items():
                g = res[res.N == n].sort_values("phi")
                if not len(g) or field not in g:
                    continue
                states = g.state.fillna("drifting").to_numpy()
                c = colours[label]
                ax.errorbar(g.phi, g[field], yerr=g[f"{field}_sem"].fillna(0), color=c, lw=0.8,
                            capsize=1.5, marker="none", label=label)
                for name, fill in STATE_FILL.items():
                    k = states == name
                    ax.plot(g.phi[k], g[field][k], "o", color=c, ms=4.5, fillstyle=fill,
                            mfc=c if fill != "none" else "white", mfcalt="white")
            ax.set_xscale("log")
            if col == 0:
                ax.set_ylabel(title, fontsize=7.5)
            if row == 0:
                ax.set_title(f"N = {n}", fontsize=9)
            if row == len(OBSERVABLES) - 1:
                ax.set_xlabel(r"$\phi = k_b/\Delta k_d$")
    # one key below the panels (the curves, then the marker convention): it covers no point
    handles, labels = axes[0, 0].get_legend_handles_labels()
    states, words = state_handles()
    fig.legend(handles + states, labels + words, loc="outside lower center", ncol=4,
               frameon=False, fontsize=7)
    return _write(fig, figs / "fig2a_protocols.png")


def _write(fig, path: Path) -> Path:
    """Save one of this script's figures (PNG, bkflow's resolution, trimmed) at ``path``."""
    fig.savefig(path, dpi=STYLE["savefig.dpi"], bbox_inches="tight")
    return path


def relaxation_figure(out: Path, figs: Path) -> Path | None:
    """The equilibration time t_equil of the stress (Chodera's detection) against phi: from
    the synchronized start (t_end = 16000) and from the random start (until stationary)."""
    cs = curves(out)
    plt = _style()
    fig, ax = plt.subplots(figsize=(4.6, 3.2))
    drawn = False
    for label, ls in (("paper, t_end = 16000", "-"), ("steady protocol", ":"),
                      ("steady protocol, N = 3600", ":")):
        if label not in cs:
            continue
        runs = cs[label][0]
        for (n, g), m in zip(runs.groupby("N"), "os^D"):
            med = g.groupby("phi").t_equil.median()
            ax.plot(med.index, med.to_numpy(), m + ls, lw=0.8, ms=3.5,
                    mfc="none" if ls == ":" else None,
                    label=f"{'synchronized' if ls == '-' else 'steady protocol'}, N = {n}")
            drawn = True
    if not drawn:
        return None
    ax.set_xscale("log")
    ax.set_yscale("symlog", linthresh=10)
    ax.set_xlabel(r"$\phi$")
    ax.set_ylabel(r"$t_{\rm equil}$ of $\sigma_x$ (median over seeds)")
    ax.set_title("how long the start is remembered", fontsize=9)
    ax.legend(frameon=False, fontsize=6)
    return _write(fig, figs / "relaxation.png")


def figures(out: Path, figs: Path) -> list[Path]:
    written = []
    for label, (name, where) in CURVES.items():
        if _tables(out, name, where) is None:
            continue
        sub = figs / label.split(" (")[0].replace(", ", "_").replace(" = ", "").replace(" ", "_")
        paths, _ = plot(out / name, sub, formats=("png",), where=where)
        written += paths
    for make in (protocols_figure, relaxation_figure):
        path = make(out, figs)
        if path is not None:
            written.append(path)
    if _tables(out, "aspect") is not None:
        written += aspect_figures(out / "aspect", figs)
    path = energy_figure(energy_argument(out), figs)
    if path is not None:
        written.append(path)
    return written


def aspect_figures(aspect_dir: Path, out: Path) -> list[Path]:
    """Share of DT clusters against phi for each aspect ratio, and the cluster scatter of
    each aspect ratio at the phi with the most DT clusters and at phi = 0.1."""
    plt = _style()
    data = SweepData(aspect_dir)
    rows = (len(ASPECT_SIZES) + 2) // 3   # N = 100 above, N = 400 below
    fig, axes = plt.subplots(rows, 3, figsize=(9.0, 3.9 * rows), squeeze=False)
    for ax, (lx, ly) in zip(axes.flat, ASPECT_SIZES):
        cluster_scatter(data, plt, lx, ly, [2.15443, 0.1], f"{lx}x{ly} (Lx/Ly = {lx / ly:g})",
                        ax=ax)
        ax.legend(frameon=False, fontsize=6.5, loc="upper center", bbox_to_anchor=(0.5, -0.16),
                  ncol=1, markerscale=1.5)
    return [_write(fig, out / "aspect_clusters.png"), aspect_share_figure(aspect_dir, out)]


def aspect_share_figure(aspect_dir: Path, out: Path) -> Path:
    plt = _style()
    a, _ = read_tables(aspect_dir)
    fig, ax = plt.subplots(figsize=(3.8, 2.8))
    for (lx, ly), m, c in zip(ASPECT_SIZES, "osDosD", ["tab:blue", "tab:orange", "tab:green"] * 2):
        s = a[(a.Lx == lx) & (a.Ly == ly)]
        rows = [(phi, cluster_share(g, "DT")) for phi, g in s.groupby("phi")]
        if rows:
            x, y = zip(*rows)
            even = lx % 2 == 0 and ly % 2 == 0
            ax.plot(x, y, marker=m, lw=0.8, color=c, ls="-" if even else "--",
                    mfc=c if even else "none", ms=4,
                    label=f"{lx}x{ly} (Lx/Ly = {lx / ly:g}, N = {lx * ly})")
    ax.set_xscale("log")
    ax.set_xlabel(r"$\phi$")
    ax.set_ylabel("share of DT clusters")
    ax.set_title("aspect ratio check (parity-free rule)", fontsize=9)
    ax.legend(frameon=False, fontsize=6.5)
    return _write(fig, out / "aspect_dt_share.png")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("--out", default="runs/paper", help="where the runs go (default runs/paper)")
    p.add_argument("--jobs", type=int, default=available_cores())
    p.add_argument("--seeds", type=int, default=3)
    p.add_argument("--dt-factor", type=float, default=RunSpec.dt_factor)
    p.add_argument("--sizes", default="100,400,900",
                   help="the N of the paper's grid to run, of 100, 400, 900 (default: all)")
    p.add_argument("--protocols", default=",".join(protocols(1, RunSpec.dt_factor)),
                   help="which sweeps to run (default: all)")
    p.add_argument("--figures", default=str(HERE / "figures"))
    p.add_argument("--numbers", default=str(HERE / "numbers.md"),
                   help="where the numbers REPRODUCTION.md cites go (default: beside it)")
    a = p.parse_args(argv)
    out, figs = Path(a.out), Path(a.figures)
    figs.mkdir(parents=True, exist_ok=True)
    try:
        sizes = tuple(int(n) for n in a.sizes.split(","))
    except ValueError:
        p.error(f"--sizes {a.sizes}: give N values, e.g. 100,400")
    if not set(sizes) <= {100, 400, 900}:
        p.error(f"--sizes {a.sizes}: the paper's grid has N = 100, 400, 900")
    every = protocols(a.seeds, a.dt_factor, sizes)
    chosen = [n.strip() for n in a.protocols.split(",") if n.strip()]
    unknown = set(chosen) - set(every)
    if unknown:
        p.error(f"unknown protocol(s) {', '.join(sorted(unknown))}; choose from "
                f"{', '.join(every)}")
    wall, failed = {}, False
    for name in chosen:
        t0 = time.perf_counter()
        rep = run_sweep(name, every[name], a.jobs, out / name)
        if rep.finished:  # what this invocation ran or re-analysed, and how long it took
            wall[name] = (fmt_duration(time.perf_counter() - t0)
                          + f" ({len(rep.finished)} runs run or re-analysed)")
        failed |= bool(rep.failed)
    written = figures(out, figs)
    for pth in written:
        print(f"wrote {pth}")
    Path(a.numbers).write_text(numbers(out, wall))
    print(f"wrote {a.numbers}")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
