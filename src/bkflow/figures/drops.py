"""The sizes of the slips: the stress drops' density for the phi of the cluster figure, with a
power law drawn only where the analysis found it plausible in every seed, and the two
populations of the stiffest (system-wide slips and the rest) (``fig_drops``); the slips'
potencies, their density and against their stress drops (``fig_potency``). The verdicts on a
power law are the analysis's (runs.csv), never fitted here.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from bkflow.analysis.registry import power_law_names
from bkflow.figures.clusters import _cluster_size, cluster_phis
from bkflow.figures.data import SweepData, _point_states
from bkflow.figures.keys import state_key
from bkflow.figures.style import MARKERS, MIN_FONT, STATE_FILL, _num, _size_label, phi_colour


def _log_density(d, bins: int, part=None) -> tuple[np.ndarray, np.ndarray]:
    """Probability density of positive values in logarithmic bins (centres, density); with
    ``part`` (a mask of ``d``), that part's share of it, in the same bins: the parts' densities
    add up to the whole's."""
    lo, hi = d.min(), max(d.max(), d.min() * 1.0001)
    edges = np.geomspace(lo, hi, bins + 1)
    counts, _ = np.histogram(d if part is None else d[part], edges)
    return np.sqrt(edges[:-1] * edges[1:]), counts / (len(d) * np.diff(edges))


def _late_drops(data: SweepData, runs: pd.DataFrame):
    """The drops after the transient of ``runs`` (events.parquet), pooled over the seeds, and
    whether each drop's slip moved every particle of the layer (its largest cluster in
    clusters.csv holds all N; None when a run recorded no clusters)."""
    drops, whole = [], []
    for _, r in runs.iterrows():
        rd = data.run_dir(r)
        e = rd.read_events()
        late = e["late"].fillna(False).astype(bool).to_numpy()
        d = pd.to_numeric(e["drop"], errors="coerce").to_numpy(dtype=float)
        drops.append(d[late])
        c = rd.read_clusters()
        if c is None:
            whole = None
        elif whole is not None:
            largest = c.groupby("event")["n_c"].max()
            n_max = largest.reindex(np.arange(len(e))).to_numpy(dtype=float)
            whole.append((n_max >= int(r.Lx) * int(r.Ly))[late])
    d = np.concatenate(drops) if drops else np.empty(0)
    keep = np.isfinite(d) & (d > 0)
    return d[keep], (np.concatenate(whole)[keep] if whole else None)



def _column(runs: pd.DataFrame, name: str) -> pd.Series:
    """The numbers of a column of ``runs``, NaN where the runs have no such column."""
    return pd.to_numeric(runs[name], errors="coerce") if name in runs \
        else pd.Series(np.nan, index=runs.index)


def _drop_verdict(runs: pd.DataFrame, key: str = "drop") -> tuple[bool, str]:
    """Whether the seeds' stress drops (``key`` "drop"; "potency": the slips' potencies)
    follow a power law, from their analyses (runs.csv: ``drop_power_law``, ``drop_fit_p``,
    ``drop_vs_lognormal[_p]``, named by ``bkflow.analysis.registry.power_law_names``):
    plausible only when it is in every seed and no seed's lognormal is significantly better
    (R < 0, p < 0.1); and the key's words."""
    verdict, fit_p, vs_lognormal, vs_lognormal_p = power_law_names(key)
    verdicts = runs[verdict].astype(str).tolist() if verdict in runs \
        else ["no fit"] * len(runs)
    p = _column(runs, fit_p)
    R, Rp = _column(runs, vs_lognormal), _column(runs, vs_lognormal_p)
    favoured = int(((R < 0) & (Rp < 0.1)).sum())  # seeds whose lognormal is significantly better
    if verdicts and all(v == "plausible" for v in verdicts):
        return _plausible(runs, key, p, favoured)
    return False, _rejected(runs, key, verdicts, p, favoured)


def _plausible(runs: pd.DataFrame, key: str, p: pd.Series, favoured: int) -> tuple[bool, str]:
    """The verdict where the power law is plausible in every seed (``_drop_verdict``): drawn
    with the seeds' mean exponent, unless a lognormal is significantly better in ``favoured``
    seeds."""
    n = len(runs)
    if favoured:
        return False, (f"a lognormal favoured in {favoured} of {n} seeds" if n > 1 else
                       "a lognormal favoured") + f" (power law p >= {p.min():.2f})"
    alpha = _column(runs, f"{key}_exponent").mean()
    err = _column(runs, f"{key}_exponent_err").mean()
    return True, (rf"$\alpha$ = {alpha:.2f} $\pm$ {err:.2f} (p >= {p.min():.2f}"
                  + (f" in all {n} seeds)" if n > 1 else ")"))


def _rejected(runs: pd.DataFrame, key: str, verdicts, p: pd.Series, favoured: int) -> str:
    """The key's words where the power law is not plausible in every seed (``_drop_verdict``):
    in how many seeds it was rejected, at what p, and whether a lognormal was favoured in each
    of them; "no fit" where no seed rejected it."""
    n = len(verdicts)
    rejected = sum(v == "rejected" for v in verdicts)
    if not rejected:
        return "no fit"
    lognormal = favoured == rejected
    worst = p[runs[power_law_names(key)[0]].astype(str) == "rejected"].max()
    shown = "p < 0.001" if worst < 0.001 else f"p <= {worst:.2f}"
    return ("power law rejected" + (f" in {rejected} of {n} seeds" if n > 1 else "")
            + f" ({shown}" + (", lognormal favoured)" if lognormal else ")"))


def _point_fill(points: pd.DataFrame, phi: float) -> str:
    """How the markers of ``phi`` are filled: by its point's state (``STATE_FILL``; a phi
    without a point of the tables as a drifting one)."""
    state = _point_states(points[np.isclose(points.phi, phi, rtol=1e-9, atol=0)])
    return STATE_FILL.get(state[0] if len(state) else "drifting", "none")


def _fitted_law(ax, runs: pd.DataFrame, key: str, values: np.ndarray, colour) -> None:
    """The fitted density of ``values`` over the tail (the seeds' mean exponent of ``key``
    above their x_min), scaled by the tail's share of all ``values``."""
    alpha = pd.to_numeric(runs[f"{key}_exponent"], errors="coerce").mean()
    x_min = pd.to_numeric(runs[f"{key}_x_min"], errors="coerce").mean()
    xs = np.geomspace(x_min, values.max(), 50)
    share = np.mean(values >= x_min)
    ax.plot(xs, share * (alpha - 1) / x_min * (xs / x_min) ** -alpha, color=colour, lw=0.8)


def fig_drops(data: SweepData, plt):
    """(a) Density of stress-drop sizes after the transient (events.parquet, the seeds pooled)
    for the phi of the cluster figure (``cluster_phis``; those with two drops or more are
    drawn), with the maximum-likelihood power law drawn only where the analysis found it
    plausible in every seed (Clauset et al.'s bootstrap, p >= 0.1; runs.csv
    ``drop_power_law``), else the rejection written in the key.
    (b) The stiffest phi drawn in (a) whose runs recorded clusters, split into its two
    populations: slips that move every particle of the layer (system-wide) and the rest,
    each density weighted by its share so that the two add up to (a)'s; its title says which
    of (a)'s phi it is, counted from the data. Markers by the point's state
    (``STATE_FILL``), colours by phi (``phi_colour``)."""
    lx, ly = _cluster_size(data)
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(7.4, 3.6))
    points = data.results_of(lx, ly)
    drawn, stiff, lines = [], None, 0
    for phi, m in zip(cluster_phis(data.runs_of(lx, ly).phi), MARKERS):
        colour = phi_colour(phi)
        runs = data.runs_of(lx, ly, phi)
        d, whole = _late_drops(data, runs)
        if len(d) < 2:
            continue
        drawn.append(phi)
        plausible, words = _drop_verdict(runs)
        fill = _point_fill(points, phi)
        x, dens = _log_density(d, 15)
        nz = dens > 0
        ax.plot(x[nz], dens[nz], m, color=colour, fillstyle=fill,
                mfc=colour if fill != "none" else "white", mfcalt="white",
                label=rf"$\phi$ = {_num(phi)}: {words}")
        if plausible:
            _fitted_law(ax, runs, "drop", d, colour)
            lines += 1
        if whole is not None and (stiff is None or phi > stiff[0]):
            stiff = (phi, d, whole, colour, fill)
    if not drawn:  # no run had two stress drops after its transient
        return None
    for a in (ax, bx):
        a.set_xscale("log")
        a.set_yscale("log")
        a.set_xlabel(r"stress drop $\Delta\sigma_x$ ($k_d/l$)")
    ax.set_ylabel("probability density")
    bx.set_ylabel("probability density (of all drops)")
    ax.set_title(f"stress-drop sizes, {_size_label(lx, ly)}\n" + (
        "lines: power laws that pass Clauset et al.'s test (p >= 0.1)" if lines else
        "no power law passes Clauset et al.'s test (p >= 0.1)"), fontsize=8)
    state_key(fig, data)
    # below the axes: a rejection's words never cover a point
    ax.legend(frameon=False, fontsize=MIN_FONT, loc="upper left", bbox_to_anchor=(-0.02, -0.2))
    if stiff is None:
        bx.text(0.5, 0.5, "no cluster data\n(scene without slip frames)",
                transform=bx.transAxes, ha="center", va="center", fontsize=MIN_FONT)
        return fig
    _populations(bx, stiff, drawn)
    return fig


def _populations(bx, stiff: tuple, drawn) -> None:
    """fig_drops' (b): the drops of the stiffest phi with slip clusters (``stiff``: phi, its
    drops, whether each moved every particle, its colour and fill) as two densities in (a)'s
    bins, system-wide and partial, each weighted by its share."""
    phi, d, whole, colour, fill = stiff
    for part, label, m, ls in ((whole, "system-wide (every particle slips)", "^", "-"),
                               (~whole, "partial", "v", "--")):
        x, dens = _log_density(d, 15, part)  # (a)'s bins: the two add up to (a)'s density
        nz = dens > 0
        if nz.any():
            bx.plot(x[nz], dens[nz], marker=m, ls=ls, color=colour, lw=0.8, fillstyle=fill,
                    mfc=colour if fill != "none" else "white", mfcalt="white",
                    label=f"{label}: {np.mean(part):.0%} of {len(d)}")
    bx.set_title(rf"two populations at $\phi$ = {_num(phi)}" + "\n(" + _which(phi, drawn)
                 + ")", fontsize=8)
    bx.legend(frameon=False, fontsize=MIN_FONT, loc="upper left", bbox_to_anchor=(-0.02, -0.2))


def _which(phi: float, drawn) -> str:
    """Which of the phi ``drawn`` ``phi`` is, in words from their number: "the stiffest of
    the three in (a)", "the only one in (a)", or, when a stiffer one drawn in (a) recorded
    no clusters, "the stiffest with slip clusters"."""
    words = {2: "two", 3: "three", 4: "four", 5: "five", 6: "six"}
    if len(drawn) == 1:
        return "the only one in (a)"
    if phi < max(drawn):
        return "the stiffest with slip clusters"
    return f"the stiffest of the {words.get(len(drawn), len(drawn))} in (a)"


def _late_potencies(data: SweepData, runs: pd.DataFrame):
    """(potencies, stress drops) of the slips after the transient that have a potency
    (events.parquet of scenes with slip frames), pooled over the seeds."""
    pot, drops = [], []
    for _, r in runs.iterrows():
        e = data.run_dir(r).read_events()
        if "potency" not in e:
            continue
        late = e["late"].fillna(False).astype(bool).to_numpy()
        pot.append(pd.to_numeric(e["potency"], errors="coerce").to_numpy(float)[late])
        drops.append(pd.to_numeric(e["drop"], errors="coerce").to_numpy(float)[late])
    if not pot:
        return np.empty(0), np.empty(0)
    p, d = np.concatenate(pot), np.concatenate(drops)
    keep = np.isfinite(p) & (p > 0)
    return p[keep], d[keep]



def fig_potency(data: SweepData, plt):
    """The magnitude-frequency view, beside fig_drops: (a) the density of the slips'
    potencies after the transient for the phi of the cluster figure (``cluster_phis``), the
    seeds pooled, with the analysis's verdict on a power law in the key (runs.csv
    ``potency_power_law``; the fitted law drawn where it is plausible in every seed); (b) each
    slip's potency against its stress drop, the largest set drawn lowest.

    The potency is events.parquet's ``potency`` (bkflow.observables.catalogue): the sum over the
    slipping particles of their slips in x, sum_i dx_i, a length in lattice units l. (Seismic
    potency, slip times area, is this times the area l^2 each particle stands for: l^3; the axes
    show the sum as computed, so their unit is l.)"""
    lx, ly = _cluster_size(data)
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(7.4, 3.6))
    points = data.results_of(lx, ly)
    drawn = 0
    for phi, m in zip(cluster_phis(data.runs_of(lx, ly).phi), MARKERS):
        colour = phi_colour(phi)
        runs = data.runs_of(lx, ly, phi)
        pot, drops = _late_potencies(data, runs)
        if len(pot) < 2:
            continue
        drawn += 1
        plausible, words = _drop_verdict(runs, "potency")
        fill = _point_fill(points, phi)
        style_ = dict(color=colour, fillstyle=fill, mfcalt="white",
                      mfc=colour if fill != "none" else "white")
        x, dens = _log_density(pot, 15)
        nz = dens > 0
        ax.plot(x[nz], dens[nz], m, label=rf"$\phi$ = {_num(phi)}: {words}", **style_)
        if plausible:
            _fitted_law(ax, runs, "potency", pot, colour)
        # the largest set lowest: a sparse one is drawn over it, not under it
        bx.plot(drops, pot, m, ms=2.5, alpha=0.6, ls="none", zorder=2 + 1 / len(pot),
                **style_)
    if not drawn:  # no run recorded slip frames
        return None
    for a in (ax, bx):
        a.set_xscale("log")
        a.set_yscale("log")
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    for axis in (ax.xaxis, bx.yaxis):  # potencies span a decade or two: 1-2-5 ticks, plain
        axis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
        axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        axis.set_minor_formatter(NullFormatter())
    ax.set_xlabel(r"potency $\sum_i \Delta x_i$ of the slipping particles ($l$)")
    ax.set_ylabel("probability density")
    ax.set_title(f"potencies, {_size_label(lx, ly)}: a law drawn only where\nClauset et al.'s "
                 "test passes (p >= 0.1) and a lognormal is not favoured", fontsize=8)
    bx.set_xlabel(r"stress drop $\Delta\sigma_x$ ($k_d/l$)")
    bx.set_ylabel(r"potency $\sum_i \Delta x_i$ ($l$)")
    bx.set_title("each slip's potency against its stress drop", fontsize=8)
    state_key(fig, data)
    # below the axis label (two lines tall with its sum)
    ax.legend(frameon=False, fontsize=MIN_FONT, loc="upper left",
              bbox_to_anchor=(-0.02, -0.27))
    return fig

