"""The aspect-ratio check (claim 5: with Lx <= Ly the DT regime does not appear): its tables
in numbers.md (``aspect_numbers``) and its figures (``aspect_figures``: every cluster of each
lattice, and the share of DT clusters against phi)."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
from claims_record import cluster_share, standard_error
from paper_figures import write_figure
from paper_sweeps import ASPECT_SIZES

from bkflow.figures.clusters import cluster_scatter
from bkflow.figures.data import SweepData
from bkflow.figures.style import new_figures
from bkflow.model.lattice import box_fractions
from bkflow.model.settings import AnalysisSettings
from bkflow.store import formats
from bkflow.store.rundir import sweep_run_dir
from bkflow.store.tables import SETTINGS_FILE, read_tables, settings_in


def span_fraction(sweep_dir: Path) -> float:
    """The fraction of the box from which the sweep's analysis counts an axis as spanned."""
    settings = settings_in(formats.read_json(Path(sweep_dir) / SETTINGS_FILE))
    return AnalysisSettings.from_dict(settings).span_fraction


def aspect_numbers(aspect_dir: Path, a: pd.DataFrame) -> list[str]:
    """numbers.md's sections of the aspect check (its runs ``a``): the share of DT clusters
    per phi and lattice, and the clusters' shapes over all phi and seeds."""
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
    return [write_figure(fig, out / "aspect_clusters.png"), aspect_share_figure(aspect_dir, out)]


def _shared_cluster_axes(axes) -> None:
    """One range for every panel of the cluster scatter (every point inside it), and the
    regions' names (grey text that cluster_scatter placed) moved, each inside its region, to
    where the fewest of the panel's points lie: a name never sits on the data."""
    if not axes:
        return
    pts = {ax: _scatter_points(ax) for ax in axes}
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
            best = _emptiest_place(regions[name], p, top)
            if best is not None:
                t.set_position(best)


def _scatter_points(ax) -> np.ndarray:
    """The (x, y) of every cluster a cluster scatter drew on ``ax`` (its "o" markers)."""
    return np.concatenate([np.asarray(ln.get_xydata(), float) for ln in ax.get_lines()
                           if ln.get_marker() == "o" and len(ln.get_xdata()) > 0]
                          or [np.empty((0, 2))])


def _emptiest_place(region: tuple, p: np.ndarray, top: float) -> tuple | None:
    """Where in ``region`` ((x0, x1), (y0, y1)[, "below" or "above" the diagonal]) of a
    cluster scatter whose range ends at ``top`` the fewest of the points ``p`` lie near: the
    place of the region's name (None where the region leaves no room)."""
    (x0, x1), (y0, y1), *side = region
    gx, gy = np.meshgrid(np.linspace(x0 + 0.06 * top, x1 - 0.06 * top, 12),
                         np.linspace(y0 + 0.04 * top, y1 - 0.04 * top, 12))
    cand = np.column_stack([gx.ravel(), gy.ravel()])
    if side:   # DP below the diagonal, DT above it (with a margin for the letters)
        keep = cand[:, 1] < cand[:, 0] - 0.08 * top if side[0] == "below" \
            else cand[:, 1] > cand[:, 0] + 0.08 * top
        cand = cand[keep]
    if not len(cand):
        return None
    d = np.hypot(p[None, :, 0] - cand[:, None, 0], p[None, :, 1] - cand[:, None, 1]) \
        if len(p) else np.full((len(cand), 1), np.inf)
    return tuple(cand[int(np.argmin((d < 0.07 * top).sum(axis=1)))])


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
            rows.append((phi, cluster_share(g, "DT"), standard_error(per_seed)))
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
    return write_figure(fig, out / "aspect_dt_share.png")

