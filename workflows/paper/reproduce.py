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
import json
import math
import re
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from bkflow.figures.clusters import cluster_scatter
from bkflow.figures.data import SweepData, point_states
from bkflow.figures.keys import state_handles
from bkflow.figures.registry import plot
from bkflow.figures.style import STATE_FILL, STYLE, new_figures, state_marker
from bkflow.model.lattice import box_fractions
from bkflow.model.params import PAPER_SIZES, RunSpec
from bkflow.model.protocols import protocol_fields
from bkflow.model.settings import AnalysisSettings
from bkflow.observables.states import SWITCHING
from bkflow.store import files, formats
from bkflow.store.rundir import sweep_run_dir
from bkflow.store.tables import SETTINGS_FILE, read_tables, settings_in
from bkflow.sweeps.grid import phi_values, sweep_specs
from bkflow.sweeps.local import available_cores, fmt_duration, sweep

sys.path.insert(0, str(Path(__file__).resolve().parent))
import claims  # noqa: E402  (workflows/paper/claims.py, beside this script)
import claims_record  # noqa: E402

HERE = Path(__file__).resolve().parent
PHI = "1e-1:1e3"
#: the aspect-ratio check: N = 100 as the paper, and N = 400 with every side even (an odd
#: side's whole-box extent is shorter, so claim 5 is also decided where parity plays no part)
ASPECT_SIZES = [(20, 5), (10, 10), (5, 20), (40, 10), (20, 20), (10, 40)]
#: the paper's protocol: the synchronized start run for a finite length, at three lengths
PAPER_LENGTHS = (1000.0, 4000.0, 16000.0)
#: the paper's literal integrator (docs/model.md "Integration"): the damping with the half-step
#: velocity and a broken contact re-formed at the step's end, first order in dt; run under the
#: paper's protocol at its longest length, at the same time step as the other curves, so that
#: the two schemes differ only in their step's bias
FIRST_ORDER = {"damping": "half", "contact_rule": "reset/step"}
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
        "paper_first_order": sweep_specs(grid, grid_sizes, seeds,
                                         **{**paper, "t_end": PAPER_LENGTHS[-1], **FIRST_ORDER}),
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
    settings = settings_in(formats.read_json(Path(sweep_dir) / SETTINGS_FILE))
    return AnalysisSettings.from_dict(settings).span_fraction


#: the curves compared in the figures and tables: label -> (protocol directory, selection)
CURVES = {
    "paper, t_end = 1000": ("paper", {"t_end": 1000.0}),
    "paper, t_end = 4000": ("paper", {"t_end": 4000.0}),
    "paper, t_end = 16000": ("paper", {"t_end": 16000.0}),
    "paper, first-order scheme, t_end = 16000": ("paper_first_order", {}),
    "steady protocol": ("steady", {}),
    "steady protocol, N = 3600": ("steady_3600", {}),
    "synchronized start until steady": ("sync_steady", {}),
}
#: (field, its name in numbers.md, its axis label in the figures)
OBSERVABLES = (("mu_bar", "mu_bar (slips above 1% of mu_s sigma_n)",
                "$\\overline{\\mu}$, slips above\n1% of $\\mu_s\\sigma_n$"),
               ("mu_bar_large", "mu_bar (large drops: drop > mean drop)",
                "$\\overline{\\mu}$, large drops:\ndrop > mean drop"),
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


NOTHING = "nothing new to run or analyse"


def numbers(out: Path, wall: dict) -> str:
    """The tables REPRODUCTION.md cites, as markdown."""
    cs = curves(out)
    lines = ["# Numbers of the reproduction (generated by workflows/paper/reproduce.py)", "",
             "Errors are standard errors over seeds. `state` is a point's: steady when every "
             "seed's run was steady over its analysed window, metastable when one was (a flat "
             "stress that still remembers its start, or a pair whose two starts disagree), "
             "drifting otherwise, or the states a switching layer visited (docs/model.md "
             "\"Steady state\"); the counts are steady/switching/drifting/metastable runs.",
             "This invocation: " + (", ".join(f"{k} {v}" for k, v in wall.items()) + " wall"
                                    if wall else NOTHING)
             + " (runs finished earlier are not redone; REPRODUCTION.md gives each "
             "protocol's time from scratch).", "",
             "## The runs", "",
             "| curve | runs | steady | switching between states | drifting | metastable | "
             "t_run (min - max) | LAMMPS core-seconds |",
             "|---|---|---|---|---|---|---|---|"]
    for label, (runs, _) in cs.items():
        n = runs.state.value_counts()
        lines.append(f"| {label} | {len(runs)} | {n.get('steady', 0)} | "
                     f"{sum(n.get(k, 0) for k in SWITCHING)} | "
                     f"{n.get('drifting', 0)} | {n.get('metastable', 0)} | "
                     f"{runs.t_run.min():.0f} - {runs.t_run.max():.0f} | "
                     f"{runs.wall_time_s.sum():.0f} |")

    for field, title, _ in OBSERVABLES:
        lines += ["", f"## {title}: minimum against the ends", "",
                  "non-monotonic = the lowest point is interior and below both ends by more "
                  "than the critical value, Student's t with the seeds' degrees of freedom, "
                  "corrected for the interior phi it was picked from (claims.py's test).", "",
                  "| curve | N | phi at min | min | 1 - min/mu_s | lowest phi | highest phi | z_lo "
                  "| z_hi | critical | non-monotonic |",
                  "|---|---|---|---|---|---|---|---|---|---|---|"]
        for label, (_, res) in cs.items():
            for n, g in res.groupby("N"):
                if field not in g or g[field].isna().all():
                    continue
                g = g.sort_values("phi")
                m = claims_record.minimum(g.phi, g[field], g[f"{field}_sem"], int(g.n_seeds.min()))
                e = g[f"{field}_sem"].to_numpy(float)
                mu_s = float(g.mu_s.iloc[0])
                lines.append(f"| {label} | {n} | {m['phi']:g} | {_pm(m['min'], m['sem'])} | "
                             f"{1 - m['min'] / mu_s:.3f} | {_pm(m['lo'], e[0])} | "
                             f"{_pm(m['hi'], e[-1])} | {claims.num_text(m['z_lo'], '.1f')} | "
                             f"{claims.num_text(m['z_hi'], '.1f')} | {m['critical']:.2f} | "
                             f"{'yes' if m['non_monotonic'] else 'no'} |")

    lines += ["", "## Per phi: every curve", "",
              "| curve | N | phi | state (s/w/d/m) | t_run | mu_bar | mu_bar (large) | "
              "<sigma_x>/sigma_n | Psi(inf) | <l_x>/<l_y> | <l_x>/<l_y> (large) | regime | "
              "t_equil |", "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for label, (_, res) in cs.items():
        for _, r in res.sort_values(["N", "phi"]).iterrows():
            lines.append(
                f"| {label} | {r.N} | {r.phi:g} | {r.state} ({r.n_steady}/"
                f"{r.get('n_switching', 0)}/{r.n_drifting}/{r.n_metastable}) | "
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
              "The parity-free rule of bkflow.observables.clusters.regime: each extent against the "
              "whole "
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
            "DT and 'spans both axes' by the parity-free rule "
            "(bkflow.observables.clusters.regime: each "
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
    """Every slip cluster after the transient of one curve's runs (RunDir.read_clusters), with
    the run's phi, Lx, Ly, N and seed, and its shape: claims.py's class (its regime from its
    extents, as claims 4, 5 and 6 count it; C and W one class, "whole")."""
    name, where = CURVES[label]
    t = _tables(out, name, where)
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
        c.loc[k, "shape"] = claims_record.shape_class(c.l_x[k], c.l_y[k], int(lx), int(ly))
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
                            **{k: float((h["shape"] == k).mean()) for k in claims.SHAPES},
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
    return _write(fig, figs / "energy_argument.png")


def matplotlib_lognorm(lo: float, hi: float):
    from matplotlib.colors import LogNorm

    return LogNorm(lo, hi)


#: the curves' colours in fig2a_protocols (Okabe and Ito's colour-blind-safe palette: the
#: paper's run lengths orange, vermillion, reddish purple; the steady protocol blue and sky
#: blue; the synchronized start until steady bluish green) and line styles (the paper's run
#: lengths dotted, dashed, dash-dotted: told apart without colour too; the paper's first-order
#: scheme black, dash-dot-dotted)
CURVE_STYLE = {"paper, t_end = 1000": ("#E69F00", ":"),
               "paper, t_end = 4000": ("#D55E00", "--"),
               "paper, t_end = 16000": ("#CC79A7", "-."),
               "paper, first-order scheme, t_end = 16000": ("#000000", (0, (3, 1, 1, 1, 1, 1))),
               "steady protocol": ("#0072B2", "-"),
               "steady protocol, N = 3600": ("#56B4E9", "-"),
               "synchronized start until steady": ("#009E73", "-")}
#: the long-run curve (benchmarks/stiff_states.py report writes it from the long runs: each
#: layer's mean over 10^6 time units from four starts, the seeds' mean), drawn in fig2a as the
#: truth the protocols are read against; its columns per figure row
LONG_RUN_CURVE = HERE.parent.parent / "benchmarks" / "records" / "long_run_curve.csv"
LONG_RUN_FIELDS = {"mu_bar": "mu_bar", "mean_stress_ratio": "stress"}
LONG_RUN_LABEL = "long runs (each layer's long-run mean; benchmarks/RESULTS.md)"
#: the paper's claim 1: the minimum of mu_bar lies about 40% below mu_s
PAPER_MINIMUM_BELOW_MU_S = 0.4


def _mu_s(tables) -> float | None:
    """The static friction coefficient mu_s of the runs of ``tables`` (results or runs
    DataFrames), None when they used more than one."""
    values = {float(v) for t in tables if "mu_s" in t for v in t.mu_s.dropna()}
    return values.pop() if len(values) == 1 else None


#: fig2a_protocols' layout: two sizes side by side, each a column of the three observables
#: (OBSERVABLES), the next two sizes below: 6.8 in wide, so that, trimmed as saved, it prints
#: at its own size (no text under 7 pt) in a 7 in column; its height (in) per row of sizes,
#: and the key's
PROTOCOL_COLUMNS, PROTOCOL_WIDTH, PROTOCOL_HEIGHT, PROTOCOL_KEY_HEIGHT = 2, 6.8, 3.75, 1.15


def protocols_figure(out: Path, figs: Path) -> Path | None:
    """mu_bar, mu_bar over large drops and <sigma_x>/sigma_n against phi, one column of
    panels per N, two N side by side (PROTOCOL_COLUMNS: the figure fits a 7 in column), one
    curve per protocol and run length (colour and line style, CURVE_STYLE); a point's
    marker's shape and fill are its state, as in every bkflow figure
    (bkflow.figures.style.state_marker, keyed by bkflow.figures.keys.state_handles). Each
    observable's panels share one y range across N, so that a curve's depth can be compared
    between sizes; the right axis reads each value as a fraction below mu_s (the runs' static
    friction coefficient), and a grey line marks the paper's minimum, 40% below mu_s."""
    cs = curves(out)
    if not cs:
        return None
    long_run = pd.read_csv(LONG_RUN_CURVE) if LONG_RUN_CURVE.exists() else None
    ns = sorted({int(n) for _, res in cs.values() for n in res.N})
    fig, panels = _protocol_axes(new_figures(), ns)
    mu_s = _mu_s([res for _, res in cs.values()])
    present = set()
    for n, column in panels.items():
        for ax, (field, _, _) in zip(column, OBSERVABLES):
            present |= _protocol_panel(ax, cs, n, field, long_run, mu_s)
    _label_protocol_panels(fig, panels, mu_s)
    _protocol_key(fig, present, mu_s)
    return _write(fig, figs / "fig2a_protocols.png")


def _protocol_axes(plt, ns: list) -> tuple:
    """fig2a_protocols' figure and its panels, {N: [one axes per observable, top to bottom]}:
    PROTOCOL_COLUMNS sizes to a row of sizes, each observable's panels sharing one y range
    (its tick labels on the left column only), phi shared by every panel; the cells no size
    fills are hidden."""
    ncol = min(PROTOCOL_COLUMNS, len(ns))
    blocks = -(-len(ns) // ncol)
    k = len(OBSERVABLES)
    fig, axes = plt.subplots(k * blocks, ncol, squeeze=False, sharex=True, figsize=(
        PROTOCOL_WIDTH, PROTOCOL_HEIGHT * blocks + PROTOCOL_KEY_HEIGHT))
    fig.get_layout_engine().set(wspace=0.06)   # one column's 10^3 clear of the next's 10^-1
    panels = {n: [axes[(i // ncol) * k + row, i % ncol] for row in range(k)]
              for i, n in enumerate(ns)}
    for row in range(k):
        for n in ns[1:]:
            panels[n][row].sharey(panels[ns[0]][row])
    used = {id(ax) for column in panels.values() for ax in column}
    for ax in axes.flat:
        ax.set_visible(id(ax) in used)
    return fig, panels


def _protocol_panel(ax, cs: dict, n: int, field: str, long_run, mu_s) -> set:
    """One panel of fig2a_protocols: ``field`` against phi at N = ``n``, every curve of
    ``cs`` with its points' states, the long-run curve, and (a mu_bar) the paper's minimum;
    the states drawn."""
    present = set()
    for label, (_, res) in cs.items():
        g = res[res.N == n].sort_values("phi")
        if not len(g) or field not in g:
            continue
        c, ls = CURVE_STYLE[label]
        ax.errorbar(g.phi, g[field], yerr=g[f"{field}_sem"].fillna(0), color=c, lw=0.9,
                    ls=ls, capsize=1.5, marker="none", label=label, zorder=2)
        states = point_states(g)
        for name in STATE_FILL:
            k = states == name
            if k.any():
                present.add(name)
                ax.plot(g.phi[k], g[field][k], ls="none", zorder=3,
                        **state_marker(name, c, 6.0))
    lr = long_run[long_run.N == n].sort_values("phi") if long_run is not None else []
    if len(lr) and LONG_RUN_FIELDS.get(field) in lr:
        key = LONG_RUN_FIELDS[field]
        ax.errorbar(lr.phi, lr[key], yerr=lr[key + "_se"].fillna(0), color="0.55", lw=2.2,
                    alpha=0.8, capsize=1.5, marker="none", zorder=1, label=LONG_RUN_LABEL)
    if mu_s is not None and field.startswith("mu_bar"):  # claim 1 is about mu_bar
        ax.axhline((1 - PAPER_MINIMUM_BELOW_MU_S) * mu_s, color="0.55", lw=0.8,
                   ls=(0, (6, 3)), zorder=1)
    ax.set_xscale("log")
    return present


def _label_protocol_panels(fig, panels: dict, mu_s) -> None:
    """fig2a_protocols' labels: N over each column, the observable left of the left column,
    phi under each row of sizes (its ticks there too), and right of the right column the
    value as a fraction below mu_s, the paper's measure."""
    ns = list(panels)
    ncol = min(PROTOCOL_COLUMNS, len(ns))
    for i, (n, column) in enumerate(panels.items()):
        column[0].set_title(f"N = {n}", fontsize=8)
        column[-1].set_xlabel(r"$\phi = k_b/\Delta k_d$", fontsize=8)
        column[-1].tick_params(labelbottom=True)
        last = i % ncol == ncol - 1 or n == ns[-1]
        for ax, (_, _, label) in zip(column, OBSERVABLES):
            if i % ncol == 0:
                ax.set_ylabel(label, fontsize=7.5)
            else:
                ax.tick_params(labelleft=False)
            if last and mu_s is not None:
                right = ax.secondary_yaxis("right", functions=(
                    lambda y: 100 * (1 - np.asarray(y) / mu_s),
                    lambda p: mu_s * (1 - np.asarray(p) / 100)))
                right.set_ylabel(rf"below $\mu_s$ = {mu_s:g} (%)", fontsize=7.5)


def _protocol_key(fig, present: set, mu_s) -> None:
    """fig2a_protocols' key below its panels: the curves in its first rows, the paper's
    minimum beside them, the marker convention of the states ``present`` in its last rows."""
    from matplotlib.lines import Line2D

    found = {}
    for ax in fig.axes:  # a curve drawn at some N only (N = 3600) is keyed too
        for h, lab in zip(*ax.get_legend_handles_labels()):
            found.setdefault(lab, h)
    keys = [(found[lab], lab) for lab in (*CURVE_STYLE, LONG_RUN_LABEL) if lab in found]
    if mu_s is not None:
        keys.append((Line2D([], [], color="0.55", lw=0.8, ls=(0, (6, 3))),
                     rf"the paper's minimum of $\overline{{\mu}}$: "
                     rf"{100 * PAPER_MINIMUM_BELOW_MU_S:.0f}% below $\mu_s$"))
    ncol = 2
    keys += [(Line2D([], [], alpha=0), "")] * (-len(keys) % ncol)
    keys += list(zip(*state_handles(present)))
    handles, labels = zip(*_row_major(keys, ncol))
    fig.legend(handles, labels, loc="outside lower center", ncol=ncol, frameon=False,
               fontsize=7, handlelength=2.6)


def _row_major(keys: list, ncol: int) -> list:
    """``keys`` reordered so that a legend of ``ncol`` columns (which fills column by
    column) shows them row by row; the last row padded with blank keys."""
    from matplotlib.lines import Line2D

    keys = list(keys) + [(Line2D([], [], alpha=0), "")] * (-len(keys) % ncol)
    rows = len(keys) // ncol
    return [keys[r * ncol + c] for c in range(ncol) for r in range(rows)]


def _write(fig, path: Path) -> Path:
    """Save one of this script's figures (PNG, bkflow's resolution, trimmed) at ``path``."""
    fig.savefig(path, dpi=STYLE["savefig.dpi"], bbox_inches="tight")
    return path


#: the sets of runs in the relaxation figure: (protocol directory, its start and rule in
#: words, marker)
RELAXATION_SETS = (("paper", "synchronized start, a fixed length (the paper's protocol)", "o"),
                   ("sync_steady", "synchronized start, until steady", "D"),
                   ("steady", "random start, until steady (the steady protocol)", "s"),
                   ("steady_3600", "random start, until steady (the steady protocol)", "s"))
#: a run's verdict (runs.csv ``state``) as a colour (Okabe and Ito's palette) and words
RELAXATION_STATES = {
    "steady": ("#0072B2", "steady: the start forgotten"),
    "switching": ("#009E73", "in the layer's own states (quiet / coherent): the start "
                             "forgotten"),
    "drifting": ("#E69F00", "drifting: not settled yet"),
    "metastable": ("#D55E00", "metastable: still remembers its start"),
    "none": ("0.6", "no verdict")}


def _run_verdicts(runs: pd.DataFrame) -> np.ndarray:
    """Each run's verdict as RELAXATION_STATES names it."""
    from bkflow.observables.states import SWITCHING

    states = runs["state"].astype(object).where(runs["state"].notna(), "none").astype(str) \
        if "state" in runs else pd.Series("none", index=runs.index)
    states = np.where(states.isin(SWITCHING), "switching", states.to_numpy())
    return np.where(np.isin(states, list(RELAXATION_STATES)), states, "none")


def relaxation_figure(out: Path, figs: Path) -> Path | None:
    """How long the start is remembered, from the verdicts alone: every run (each seed) at
    phi and at the length it ran (t_run: the paper's fixed lengths, or where a run until
    steady stopped: steady and within its error target, or at its cap), coloured by its
    state, one column per N. A drift or a flat plateau that still remembers the start cannot
    pass for a forgotten start here: the verdict reads the stress's trend and the contacts'
    phases (docs/model.md "Steady state"). No equilibration time is drawn: Chodera's
    detection answers tens of time units on a slow drift and 0 on the synchronized plateau
    (benchmarks/stationarity.py measures it)."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    sets = []
    for name, words, marker in RELAXATION_SETS:
        t = _tables(out, name)
        if t is not None:
            sets.append((name, words, marker, t[0]))
    if not sets:
        return None
    ns = sorted({int(n) for *_, runs in sets for n in runs.N})
    plt = new_figures()
    ncols = min(len(ns), 2)
    nrows = -(-len(ns) // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(3.4 * ncols + 0.4, 2.7 * nrows + 1.3),
                             squeeze=False, sharex=True, sharey=True)
    for ax in axes.flat[len(ns):]:
        ax.set_visible(False)
    axes = axes.flat
    present, markers, left_out = set(), {}, 0
    for col, n in enumerate(ns):
        ax = axes[col]
        for _, words, marker, runs in sets:
            g = runs[runs.N == n]
            if not len(g):
                continue
            t_run = g.t_run.to_numpy(float)
            ok = np.isfinite(t_run) & (t_run > 0)   # a log axis: a length must be > 0
            left_out += int((~ok).sum())
            g, t_run = g[ok], t_run[ok]
            # the seeds of one phi side by side, within 0.2 decade (the grid's phi lie a
            # third of a decade apart: each phi's runs stay a group of their own)
            order = sorted(set(g.seed))
            rank = g.seed.map({s: i for i, s in enumerate(order)}).to_numpy(float)
            step = min(0.07, 0.2 / max(len(order) - 1, 1))
            x = g.phi.to_numpy(float) * 10 ** (step * (rank - (len(order) - 1) / 2))
            ms = 3.8 if len(order) <= 4 else 2.8
            verdicts = _run_verdicts(g)
            for v, (colour, _) in RELAXATION_STATES.items():
                k = verdicts == v
                if k.any():
                    present.add(v)
                    ax.plot(x[k], t_run[k], marker, ls="none", ms=ms, color=colour, mew=0.3,
                            mec="white", alpha=0.9)
            markers.setdefault(words, (marker, set()))[1].update(
                {(n, float(t)) for t in g.t_end})
        lx, ly = (PAPER_SIZES[n] if n in PAPER_SIZES else LARGE_SIZE)
        ax.set_title(f"N = {n} ({lx}x{ly})", fontsize=9)
        ax.set_xscale("log")
        ax.set_yscale("log")
        if col >= len(ns) - ncols:
            ax.set_xlabel(r"$\phi$")
        if col % ncols == 0:
            ax.set_ylabel(r"its length $t_{\rm run}$ ($\sqrt{m/k_d}$)")
    handles = [Patch(color=RELAXATION_STATES[v][0]) for v in RELAXATION_STATES if v in present]
    labels = [RELAXATION_STATES[v][1] for v in RELAXATION_STATES if v in present]
    for words, (marker, ends) in markers.items():
        handles.append(Line2D([], [], marker=marker, ls="none", color="0.35", ms=4))
        labels.append(words + ": " + _lengths(ends, "fixed" in words))
    # the states in the first column, the sets of runs in the second
    fig.legend(handles, labels, loc="outside lower center", ncol=2, frameon=False,
               fontsize=6.5)
    fig.suptitle("How long the start is remembered: every run's verdict at the length it ran\n"
                 "(the verdict reads the stress's trend and the contacts' phases: neither a "
                 "drift nor a plateau that\nremembers the start passes for steady; no "
                 "equilibration time is drawn: a slow drift fools it)"
                 + (f"\n{left_out} run(s) without a length left out" if left_out else ""),
                 fontsize=7.5)
    return _write(fig, figs / "relaxation.png")


def _lengths(ends: set, fixed: bool) -> str:
    """The lengths (fixed) or caps of a set of runs, from its (N, t_end) pairs: one list
    where every N has the same, else the most common and the others by N."""
    by_n = {}
    for n, t in ends:
        by_n.setdefault(n, set()).add(t)
    groups = {}
    for n, ts in sorted(by_n.items()):
        groups.setdefault(tuple(sorted(ts)), []).append(n)
    common = max(groups, key=lambda k: len(groups[k]))
    word = "t_end = " if fixed else "cap "
    text = word + ", ".join(f"{t:g}" for t in common)
    others = [f"{', '.join(f'{t:g}' for t in ts)} at N = {', '.join(map(str, ns))}"
              for ts, ns in groups.items() if ts != common]
    return text + (f" ({'; '.join(others)})" if others else "")


def sizes_figure(out: Path, figs: Path) -> Path | None:
    """The steady curve as the lattice grows: mu_bar against N (log) at every phi all sizes
    were run at, with its error over seeds, and the line fitted on the sizes with at least 3
    seeds (claims_record.size_trend); the sizes of fewer seeds drawn as diamonds (an open marker
    means a drifting point in bkflow's figures)."""
    cs = curves(out)
    steady = [cs[k][0] for k in claims_record.SIZE_CURVES if k in cs]
    if not steady:
        return None
    trend = claims_record.size_trend(pd.concat(steady, ignore_index=True))
    if not trend["phi"]:
        return None
    plt = new_figures()
    fig, ax = plt.subplots(figsize=(4.6, 3.8))
    from bkflow.figures.style import phi_colour

    for phi, v in trend["phi"].items():
        c = phi_colour(float(phi))
        n, m, e = (np.asarray(v[k], float) for k in ("N", "mean", "sem"))
        fit = np.isin(n, v["fitted"])
        ax.errorbar(n[fit], m[fit], yerr=e[fit], color=c, marker="o", ls="none", ms=4,
                    capsize=2, label=rf"$\phi$ = {phi}")
        ax.errorbar(n[~fit], m[~fit], yerr=np.nan_to_num(e[~fit]), color=c, marker="D",
                    ls="none", ms=4, capsize=2)
        if v["slope_per_decade"] is not None:
            x = np.log10(n)
            k = fit
            xm = np.average(x[k], weights=1 / e[k] ** 2)
            ym = np.average(m[k], weights=1 / e[k] ** 2)
            xs = np.linspace(x.min(), x.max(), 20)
            ax.plot(10 ** xs, ym + v["slope_per_decade"] * (xs - xm), color=c, lw=0.8)
    ax.set_xscale("log")
    ax.set_xlabel("N (particles)")
    ax.set_ylabel(r"$\overline{\mu}$ (steady protocol)")
    ax.set_title("The steady state as the lattice grows: circles, fitted (10 seeds);\n"
                 "diamonds, 2 seeds (not fitted); lines: the fit against log N", fontsize=7.5)
    fig.legend(*ax.get_legend_handles_labels(), loc="outside lower center", ncol=5,
               frameon=False, fontsize=7)
    return _write(fig, figs / "sizes.png")


def figures(out: Path, figs: Path) -> list[Path]:
    written = []
    for label, (name, where) in CURVES.items():
        if _tables(out, name, where) is None:
            continue
        sub = figs / label.split(" (")[0].replace(", ", "_").replace(" = ", "").replace(" ", "_")
        paths, _ = plot(out / name, sub, formats=("png",), where=where)
        written += paths
    for make in (protocols_figure, relaxation_figure, sizes_figure):
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
    """The cluster scatter of each lattice of the aspect check (ASPECT_SIZES, N = 100 in the
    top row, N = 400 below; at phi = 0.1 and 2.15, where DT clusters are most common), on
    one pair of axes for every panel, one key for the figure, each panel's counts and regime
    shares under its title and the regions' names where the fewest clusters lie; and the share
    of DT clusters against phi (aspect_share_figure)."""
    plt = new_figures()
    data = SweepData(aspect_dir)
    rows = (len(ASPECT_SIZES) + 2) // 3   # N = 100 above, N = 400 below
    fig, axes = plt.subplots(rows, 3, figsize=(9.0, 3.5 * rows + 0.9), squeeze=False)
    handles = None
    drawn = []
    for ax, (lx, ly) in zip(axes.flat, ASPECT_SIZES):
        if cluster_scatter(data, plt, lx, ly, [2.15443, 0.1],
                           f"N = {lx * ly}: {lx}x{ly} (Lx/Ly = {lx / ly:g})", ax=ax) is None:
            ax.set_title(f"N = {lx * ly}: {lx}x{ly}: no clusters", fontsize=9)
            continue
        leg = ax.get_legend()
        texts = [t.get_text() for t in leg.get_texts()]
        if handles is None:   # the same phi and guides on every panel: one key for all
            handles = list(leg.legend_handles)
            labels = [t.split(":")[0] if t.startswith(r"$\phi$") else t for t in texts]
        leg.remove()
        # each phi's count and regime shares on a line under the title (the shares' own
        # counts, which the key carries, left out: the line fits the panel's width)
        shares = [re.sub(r" \(\d+\)", "", t).replace(" clusters\n(", " clusters: ")
                  .replace(" clusters (", ": ").rstrip(")") for t in texts
                  if t.startswith(r"$\phi$")]
        ax.set_title(f"N = {lx * ly}: {lx}x{ly} (Lx/Ly = {lx / ly:g})\n" + "\n".join(shares),
                     fontsize=7)
        ax.set_xlabel(r"$l_x / l_x^{\mathrm{box}}$")
        ax.set_ylabel(r"$l_y / l_y^{\mathrm{box}}$" if ax in axes[:, 0] else "")
        drawn.append(ax)
    for ax in axes.flat[len(ASPECT_SIZES):]:
        ax.set_visible(False)
    _shared_cluster_axes(drawn)
    if handles is not None:
        fig.legend(handles, labels, loc="outside lower center", ncol=len(handles),
                   frameon=False, fontsize=7.5)
    fig.suptitle(r"Aspect-ratio check: every cluster at $\phi$ = 0.1 and 2.15 (the paper's "
                 "protocol, t_end = 8000), with its regime shares.\n"
                 r"$l^{\mathrm{box}}$: the extent of a slip of the whole box on that side; a "
                 "cluster's mean distance between its particles can exceed it, so values pass 1",
                 fontsize=8)
    return [_write(fig, out / "aspect_clusters.png"), aspect_share_figure(aspect_dir, out)]


def _shared_cluster_axes(axes) -> None:
    """One range for every panel of the cluster scatter (every point inside it), and the
    regions' names (grey text that cluster_scatter placed) moved, each inside its region, to
    where the fewest of the panel's points lie: a name never sits on the data."""
    if not axes:
        return
    pts = {ax: np.concatenate([np.asarray(ln.get_xydata(), float) for ln in ax.get_lines()
                               if ln.get_marker() == "o" and len(ln.get_xdata()) > 0]
                              or [np.empty((0, 2))]) for ax in axes}
    top = max([1.1] + [float(np.nanmax(p)) * 1.03 for p in pts.values() if len(p)])
    span = 0.9
    regions = {"C / W": ((span, top), (span, top)), "LC": ((span, top), (0, span)),
               "DP": ((0, span), (0, span), "below"), "DT": ((0, span), (0, span), "above")}
    for ax in axes:
        ax.set_xlim(-0.03, top)
        ax.set_ylim(-0.03, top)
        for ln in ax.get_lines():   # the DP / DT bound (the diagonal) across the whole range
            if ln.get_linestyle() == "--" and len(ln.get_xdata()) == 2:
                ln.set_data([0, top], [0, top])
        p = pts[ax]
        p = p[np.all(np.isfinite(p), axis=1)]
        for t in list(ax.texts):
            name = t.get_text()
            if name not in regions:
                continue
            (x0, x1), (y0, y1), *side = regions[name]
            gx, gy = np.meshgrid(np.linspace(x0 + 0.06 * top, x1 - 0.06 * top, 12),
                                 np.linspace(y0 + 0.04 * top, y1 - 0.04 * top, 12))
            cand = np.column_stack([gx.ravel(), gy.ravel()])
            if side:   # DP below the diagonal, DT above it (with a margin for the letters)
                keep = cand[:, 1] < cand[:, 0] - 0.08 * top if side[0] == "below" \
                    else cand[:, 1] > cand[:, 0] + 0.08 * top
                cand = cand[keep]
            if not len(cand):
                continue
            d = np.hypot(p[None, :, 0] - cand[:, None, 0], p[None, :, 1] - cand[:, None, 1]) \
                if len(p) else np.full((len(cand), 1), np.inf)
            best = cand[int(np.argmin((d < 0.07 * top).sum(axis=1)))]
            t.set_position(tuple(best))


#: the aspect ratios' colours (Okabe and Ito's palette), one per Lx/Ly
ASPECT_COLOURS = {4.0: "#0072B2", 1.0: "#E69F00", 0.25: "#009E73"}
#: the sizes' line styles and markers (all filled: an open marker means a drifting point in
#: bkflow's other figures)
SIZE_STYLE = {100: ("-", "o"), 400: ("--", "^")}


def aspect_share_figure(aspect_dir: Path, out: Path) -> Path:
    """The share of DT clusters against phi on each lattice of the aspect check, with its
    standard error over seeds (each seed's share of its clusters): the colour is the aspect
    ratio Lx/Ly, the line style and the marker the size (N = 100 solid circles, N = 400
    dashed triangles)."""
    plt = new_figures()
    a, _ = read_tables(aspect_dir)
    fig, ax = plt.subplots(figsize=(4.2, 3.8))
    for lx, ly in ASPECT_SIZES:
        s = a[(a.Lx == lx) & (a.Ly == ly)]
        rows = []
        for phi, g in s.groupby("phi"):
            per_seed = [cluster_share(h, "DT") for _, h in g.groupby("seed")]
            rows.append((phi, cluster_share(g, "DT"), claims_record.standard_error(per_seed)))
        if not rows:
            continue
        x, y, e = (np.asarray(v, float) for v in zip(*rows))
        ls, m = SIZE_STYLE.get(lx * ly, (":", "s"))
        c = ASPECT_COLOURS.get(lx / ly, "0.4")
        ax.errorbar(x, y, yerr=np.nan_to_num(e), marker=m, lw=1.0, color=c, ls=ls, ms=4.5,
                    capsize=2, label=f"N = {lx * ly}: {lx}x{ly} (Lx/Ly = {lx / ly:g})")
    ax.set_xscale("log")
    ax.set_ylim(bottom=-0.02)
    ax.set_xlabel(r"$\phi$")
    ax.set_ylabel("share of DT clusters")
    ax.set_title("Aspect-ratio check: DT clusters (parity-free rule),\nthe paper's "
                 "protocol, t_end = 8000; error bars: standard error over seeds", fontsize=8)
    # below the axes, N = 100 in the first column, N = 400 in the second: it covers no point
    fig.legend(*ax.get_legend_handles_labels(), loc="outside lower center", ncol=2,
               frameon=False, fontsize=7)
    return _write(fig, out / "aspect_dt_share.png")


def claim_record(out: Path, prov: dict | None = None) -> dict:
    """The claims' record (claims.py) of the sweeps under ``out``; ``prov``: the provenance
    taken before this script wrote anything (its own figures and records would make the tree
    dirty), else now."""
    from bkflow.store.provenance import record as provenance

    cs = curves(out)
    aspect = _tables(out, "aspect")
    return claims_record.record(cs, {label: out / CURVES[label][0] for label in cs},
                         (aspect[0], out / "aspect") if aspect is not None else None,
                         ASPECT_SIZES, prov if prov is not None else provenance())


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("--out", default="runs/paper", help="where the runs go (default runs/paper)")
    p.add_argument("--jobs", type=int, default=available_cores())
    p.add_argument("--seeds", type=int, default=10,
                   help="seeds per point (default 10, the seeds the claims are decided on)")
    p.add_argument("--dt-factor", type=float, default=RunSpec.dt_factor)
    p.add_argument("--sizes", default="100,400,900",
                   help="the N of the paper's grid to run, of 100, 400, 900 (default: all)")
    p.add_argument("--protocols", default=",".join(protocols(1, RunSpec.dt_factor)),
                   help="which sweeps to run (default: all)")
    p.add_argument("--figures", default=str(HERE / "figures"))
    p.add_argument("--numbers", default=str(HERE / "numbers.md"),
                   help="where the numbers REPRODUCTION.md cites go (default: beside it)")
    p.add_argument("--claims", default=str(HERE / "claims.json"),
                   help="the record of the claims' tests, which REPRODUCTION.md's generated "
                        "blocks show (default: beside it)")
    a = p.parse_args(argv)
    from bkflow.store.provenance import record as provenance

    prov = provenance()   # the tree as it was asked to run: before this writes its outputs
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
    # the record as the documents read it back (JSON's order and types), rendered from that
    rec = json.loads(json.dumps(claim_record(out, prov)))
    with files.atomic_file(Path(a.claims)) as f:
        f.write(json.dumps(rec, indent=1) + "\n")
    print(f"wrote {a.claims}")
    Path(a.numbers).write_text(numbers(out, wall) + "\n" + claims.render_all(rec))
    print(f"wrote {a.numbers}")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
