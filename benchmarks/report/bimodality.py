"""Two states or one: whether a stiff layer's blocks fall into two groups, the quiet and the
coherent of bkflow.observables.states, or spread about one mode that the threshold cuts.

    python -m benchmarks.report.bimodality   # bimodality.png and records/bimodality.json

From the long runs of benchmarks/measure/stiff_states.py (benchmarks/records/stiff_states/,
loaded by benchmarks/report/stiff_states.py: every run's first 20% left out, every seed and
start of a layer pooled). A block of 1000 time units is quiet when its coherence R (the mean
of |Z| over the block) is below sqrt(pi / 4N), else coherent. Per (N, phi):

- Sarle's bimodality coefficient b = (g^2 + 1) / (k + 3 (n - 1)^2 / ((n - 2)(n - 3))) of the
  blocks' R and of their mean stress (g the skewness, k the excess kurtosis; scipy.stats,
  bias-corrected): a normal distribution has 1/3, a uniform 5/9; b > 5/9 suggests two modes
  (a skewed single mode can reach it too, so it is a hint, not a test). The blocks follow
  each other closely in time (a state lasts 10^4-10^5 time units), so no p-value is given;
  and the seeds pooled are layers with different means, which widens the distribution. The
  record gives b over each seed's blocks too (its range), and b without the synchronized
  start's runs (its memory can outlast the 20% left out of the short runs at N = 900);
- the quiet share of the blocks under block lengths 1000, 2000 and 5000 time units
  (consecutive blocks of a run merged, weighted by their samples, a run's remainder left out)
  and thresholds 0.5, 1 and 2 times sqrt(pi / 4N).

The figure: per phi (a soft one for contrast, then the stiff end) the histograms of R (in
units of the threshold) and of the stress at each N, and their joint distribution per N; below,
the quiet share under each block length and threshold.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from benchmarks.harness import BENCH, RECORDS, parser, write_json
from benchmarks.measure.stiff_states import OUT
from benchmarks.report import stiff_states
from bkflow.observables.states import r_independent

FIGURE = BENCH / "bimodality.png"
RECORD = RECORDS / "bimodality.json"
#: the figure's phi: a soft layer for contrast, then the stiff end
PHIS = (10.0, 215.0, 464.0, 1000.0)
SIZES = (100, 400, 900)
SIZE_COLOURS = {100: "tab:blue", 400: "tab:orange", 900: "tab:green"}
#: block lengths (time units; the records' blocks are 1000) and threshold factors
LENGTHS = (1000, 2000, 5000)
LENGTH_MARKERS = {1000: ("o", "-", 5.0), 2000: ("s", "--", 4.0), 5000: ("^", ":", 3.5)}
#: the block lengths' points are drawn this far apart (a factor in x) where they coincide
DODGE = {1000: 1 / 1.08, 2000: 1.0, 5000: 1.08}
FACTORS = (0.5, 1.0, 2.0)
#: the layer whose seeds are drawn one by one (the one with most quiet blocks)
SEEDS_SHOWN = (100, 1000.0)
#: Sarle's coefficient above this (a uniform distribution's) suggests two modes
SARLE_BIMODAL = 5 / 9
MIN_FONT = 7.0


def sarle(x) -> float:
    """Sarle's bimodality coefficient of the sample ``x`` (module doc)."""
    from scipy.stats import kurtosis, skew

    x = np.asarray(x, float)
    n = len(x)
    if n < 4 or np.ptp(x) == 0:
        return float("nan")
    g, k = skew(x, bias=False), kurtosis(x, bias=False)
    return float((g ** 2 + 1) / (k + 3 * (n - 1) ** 2 / ((n - 2) * (n - 3))))


def merged(b: pd.DataFrame, k: int) -> pd.DataFrame:
    """Blocks of one run, every ``k`` consecutive ones merged (R and the stress s weighted by
    their samples n); the last blocks that make no whole group are left out."""
    m = len(b) // k * k
    w = b.n.to_numpy(float)[:m].reshape(-1, k)
    return pd.DataFrame({c: (b[c].to_numpy(float)[:m].reshape(-1, k) * w).sum(1) / w.sum(1)
                         for c in ("R", "s")})


def layer(runs: pd.DataFrame, n: int, phi: float, k: int = 1) -> pd.DataFrame:
    """The kept blocks of every run of (n, phi), ``k`` merged into one, with their seed."""
    g = runs[(runs.N == n) & (runs.phi == phi)]
    parts = [merged(r.blocks, k).assign(seed=r.seed) for _, r in g.iterrows()]
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(
        columns=["R", "s", "seed"])


def numbers(runs: pd.DataFrame, n: int, phi: float) -> dict:
    """What the record holds of one layer (N, phi)."""
    r0 = r_independent(n)
    out = {"N": int(n), "phi": float(phi), "threshold": round(r0, 6),
           "runs": int(((runs.N == n) & (runs.phi == phi)).sum()),
           "sarle_R": {}, "sarle_stress": {}, "quiet": {}}
    for length in LENGTHS:
        b = layer(runs, n, phi, length // 1000)
        key = str(length)
        if length == LENGTHS[0]:
            out["blocks"] = len(b)
            out["seeds"] = sorted(int(s) for s in b.seed.unique())
            per_seed = [sarle(g.R) for _, g in b.groupby("seed")]
            out["sarle_R_seeds"] = [round(min(per_seed), 4), round(max(per_seed), 4)]
        out["sarle_R"][key] = round(sarle(b.R), 4)
        out["sarle_stress"][key] = round(sarle(b.s), 4)
        out["quiet"][key] = {f"{f:g}": round(float((b.R < f * r0).mean()), 4) for f in FACTORS}
    b = layer(runs[runs.start != "synchronized"], n, phi)
    out["sarle_without_synchronized"] = {"R": round(sarle(b.R), 4), "stress": round(sarle(b.s), 4)}
    return out


def record(runs: pd.DataFrame) -> dict:
    layers = [numbers(runs, n, phi) for (n, phi), _ in runs.groupby(["N", "phi"])]
    return {"comment": "written by benchmarks/report/bimodality.py from "
                       "benchmarks/records/stiff_states (see its docstring): per (N, phi) "
                       "Sarle's bimodality coefficient of the blocks' R and stress at each "
                       "block length, its range over the seeds (R, blocks of 1000), both "
                       "without the synchronized start's runs (blocks of 1000), and the quiet "
                       "share at each block length and threshold factor (of sqrt(pi / 4N))",
            "block_lengths": list(LENGTHS), "factors": list(FACTORS),
            "sarle_bimodal": round(SARLE_BIMODAL, 6), "layers": layers}


# ------------------------------------------------------------------------------ the figure
def _thresholds(ax, how="v") -> None:
    line = ax.axvline if how == "v" else ax.axhline
    for f in FACTORS:
        line(f, color="k" if f == 1 else "0.45", lw=0.9 if f == 1 else 0.7,
             ls="--" if f == 1 else ":")


def _histograms(ax_r, ax_s, runs, phi, x_max) -> None:
    """R (in units of the threshold) and the stress of each N's blocks, each scaled to its
    peak; the stress of the quiet blocks shaded."""
    for n, colour in SIZE_COLOURS.items():
        b = layer(runs, n, phi)
        if b.empty:
            continue
        x = b.R / r_independent(n)
        _step(ax_r, x, np.linspace(0, x_max, 61), colour)
        edges = np.linspace(b.s.min(), b.s.max(), 41)
        peak = _step(ax_s, b.s, edges, colour)
        q = (x < 1).to_numpy()
        if q.any():
            hq, _ = np.histogram(b.s[q], bins=edges)
            ax_s.stairs(hq / peak, edges, fill=True, color=colour, alpha=0.3, lw=0)
    _thresholds(ax_r)
    ax_r.set_xlim(0, x_max)
    for ax in (ax_r, ax_s):
        ax.set_ylim(0, 1.08)
        ax.set_ylabel("blocks per bin / its peak")
    ax_r.set_xlabel(r"$R\,/\sqrt{\pi/4N}$")
    ax_s.set_xlabel(r"$\langle\sigma_x\rangle/\sigma_n$ of a block")
    ax_r.set_title(f"$\\phi$ = {phi:g}: coherence $R$")
    ax_s.set_title(f"$\\phi$ = {phi:g}: stress (quiet shaded)")


def _step(ax, x, edges, colour) -> float:
    h, _ = np.histogram(x, bins=edges)
    peak = max(h.max(), 1)
    ax.stairs(h / peak, edges, color=colour, lw=1.0)
    return float(peak)


def _joint(ax, runs, rec, n, phi, x_max, norm) -> None:
    """The 2-d histogram of (R / threshold, stress) of the blocks of (n, phi)."""
    b = layer(runs, n, phi)
    if b.empty:
        ax.text(0.5, 0.5, f"N = {n}, $\\phi$ = {phi:g}:\nnot recorded", ha="center",
                va="center", transform=ax.transAxes)
        ax.axis("off")
        return None
    x = b.R / r_independent(n)
    h, xe, ye = np.histogram2d(x, b.s, bins=(np.linspace(0, x_max, 41),
                                             np.linspace(b.s.min(), b.s.max(), 31)))
    share = np.where(h > 0, h / len(b), np.nan)
    mesh = ax.pcolormesh(xe, ye, share.T, norm=norm, cmap="viridis", rasterized=True)
    _thresholds(ax)
    layer_rec = next(r for r in rec["layers"] if r["N"] == n and r["phi"] == phi)
    ax.set_title(f"$\\phi$ = {phi:g}, N = {n}: quiet {100 * layer_rec['quiet']['1000']['1']:.1f}%\n"
                 f"$b_R$ = {layer_rec['sarle_R']['1000']:.2f}, "
                 f"$b_\\sigma$ = {layer_rec['sarle_stress']['1000']:.2f}")
    ax.set_xlabel(r"$R\,/\sqrt{\pi/4N}$")
    ax.set_ylabel(r"$\langle\sigma_x\rangle/\sigma_n$")
    return mesh


def _sensitivity(ax, rec, phi) -> None:
    """The quiet share against the threshold factor at phi: a line per N and block length."""
    layers = [r for r in rec["layers"] if r["phi"] == phi]
    for layer_rec in layers:
        for length, (mk, ls, ms) in LENGTH_MARKERS.items():
            q = layer_rec["quiet"][str(length)]
            ax.plot([f * DODGE[length] for f in FACTORS], [q[f"{f:g}"] for f in FACTORS],
                    marker=mk, ls=ls, ms=ms, color=SIZE_COLOURS.get(layer_rec["N"], "0.3"),
                    mfc="none" if length > 1000 else None, lw=0.8)
    ax.set_xscale("log", base=2)
    ax.set_xticks(FACTORS, [f"{f:g}x" for f in FACTORS])
    ax.minorticks_off()
    ax.set_xlim(0.42, 2.4)
    ax.set_ylim(-0.04, 1.04)
    ax.set_xlabel(r"threshold / $\sqrt{\pi/4N}$")
    ax.set_ylabel("quiet share of the blocks")
    none = not any(v for r in layers for q in r["quiet"].values() for v in q.values())
    ax.set_title(f"$\\phi$ = {phi:g}: quiet share" + (" (none quiet)" if none else ""))


def _keys(fig) -> None:
    from matplotlib.lines import Line2D

    sizes = [Line2D([], [], color=c, lw=1.2, label=f"N = {n}") for n, c in SIZE_COLOURS.items()]
    lines = [Line2D([], [], color="k", lw=0.9, ls="--",
                    label=r"threshold $\sqrt{\pi/4N}$ (quiet below)"),
             Line2D([], [], color="0.45", lw=0.7, ls=":", label="0.5x and 2x the threshold")]
    lengths = [Line2D([], [], color="0.3", marker=mk, ls=ls, ms=ms, lw=0.8,
                      mfc="none" if length > 1000 else None,
                      label=f"quiet share, blocks of {length}")
               for length, (mk, ls, ms) in LENGTH_MARKERS.items()]
    fig.legend(handles=sizes + lines + lengths, loc="outside lower center", ncol=4,
               frameon=False, fontsize=MIN_FONT + 0.5,
               title="the quiet share's points of each block length are drawn a little apart "
                     "(they coincide)", title_fontsize=MIN_FONT + 0.5)


def _seeds(ax, runs, n, phi) -> None:
    """R of each seed's blocks at (n, phi), each scaled to its peak and stacked, with its
    Sarle coefficient: what pooling the layers (seeds) hides."""
    b = layer(runs, n, phi)
    if b.empty:
        ax.axis("off")
        return
    seeds = sorted(b.seed.unique())
    edges = np.linspace(0, _x_max(runs, phi), 41)
    for i, seed in enumerate(seeds):
        x = b.R[b.seed == seed] / r_independent(n)
        h, _ = np.histogram(x, bins=edges)
        ax.stairs(i + 0.9 * h / max(h.max(), 1), edges, baseline=i, color=SIZE_COLOURS[n],
                  fill=True, alpha=0.5, lw=0)
        ax.text(0.97, (i + 0.35) / len(seeds), f"b = {sarle(x):.2f}", ha="right",
                transform=ax.transAxes)
    _thresholds(ax)
    ax.set_xlim(0, edges[-1])
    ax.set_ylim(0, len(seeds))
    ax.set_yticks(np.arange(len(seeds)) + 0.45, [f"seed {s}" for s in seeds])
    ax.set_xlabel(r"$R\,/\sqrt{\pi/4N}$")
    ax.set_title(f"$\\phi$ = {phi:g}, N = {n}: $R$ seed by seed\n(each scaled to its peak)")


def _x_max(runs, phi) -> float:
    """The right end of a row's R axes: every N's largest R, and twice the threshold."""
    tops = [float(b.R.max()) / r_independent(n) for n in SIZES
            if not (b := layer(runs, n, phi)).empty]
    return 1.05 * max([2.2, *tops])


def draw(runs: pd.DataFrame, rec: dict):
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    norm = LogNorm(1e-4, 1e-1)
    with plt.rc_context({"font.size": MIN_FONT, "axes.titlesize": MIN_FONT + 0.5}):
        fig, axes = plt.subplots(len(PHIS) + 1, 5, figsize=(10.0, 11.6), layout="constrained")
        mesh = None
        for i, phi in enumerate(PHIS):
            x_max = _x_max(runs, phi)
            _histograms(axes[i, 0], axes[i, 1], runs, phi, x_max)
            for j, n in enumerate(SIZES):
                mesh = _joint(axes[i, 2 + j], runs, rec, n, phi, x_max, norm) or mesh
            _sensitivity(axes[-1, i], rec, phi)
        _seeds(axes[-1, -1], runs, *SEEDS_SHOWN)
        _keys(fig)
        if mesh is not None:
            fig.colorbar(mesh, ax=axes[:-1, 2:], shrink=0.5, aspect=30,
                         label="share of the layer's blocks per bin")
        fig.suptitle("Two states or one? Blocks of $10^3$ time units of the long runs (every "
                     "seed and start pooled, each run's first 20% left out); $b$: Sarle's "
                     "bimodality coefficient\n(5/9 for a uniform distribution, 1/3 for a "
                     "normal; above 5/9 suggests two modes)", fontsize=MIN_FONT + 1.5)
    return fig


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--records", default=None, help="the long runs' records (default "
                    "benchmarks/records/stiff_states)")
    a = ap.parse_args(argv)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    runs = stiff_states.load(a.records or OUT)
    rec = record(runs)
    write_json(RECORD, rec)
    fig = draw(runs, rec)
    fig.savefig(FIGURE, dpi=200)
    plt.close(fig)
    print(f"wrote {RECORD} and {FIGURE}")


if __name__ == "__main__":
    main()
