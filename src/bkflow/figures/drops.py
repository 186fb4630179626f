"""The sizes of the slips: the stress drops' density for the phi of the cluster figure, with a
power law drawn only where the analysis found it plausible in every seed it fitted, and the two
populations of the stiffest (system-wide slips and the rest) (``fig_drops``); the slips'
potencies, their density and against their stress drops (``fig_potency``). The verdicts on a
power law are the analysis's (runs.csv), never fitted here, and rest on the runs whose state is
steady or switching between steady states (``FITTED_STATES``): one verdict per phi
(``power_law_verdict``) gives both a figure's key and its title.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from bkflow.analysis.summary_keys import power_law_names
from bkflow.figures.clusters import cluster_phis, cluster_size
from bkflow.figures.data import SweepData, point_states
from bkflow.figures.legends import state_legend
from bkflow.figures.style import (
    COLUMN_WIDTH,
    MIN_FONT,
    phi_colour,
    plain_log_ticks,
    size_label,
    state_marker,
    value_label,
)
from bkflow.observables.stress import N_BOOT

#: the states (``point_states``) of the runs whose power-law fits a figure states and draws:
#: a steady window, or one switching between the layer's steady states (docs/model.md "Steady
#: state"); a drifting or metastable run's slips are in the densities, not in the verdict
FITTED_STATES = ("steady", "switching")
#: the densities' axes: a probability density of x is per unit of x, its unit 1/[x] (the
#: stress drop in k_d/l, the potency in l); on two lines, to fit beside a short panel.
#: fig_drops' (b): each population's share of the density of every drop
DROP_DENSITY = "probability density\nof $\\Delta\\sigma_x$ ($l/k_d$)"
DROP_DENSITY_ALL = "probability density of\n$\\Delta\\sigma_x$, all drops ($l/k_d$)"
POTENCY_DENSITY = "probability density\nof the potency ($l^{-1}$)"
#: the size of fig_drops and fig_potency (inches): two panels side by side, within a 7 in
#: column as saved (``COLUMN_WIDTH``), the key below them
DENSITY_SIZE = (COLUMN_WIDTH - 0.2, 3.5)


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


@dataclass(frozen=True)
class Verdict:
    """What a figure says of one phi's power law (``power_law_verdict``): ``kind`` "drawn"
    (plausible in every fitted seed, a lognormal significantly better in none: the law is
    drawn), "lognormal" (plausible in every fitted seed, a lognormal significantly better in
    some), "rejected" (in some fitted seed), "no fit" or "not fitted" (no seed in
    ``FITTED_STATES``); ``words``, the key's; ``runs``, the seeds fitted."""

    kind: str
    words: str
    runs: pd.DataFrame

    @property
    def drawn(self) -> bool:
        return self.kind == "drawn"


def power_law_verdict(runs: pd.DataFrame, key: str = "drop") -> Verdict:
    """The verdict on a power law of one phi's seeds ``runs`` (``key`` "drop": the stress
    drops; "potency": the slips' potencies), from the analyses of those whose state is in
    ``FITTED_STATES`` (runs.csv ``drop_power_law``, ``drop_fit_p``, ``drop_vs_lognormal[_p]``,
    named by ``bkflow.analysis.summary_keys.power_law_names``); the key says how many seeds it
    rests on where it leaves some out."""
    fitted = runs[np.isin(point_states(runs), FITTED_STATES)]
    n, k = len(runs), len(fitted)
    if not k:
        return Verdict("not fitted", "not fitted: no seed steady or switching", fitted)
    kind, words = _judge(fitted, key)
    if k < n:
        words += f"; {k} of {n} seeds fitted (steady or switching)"
    return Verdict(kind, words, fitted)


def _judge(runs: pd.DataFrame, key: str) -> tuple[str, str]:
    """(kind, words) of ``Verdict`` for the fitted seeds ``runs``: plausible only when it is
    in every seed and no seed's lognormal is significantly better (R < 0, p < 0.1)."""
    verdict, fit_p, vs_lognormal, vs_lognormal_p = power_law_names(key)
    verdicts = runs[verdict].astype(str).tolist() if verdict in runs \
        else ["no fit"] * len(runs)
    p = _column(runs, fit_p)
    R, Rp = _column(runs, vs_lognormal), _column(runs, vs_lognormal_p)
    favoured = int(((R < 0) & (Rp < 0.1)).sum())  # seeds whose lognormal is significantly better
    n = len(runs)
    if verdicts and all(v == "plausible" for v in verdicts):
        if favoured:
            return "lognormal", (f"power law {_p_words('>=', p.min())}, but a lognormal "
                                 "favoured" + (f" in {favoured} of {n} seeds" if n > 1 else ""))
        alpha = _column(runs, f"{key}_exponent").mean()
        err = _column(runs, f"{key}_exponent_err").mean()
        return "drawn", (rf"$\alpha$ = {alpha:.2f} $\pm$ {err:.2f} ({_p_words('>=', p.min())}"
                         + (f" in all {n} seeds)" if n > 1 else ")"))
    rejected = [v == "rejected" for v in verdicts]
    if not any(rejected):
        return "no fit", "no fit"
    worst = p[np.asarray(rejected)].max()
    return "rejected", ("power law rejected"
                        + (f" in {sum(rejected)} of {n} seeds" if n > 1 else "")
                        + f" ({_p_words('<=', worst)}"
                        + (", lognormal favoured)" if favoured == sum(rejected) else ")"))


def _p_words(op: str, p: float) -> str:
    """A bootstrap p for a key: "p >= 0.18", "p <= 0.003"; "p < 0.001" below the bootstrap's
    resolution (1 / N_BOOT: none of its samples fitted worse), never "p <= 0.00"."""
    if not np.isfinite(p):
        return "p n/a"
    if p < 1.0 / N_BOOT:
        return f"p < {1.0 / N_BOOT:g}"
    return f"p {op} {p:.2g}"


def _law_title(verdicts) -> str:
    """The line of a density's title that says where a power law is drawn, from the same
    verdicts as the key (``power_law_verdict``): the rule, and at how many of the phi drawn
    it holds."""
    drawn = sum(v.drawn for v in verdicts)
    return ("lines: power law passes Clauset et al.'s test (p >= 0.1)\n"
            f"in every fitted seed, no lognormal favoured: {drawn} of {len(verdicts)} phi")


def _phi_label(phi: float, state: str, verdict: Verdict) -> str:
    """A phi's entry in a density's key: its value, its point's state (its marker's) and the
    verdict's words, the seeds it rests on (where it leaves some out) on a line of their own,
    so that the key fits a 7 in column."""
    return rf"$\phi$ = {value_label(phi)} ({state}): " + verdict.words.replace("; ", ";\n")


def _point_state(points: pd.DataFrame, phi: float) -> str:
    """The state of the point of ``phi`` (``point_states``; a phi without a point of the
    tables as a drifting one), whose marker its densities are drawn with."""
    state = point_states(points[np.isclose(points.phi, phi, rtol=1e-9, atol=0)])
    return str(state[0]) if len(state) else "drifting"


def _fitted_law(ax, runs: pd.DataFrame, key: str, values: np.ndarray, colour) -> None:
    """The fitted density of ``values`` over the tail (the fitted seeds' mean exponent of
    ``key`` above their x_min), scaled by the tail's share of all ``values``."""
    alpha = pd.to_numeric(runs[f"{key}_exponent"], errors="coerce").mean()
    x_min = pd.to_numeric(runs[f"{key}_x_min"], errors="coerce").mean()
    xs = np.geomspace(x_min, values.max(), 50)
    share = np.mean(values >= x_min)
    ax.plot(xs, share * (alpha - 1) / x_min * (xs / x_min) ** -alpha, color=colour, lw=0.8)


def _density_key(fig, data: SweepData) -> None:
    """A density figure's key, below its panels across the figure's width: one row per phi
    (its colour, its state's marker, the verdict), titled with the runs' protocol."""
    state_legend(fig, data, ax=fig.axes[0], states=(), ncol=1)


def _log_axes(*axes) -> None:
    """Both axes of each of ``axes`` on log scales, with ticks that never overlap
    (``plain_log_ticks``)."""
    for a in axes:
        a.set_xscale("log")
        a.set_yscale("log")
        for axis, (lo, hi) in ((a.xaxis, a.get_xlim()), (a.yaxis, a.get_ylim())):
            plain_log_ticks(axis, lo, hi)


def fig_drops(data: SweepData, plt):
    """(a) Density of stress-drop sizes after the transient (events.parquet, the seeds pooled)
    for the phi of the cluster figure (``cluster_phis``; those with two drops or more are
    drawn), with the maximum-likelihood power law drawn only where the analysis found it
    plausible in every fitted seed (``power_law_verdict``: Clauset et al.'s bootstrap,
    p >= 0.1, runs.csv ``drop_power_law``, and no lognormal favoured), else why not in the
    key; the title says at how many phi it is drawn, from the same verdicts.
    (b) The stiffest phi drawn in (a) whose runs recorded clusters, split into its two
    populations: slips that move every particle of the layer (system-wide) and the rest,
    each density weighted by its share so that the two add up to (a)'s; its title says which
    of (a)'s phi it is, counted from the data. Markers by the point's state
    (``state_marker``), colours by phi (``phi_colour``)."""
    lx, ly = cluster_size(data)
    fig, (ax, bx) = plt.subplots(1, 2, figsize=DENSITY_SIZE)
    points = data.results_of(lx, ly)
    drawn, stiff, verdicts = [], None, []
    for phi in cluster_phis(data.runs_of(lx, ly).phi):
        colour = phi_colour(phi)
        runs = data.runs_of(lx, ly, phi)
        d, whole = _late_drops(data, runs)
        if len(d) < 2:
            continue
        drawn.append(phi)
        verdict = power_law_verdict(runs)
        verdicts.append(verdict)
        state = _point_state(points, phi)
        x, dens = _log_density(d, 15)
        nz = dens > 0
        ax.plot(x[nz], dens[nz], ls="none", label=_phi_label(phi, state, verdict),
                **state_marker(state, colour, 5.5))
        if verdict.drawn:
            _fitted_law(ax, verdict.runs, "drop", d, colour)
        if whole is not None and (stiff is None or phi > stiff[0]):
            stiff = (phi, d, whole, colour, state)
    if not drawn:  # no run had two stress drops after its transient
        return None
    for a in (ax, bx):
        a.set_xlabel(r"stress drop $\Delta\sigma_x$ ($k_d/l$)")
    ax.set_ylabel(DROP_DENSITY)
    bx.set_ylabel(DROP_DENSITY_ALL)
    ax.set_title(f"stress-drop sizes, {size_label(lx, ly)}\n" + _law_title(verdicts),
                 fontsize=MIN_FONT + 0.5)
    _density_key(fig, data)
    if stiff is None:
        bx.text(0.5, 0.5, "no cluster data\n(scene without slip frames)",
                transform=bx.transAxes, ha="center", va="center", fontsize=MIN_FONT)
    else:
        _populations(bx, stiff, drawn)
    _log_axes(ax, *([bx] if stiff is not None else []))
    return fig


def _populations(bx, stiff: tuple, drawn) -> None:
    """fig_drops' (b): the drops of the stiffest phi with slip clusters (``stiff``: phi, its
    drops, whether each moved every particle, its colour and state) as two densities in (a)'s
    bins, system-wide and partial, each weighted by its share, told apart by their lines."""
    phi, d, whole, colour, state = stiff
    for part, label, ls in ((whole, "system-wide (every particle slips)", "-"),
                            (~whole, "partial", (0, (4, 2)))):
        x, dens = _log_density(d, 15, part)  # (a)'s bins: the two add up to (a)'s density
        nz = dens > 0
        if nz.any():
            bx.plot(x[nz], dens[nz], ls=ls, lw=0.9, label=f"{label}: {np.mean(part):.0%} "
                    f"of {len(d)}", **state_marker(state, colour, 5.0))
    bx.set_title(rf"two populations at $\phi$ = {value_label(phi)}" + "\n(" + _which(phi, drawn)
                 + ")", fontsize=MIN_FONT + 0.5)
    bx.legend(frameon=False, fontsize=MIN_FONT, loc="upper left", bbox_to_anchor=(-0.02, -0.2),
              handlelength=2.6)


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
    ``potency_power_law`` of the seeds steady or switching, ``power_law_verdict``; the
    fitted law drawn where it is plausible in every one of them, the title saying at how many
    phi); (b) each slip's potency against its stress drop, the largest set drawn lowest.

    The potency is events.parquet's ``potency`` (bkflow.observables.catalogue): the sum over the
    slipping particles of their slips in x, sum_i dx_i, a length in lattice units l. (Seismic
    potency, slip times area, is this times the area l^2 each particle stands for: l^3; the axes
    show the sum as computed, so their unit is l.)"""
    lx, ly = cluster_size(data)
    fig, (ax, bx) = plt.subplots(1, 2, figsize=DENSITY_SIZE)
    points = data.results_of(lx, ly)
    verdicts = []
    for phi in cluster_phis(data.runs_of(lx, ly).phi):
        colour = phi_colour(phi)
        runs = data.runs_of(lx, ly, phi)
        pot, drops = _late_potencies(data, runs)
        if len(pot) < 2:
            continue
        verdict = power_law_verdict(runs, "potency")
        verdicts.append(verdict)
        state = _point_state(points, phi)
        x, dens = _log_density(pot, 15)
        nz = dens > 0
        ax.plot(x[nz], dens[nz], ls="none", label=_phi_label(phi, state, verdict),
                **state_marker(state, colour, 5.5))
        if verdict.drawn:
            _fitted_law(ax, verdict.runs, "potency", pot, colour)
        # the largest set lowest: a sparse one is drawn over it, not under it
        bx.plot(drops, pot, ls="none", alpha=0.6, zorder=2 + 1 / len(pot),
                **state_marker(state, colour, 2.5))
    if not verdicts:  # no run recorded slip frames
        return None
    ax.set_xlabel(r"potency $\sum_i \Delta x_i$ of the slipping particles ($l$)")
    ax.set_ylabel(POTENCY_DENSITY)
    ax.set_title(f"potencies, {size_label(lx, ly)}\n" + _law_title(verdicts),
                 fontsize=MIN_FONT + 0.5)
    bx.set_xlabel(r"stress drop $\Delta\sigma_x$ ($k_d/l$)")
    bx.set_ylabel(r"potency $\sum_i \Delta x_i$ ($l$)")
    bx.set_title("each slip's potency against its stress drop", fontsize=MIN_FONT + 0.5)
    _density_key(fig, data)
    _log_axes(ax, bx)
    return fig
