"""The blocks of RESULTS.md's "The states of the stiff end" and "The run length a mean needs":
the long runs of benchmarks/measure/stiff_states.py as benchmarks/report/stiff_states.py reads
them (and the calibration bkflow installs from them).
"""

from __future__ import annotations

import math
from functools import lru_cache

from benchmarks.documents.cells import num, pct
from benchmarks.harness import RECORDS
from bkflow.observables.states import r_independent


@lru_cache(maxsize=1)
def states():
    """(benchmarks/report/stiff_states.py, its runs, their layers' long-run means), read once
    from benchmarks/records/stiff_states/."""
    from benchmarks.measure.stiff_states import OUT
    from benchmarks.report import stiff_states as sr

    runs = sr.load(OUT)
    means = sr.layer_means(runs)
    return sr, runs, means


def states_occupancy() -> str:
    sr, runs, _ = states()
    occ = sr.occupancy(runs)
    out = ["| N | phi | runs | time (10^6) | quiet share | residence quiet | residence "
           "coherent | <sigma_x>/sigma_n quiet / coherent | mu_bar quiet / coherent |",
           "|---|---|---|---|---|---|---|---|---|"]
    for _, r in occ.iterrows():
        out.append(f"| {int(r.N)} | {r.phi:g} | {int(r.runs)} | {r['T'] / 1e6:.1f} | "
                   f"{r.quiet:.3f} | "
                   f"{num(r.residence_quiet, '.3g')} | {num(r.residence_coherent, '.3g')} | "
                   f"{num(r.stress_quiet)} / {num(r.stress_coherent)} | "
                   f"{num(r.mu_bar_quiet)} / {num(r.mu_bar_coherent)} |")
    return "\n".join(out) + "\n"


def states_longrun() -> str:
    sr, runs, means = states()
    out = ["| N | phi | seed | runs | time (10^6) | <sigma_x>/sigma_n (long run) | +- | "
           "mu_bar (long run) |", "|---|---|---|---|---|---|---|---|"]
    for (n, phi, seed), m in sorted(means.items()):
        out.append(f"| {n} | {phi:g} | {seed} | {m['runs']} | {m['T'] / 1e6:.1f} | "
                   f"{m['stress']:.5f} | {num(m['stress_se'], '.1e')} | {m['mu_bar']:.5f} |")
    return "\n".join(out) + "\n"


def states_coverage() -> str:
    sr, runs, means = states()
    cov = sr.coverage(runs, means)
    ws = sorted(cov.W.unique())
    out = ["| N | phi | " + " | ".join(f"W = {w:g}" for w in ws) + " |",
           "|---|---|" + "---|" * len(ws)]
    for (n, phi), g in cov.groupby(["N", "phi"]):
        cells = []
        for w in ws:
            r = g[g.W == w]
            cells.append("n/a" if r.empty else
                         f"{r.stress.iloc[0]:.2f} / {r.mu_bar.iloc[0]:.2f}")
        out.append(f"| {n} | {phi:g} | " + " | ".join(cells) + " |")
    return "\n".join(out) + "\n"


def states_verdict() -> str:
    sr, runs, means = states()
    v = sr.verdicts(runs, means)
    out = ["| N | phi | T | windows | steady | states named | drifting | metastable | "
           "false steady (> 0.5% off) | steady, interval misses | coverage (all) |",
           "|---|---|---|---|---|---|---|---|---|---|---|"]
    for _, r in v.iterrows():
        out.append(f"| {int(r.N)} | {r.phi:g} | {r['T']:g} | {int(r.windows)} | {r.steady:.2f} | "
                   f"{r.switching:.2f} | {r.drifting:.2f} | {r.metastable:.2f} | "
                   f"{num(r.steady_off_05, '.3f')} | {num(r.false_steady, '.3f')} | "
                   f"{r.coverage:.3f} |")
    return "\n".join(out) + "\n"


def states_ergodicity() -> str:
    sr, runs, _ = states()
    e = sr.ergodicity(runs)
    out = ["| N | phi | t | d(t/4) | d(t) | d(t) / d(t/4) (ergodic: 0.25) | the starts' time "
           "averages at t: relative spread |", "|---|---|---|---|---|---|---|"]
    for _, r in e.iterrows():
        out.append(f"| {int(r.N)} | {r.phi:g} | {r.t:.3g} | {r.d_quarter:.2e} | {r.d_end:.2e} | "
                   f"{r.ratio:.2f} | {100 * r.spread:.3f}% |")
    return "\n".join(out) + "\n"


def _needed(obs: str, phi: float, n: int, rel: float) -> float:
    """The window length (time units) whose calibrated relative error of ``obs`` is ``rel``
    (bkflow.observables.states.window_variance, falling as 1/W beyond the longest window
    measured)."""
    from bkflow.observables.states import window_variance

    lo, hi = math.log(1e2), math.log(1e13)
    if window_variance(obs, phi, n, 1e2) <= rel ** 2:
        return 1e2
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if window_variance(obs, phi, n, math.exp(mid)) > rel ** 2 \
            else (lo, mid)
    return math.exp(hi)


def _length(obs: str, phi: float, n: int, rel: float, shortest: float) -> str:
    t = _needed(obs, phi, n, rel)
    return f"<= {shortest:.0e}" if t <= shortest else f"{t:.2g}"


def states_longest() -> str:
    """The runs of 10^7 time units, window by window (10^6 each, after the first 20%): the
    quiet share, <sigma_x>/sigma_n and mu_bar of each window (smallest - largest), and how
    many stretches in each state the run had: does either state absorb the layer?"""
    import numpy as np


    sr, runs, _ = states()
    long = runs[runs.blocks.map(len) >= 4000]
    out = ["| N | phi | seed | kept (10^6) | windows of 10^6: quiet share | <sigma_x>/sigma_n "
           "| mu_bar | stretches quiet / coherent |", "|---|---|---|---|---|---|---|---|"]
    for _, r in long.sort_values(["N", "phi", "seed"]).iterrows():
        b = r.blocks.reset_index(drop=True)
        k = 1000
        q, st, mu = [], [], []
        for i in range(0, len(b) - k + 1, k):
            w = b.iloc[i:i + k]
            q.append(float((w.R < r_independent(int(r.N))).mean()))
            st.append(float(w.s.mean()))
            mu.append(float(w["sfail_0.01"].sum() / w["nslip_0.01"].sum()))
        quiet = (b.R < r_independent(int(r.N))).to_numpy().astype(int)
        edges = np.flatnonzero(np.diff(quiet)) + 1
        starts = np.concatenate([[0], edges])
        nq = int(sum(quiet[a] for a in starts))
        out.append(f"| {int(r.N)} | {r.phi:g} | {int(r.seed)} | {len(b) / 1000:.1f} | "
                   f"{min(q):.2f} - {max(q):.2f} | {min(st):.4f} - {max(st):.4f} | "
                   f"{min(mu):.4f} - {max(mu):.4f} | {nq} / {len(starts) - nq} |")
    return "\n".join(out) + "\n"


#: the disorder seeds at the stiff end of N = 100 from the random start: seeds 1-6 of the
#: calibration's long runs (10^6 time units) and seeds 7-18 (5 x 10^5, their own folder, so
#: that the calibration stays what it was)
SEEDS_RECORDS = RECORDS / "stiff_seeds"


def stiff_seeds() -> str:
    """Per phi at the stiff end of N = 100: how the quiet share (the blocks with R below
    r_independent(N)), the mean stress and mu_bar of a layer spread over 15-20 disorder seeds
    (one run each, the random start, after its transient)."""
    import numpy as np

    sr, runs, _ = states()
    extra = sr.load(SEEDS_RECORDS) if SEEDS_RECORDS.exists() else runs.iloc[:0]
    import pandas as pd

    both = pd.concat([runs, extra], ignore_index=True)
    both = both[(both.N == 100) & (both.start == "random") & (both.phi >= 215)]
    out = ["| phi | seeds | time per seed (10^5) | quiet share: mean, seeds' spread (min - max) | "
           "seeds never quiet | <sigma_x>/sigma_n: mean +- error, spread | mu_bar: mean +- "
           "error, spread |", "|---|---|---|---|---|---|---|"]
    for phi, g in both.groupby("phi"):
        q, st, mu, t = [], [], [], []
        for b in g.blocks:
            w = (b.t1 - b.t0).to_numpy()
            q.append(float(np.average(b.R < r_independent(100), weights=w)))
            st.append(float(np.average(b.s, weights=w)))
            mu.append(float(sr.mu_bar(b)))
            t.append(float(w.sum()))
        k = len(q)
        se = [float(np.std(v, ddof=1) / math.sqrt(k)) for v in (st, mu)]
        out.append(f"| {phi:g} | {k} | {min(t) / 1e5:.0f} - {max(t) / 1e5:.0f} | "
                   f"{np.mean(q):.3f} ({min(q):.3f} - {max(q):.3f}) | "
                   f"{sum(v == 0 for v in q)} | {np.mean(st):.4f} +- {se[0]:.4f} "
                   f"({min(st):.4f} - {max(st):.4f}) | {np.mean(mu):.4f} +- {se[1]:.4f} "
                   f"({min(mu):.4f} - {max(mu):.4f}) |")
    return "\n".join(out) + "\n"


#: longer runs at N = 400's stiff end than the calibration's 10^6 (their own folder)
LONG_RECORDS = RECORDS / "stiff_long"


def stiff_long() -> str:
    """Whether a quiet state appears at N = 400 in runs longer than the calibration's: per run,
    its length, the share of its 1000-time-unit blocks with R below r_independent(N) (and
    below half and twice that threshold), and the lowest block R."""
    import numpy as np

    sr, _, _ = states()
    if not LONG_RECORDS.exists():
        return "(not measured yet)\n"
    runs = sr.load(LONG_RECORDS)
    out = ["| N | phi | start | seed | time (10^6) | blocks | quiet share at r_ind / 2, "
           "r_ind, 2 r_ind | lowest block R (r_ind) |", "|---|---|---|---|---|---|---|---|"]
    for r in runs.sort_values(["N", "phi", "seed"]).itertuples():
        b, thr = r.blocks, r_independent(int(r.N))
        shares = " / ".join(f"{float(np.mean(b.R < f * thr)):.3f}" for f in (0.5, 1, 2))
        out.append(f"| {r.N} | {r.phi:g} | {r.start} | {r.seed} | {r.t / 1e6:.1f} | {len(b)} | "
                   f"{shares} | {b.R.min():.3f} ({thr:.3f}) |")
    return "\n".join(out) + "\n"


def states_needed() -> str:
    """Per (N, phi): the calibrated relative error of a run's mean (about the layer's
    long-run mean) at run lengths 10^4, 10^5, 10^6, and the length a run needs for 1% and
    0.2% on <sigma_x>/sigma_n and on mu_bar."""
    from bkflow.model.calibration import switching
    from bkflow.observables.states import window_variance

    out = ["| N | phi | error of <sigma_x>/sigma_n at T = 1e4 / 1e5 / 1e6 | of mu_bar | T for "
           "1% / 0.2% on <sigma_x>/sigma_n | on mu_bar |", "|---|---|---|---|---|---|"]
    for n, size in switching().get("sizes", {}).items():
        for phi in size["phi"]:
            errs = {o: " / ".join(f"{100 * math.sqrt(window_variance(o, phi, int(n), T)):.2g}%"
                                  for T in (1e4, 1e5, 1e6)) for o in ("stress", "mu_bar")}
            need = {o: " / ".join(_length(o, phi, int(n), r, size["windows"][0])
                                  for r in (0.01, 0.002)) for o in ("stress", "mu_bar")}
            out.append(f"| {n} | {phi:g} | {errs['stress']} | {errs['mu_bar']} | "
                       f"{need['stress']} | {need['mu_bar']} |")
    return "\n".join(out) + "\n"


def states_paper() -> str:
    sr, runs, means = states()
    p = sr.paper_points(runs, means)
    out = ["| N | phi | T | seeds | paper's window: <sigma_x>/sigma_n | its chi | long run | "
           "quiet | coherent | coherent, 99th percentile | memory chi |",
           "|---|---|---|---|---|---|---|---|---|---|---|"]
    for _, r in p.iterrows():
        out.append(f"| {int(r.N)} | {r.phi:g} | {r['T']:g} | {int(r.seeds)} | {r.paper_mean:.4f} | "
                   f"{r.paper_chi:.1f} | {r.long_run:.4f} | {num(r.quiet)} | {r.coherent:.4f} | "
                   f"{num(r.coherent_p99)} | {r.memory_chi:.1f} |")
    return "\n".join(out) + "\n"


#: the windows (time units from the start) in which each start's mean stress is compared
START_WINDOWS = ((0.0, 2e3), (2e3, 1e4), (1e4, 1e5))


START_ORDER = ("random", "partial", "stratified", "synchronized")


def states_starts() -> str:
    """How far each start's mean stress lies from its layer's long-run mean in the first
    windows of a run (the long runs of benchmarks/measure/stiff_states.py, whole records from
    t = 0): relative deviation, the median over the seeds, per start."""
    import numpy as np

    from bkflow.observables.states import BLOCK_T

    sr, runs, means = states()
    half = BLOCK_T / 2     # the blocks' edges drift from whole thousands by rounding to steps
    cell = {}
    for _, r in runs.iterrows():
        lm = means[(r.N, r.phi, r.seed)]["stress"]
        w = r.whole
        for a, b in START_WINDOWS:
            sel = w[(w.t0 >= a - half) & (w.t1 <= b + half)]
            if len(sel):
                cell.setdefault((r.N, r.phi, (a, b), r.start), []).append(
                    float(np.average(sel.s, weights=sel.t1 - sel.t0)) / lm - 1.0)
    head = " | ".join(f"t = {a:g} to {b:g}" for a, b in START_WINDOWS)
    out = [f"| N | phi | seeds | {head} |", "|---|---|---|" + "---|" * len(START_WINDOWS)]
    for n, phi in sorted({(k[0], k[1]) for k in cell}):
        cells = []
        for win in START_WINDOWS:
            cells.append(" / ".join(
                pct(float(np.median(cell[(n, phi, win, st)])))
                if (n, phi, win, st) in cell else "n/a" for st in START_ORDER))
        seeds = max(len(v) for k, v in cell.items() if k[:2] == (n, phi))
        out.append(f"| {n} | {phi:g} | {seeds} | " + " | ".join(cells) + " |")
    return "\n".join(out) + "\n"


def states_starts_r() -> str:
    """The contacts' coherence R (the mean of |Z| over blocks) of each start in the first
    windows of a run, against its layer's long-run level (the long runs of
    benchmarks/measure/stiff_states.py, from t = 0; the median over the seeds), at the stiff end."""
    import numpy as np

    from bkflow.observables.states import BLOCK_T

    sr, runs, means = states()
    half = BLOCK_T / 2
    level, cell = {}, {}
    for (n, phi, _seed), g in runs.groupby(["N", "phi", "seed"]):
        allb = sr.pd.concat(list(g.blocks), ignore_index=True)
        level.setdefault((n, phi), []).append(float(np.average(allb.R, weights=allb.n)))
    for _, r in runs[runs.phi >= 100].iterrows():
        w = r.whole
        for a, b in START_WINDOWS:
            sel = w[(w.t0 >= a - half) & (w.t1 <= b + half)]
            if len(sel):
                cell.setdefault((r.N, r.phi, (a, b), r.start), []).append(
                    float(np.average(sel.R, weights=sel.n)))
    head = " | ".join(f"t = {a:g} to {b:g}" for a, b in START_WINDOWS)
    out = [f"| N | phi | long run | {head} |", "|---|---|---|" + "---|" * len(START_WINDOWS)]
    for n, phi in sorted({(k[0], k[1]) for k in cell}):
        cells = [" / ".join(f"{np.median(cell[(n, phi, win, st)]):.3f}"
                            if (n, phi, win, st) in cell else "n/a" for st in START_ORDER)
                 for win in START_WINDOWS]
        out.append(f"| {n} | {phi:g} | {np.median(level[(n, phi)]):.3f} | "
                   + " | ".join(cells) + " |")
    return "\n".join(out) + "\n"


#: the blocks this module makes, by name
BLOCKS = {"states-occupancy": states_occupancy,
          "states-longrun": states_longrun,
          "stiff-seeds": stiff_seeds,
          "stiff-long": stiff_long,
          "states-coverage": states_coverage,
          "states-verdict": states_verdict,
          "states-ergodicity": states_ergodicity,
          "states-needed": states_needed,
          "states-longest": states_longest,
          "states-paper": states_paper,
          "states-starts": states_starts,
          "states-starts-r": states_starts_r}
