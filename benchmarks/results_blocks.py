"""The generated blocks of benchmarks/RESULTS.md, workflows/paper/REPRODUCTION.md and
docs/analysis.md: every number there that comes from a benchmark's records, and the table of
the summary's keys (from bkflow.analysis.registry), is written by a function here, between
``<!-- generated: NAME -->`` and ``<!-- end -->``.

    python benchmarks/results_blocks.py            # check: exit 1 when a block differs
    python benchmarks/results_blocks.py --write    # (re)write every block

``tests/test_results_blocks.py`` makes the same check, so that a document cannot drift from
its records.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from functools import lru_cache
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

ROOT = HERE.parent
DOCUMENTS = (HERE / "RESULTS.md", ROOT / "workflows" / "paper" / "REPRODUCTION.md",
             ROOT / "docs" / "analysis.md", ROOT / "docs" / "develop.md")
BLOCK = re.compile(r"(<!-- generated: ([\w-]+) -->\n)(.*?)(<!-- end -->)", re.S)


def _pct(v, digits=2) -> str:
    return "n/a" if v is None or not math.isfinite(v) else f"{100 * v:+.{digits}f}%"


def _se(v, digits=2) -> str:
    """A standard error as a percentage without its sign (n/a where there is none)."""
    return "n/a" if v is None or not math.isfinite(v) else f"{100 * v:.{digits}f}%"


def _g(v, fmt=".4f") -> str:
    return "n/a" if v is None or not math.isfinite(v) else format(v, fmt)


# ------------------------------------------------------------------------- the stiff end
@lru_cache(maxsize=1)
def _states():
    import states_report as sr

    runs = sr.load(sr_root())
    means = sr.layer_means(runs)
    return sr, runs, means


def sr_root():
    from stiff_states import OUT

    return OUT


def states_occupancy() -> str:
    sr, runs, _ = _states()
    occ = sr.occupancy(runs)
    out = ["| N | phi | runs | time (10^6) | quiet share | residence quiet | residence "
           "coherent | <sigma_x>/sigma_n quiet / coherent | mu_bar quiet / coherent |",
           "|---|---|---|---|---|---|---|---|---|"]
    for _, r in occ.iterrows():
        out.append(f"| {int(r.N)} | {r.phi:g} | {int(r.runs)} | {r['T'] / 1e6:.1f} | "
                   f"{r.quiet:.3f} | "
                   f"{_g(r.residence_quiet, '.3g')} | {_g(r.residence_coherent, '.3g')} | "
                   f"{_g(r.stress_quiet)} / {_g(r.stress_coherent)} | "
                   f"{_g(r.mu_bar_quiet)} / {_g(r.mu_bar_coherent)} |")
    return "\n".join(out) + "\n"


def states_longrun() -> str:
    sr, runs, means = _states()
    out = ["| N | phi | seed | runs | time (10^6) | <sigma_x>/sigma_n (long run) | +- | "
           "mu_bar (long run) |", "|---|---|---|---|---|---|---|---|"]
    for (n, phi, seed), m in sorted(means.items()):
        out.append(f"| {n} | {phi:g} | {seed} | {m['runs']} | {m['T'] / 1e6:.1f} | "
                   f"{m['stress']:.5f} | {_g(m['stress_se'], '.1e')} | {m['mu_bar']:.5f} |")
    return "\n".join(out) + "\n"


def states_coverage() -> str:
    sr, runs, means = _states()
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
    sr, runs, means = _states()
    v = sr.verdicts(runs, means)
    out = ["| N | phi | T | windows | steady | states named | drifting | metastable | "
           "false steady (> 0.5% off) | steady, interval misses | coverage (all) |",
           "|---|---|---|---|---|---|---|---|---|---|---|"]
    for _, r in v.iterrows():
        out.append(f"| {int(r.N)} | {r.phi:g} | {r['T']:g} | {int(r.windows)} | {r.steady:.2f} | "
                   f"{r.switching:.2f} | {r.drifting:.2f} | {r.metastable:.2f} | "
                   f"{_g(r.steady_off_05, '.3f')} | {_g(r.false_steady, '.3f')} | "
                   f"{r.coverage:.3f} |")
    return "\n".join(out) + "\n"


def states_ergodicity() -> str:
    sr, runs, _ = _states()
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

    from bkflow.observables.states import r_independent

    sr, runs, _ = _states()
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
SEEDS_RECORDS = HERE / "records" / "stiff_seeds"


def stiff_seeds() -> str:
    """Per phi at the stiff end of N = 100: how the quiet share (the blocks with R below
    r_independent(N)), the mean stress and mu_bar of a layer spread over 15-20 disorder seeds
    (one run each, the random start, after its transient)."""
    import numpy as np

    sr, runs, _ = _states()
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
            q.append(float(np.average(b.R < sr.r_independent(100), weights=w)))
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
LONG_RECORDS = HERE / "records" / "stiff_long"


def stiff_long() -> str:
    """Whether a quiet state appears at N = 400 in runs longer than the calibration's: per run,
    its length, the share of its 1000-time-unit blocks with R below r_independent(N) (and
    below half and twice that threshold), and the lowest block R."""
    import numpy as np

    sr, _, _ = _states()
    if not LONG_RECORDS.exists():
        return "(not measured yet)\n"
    runs = sr.load(LONG_RECORDS)
    out = ["| N | phi | start | seed | time (10^6) | blocks | quiet share at r_ind / 2, "
           "r_ind, 2 r_ind | lowest block R (r_ind) |", "|---|---|---|---|---|---|---|---|"]
    for r in runs.sort_values(["N", "phi", "seed"]).itertuples():
        b, thr = r.blocks, sr.r_independent(int(r.N))
        shares = " / ".join(f"{float(np.mean(b.R < f * thr)):.3f}" for f in (0.5, 1, 2))
        out.append(f"| {r.N} | {r.phi:g} | {r.start} | {r.seed} | {r.t / 1e6:.1f} | {len(b)} | "
                   f"{shares} | {b.R.min():.3f} ({thr:.3f}) |")
    return "\n".join(out) + "\n"


def relaxation() -> str:
    """The synchronized start's relaxation (stationarity.py relaxation, its record): per
    (N, phi), the median over seeds of tau and A / s_inf where a relaxation was fitted (and in
    how many seeds), of t_equil and of the late mean."""
    import numpy as np
    from stationarity import RELAXATION_RECORD, read_relaxation_record

    if not RELAXATION_RECORD.exists():
        return "(not measured yet: python benchmarks/stationarity.py relaxation)\n"
    df, _ = read_relaxation_record()
    out = ["| N | phi | seeds fitted | tau | A / s_inf | t_equil | late mean |",
           "|---|---|---|---|---|---|---|"]
    for (n, phi), g in df.groupby(["N", "phi"]):
        fit = g[np.isfinite(g.tau)]
        tau, amp = ((f"{fit.tau.median():.3g}", f"{fit.amplitude.median():+.2g}")
                    if len(fit) else ("-", "-"))
        out.append(f"| {n} | {phi:.4g} | {len(fit)} of {len(g)} | {tau} | {amp} | "
                   f"{g.t_equil.median():.3g} | {g.late_mean.median():.4f} |")
    return "\n".join(out) + "\n"


def states_needed() -> str:
    """Per (N, phi): the calibrated relative error of a run's mean (about the layer's
    long-run mean) at run lengths 10^4, 10^5, 10^6, and the length a run needs for 1% and
    0.2% on <sigma_x>/sigma_n and on mu_bar."""
    from bkflow.observables.states import calibration, window_variance

    out = ["| N | phi | error of <sigma_x>/sigma_n at T = 1e4 / 1e5 / 1e6 | of mu_bar | T for "
           "1% / 0.2% on <sigma_x>/sigma_n | on mu_bar |", "|---|---|---|---|---|---|"]
    for n, size in calibration().get("sizes", {}).items():
        for phi in size["phi"]:
            errs = {o: " / ".join(f"{100 * math.sqrt(window_variance(o, phi, int(n), T)):.2g}%"
                                  for T in (1e4, 1e5, 1e6)) for o in ("stress", "mu_bar")}
            need = {o: " / ".join(_length(o, phi, int(n), r, size["windows"][0])
                                  for r in (0.01, 0.002)) for o in ("stress", "mu_bar")}
            out.append(f"| {n} | {phi:g} | {errs['stress']} | {errs['mu_bar']} | "
                       f"{need['stress']} | {need['mu_bar']} |")
    return "\n".join(out) + "\n"


def _claims_module():
    import importlib.util

    spec = importlib.util.spec_from_file_location("claims", CLAIMS.with_suffix(".py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _paper_rise(n: int) -> float | None:
    """How far the paper protocol's mu_bar (t_end = 16000, claims.json) rises from its
    minimum to its stiff end at N = n: the effect the long-run curve is tested against."""
    import json

    if not CLAIMS.exists():
        return None
    m = json.loads(CLAIMS.read_text())["curves"].get("paper, t_end = 16000", {})
    r = m.get("claim1", {}).get("mu_bar", {}).get(str(n))
    return None if r is None else r["hi"] - r["min"]


def states_curve() -> str:
    """The long-run curve: per (N, phi) the mean over the seeds of each layer's long-run
    <sigma_x>/sigma_n and mu_bar with their standard error over the seeds (the disorder's
    spread and each layer's own uncertainty together). Per N and observable, its shape tested
    as the claims are (workflows/paper/claims.py: Student's t, seeds - 1 degrees of freedom,
    corrected for the steps looked at): a rise from one phi to the next beyond the critical
    value, the rise each step would show with 80% power, and for mu_bar whether the stiff
    end's rise above the rest of the curve, at its 97.5% upper bound, is smaller than the rise
    the paper's protocol shows at that N (an equivalence test: a "no rise" that excludes the
    paper's effect)."""
    from stiff_states import curve_table

    claims = _claims_module()
    sr, runs, means = _states()
    table = curve_table(means)
    out = ["| N | phi | seeds | <sigma_x>/sigma_n | mu_bar |", "|---|---|---|---|---|"]
    verdicts = []
    for n, g in table.groupby("N"):
        rows = []
        for r in g.sort_values("phi").to_dict("records"):
            r["k"] = r["seeds"]
            rows.append(r)
            out.append(f"| {int(n)} | {r['phi']:g} | {r['k']} | {r['stress']:.4f} +- "
                       f"{_g(r['stress_se'], '.4f')} | {r['mu_bar']:.4f} +- "
                       f"{_g(r['mu_bar_se'], '.4f')} |")
        seeds = min(r["k"] for r in rows)
        crit = claims.critical(seeds, looks=len(rows) - 1)
        found80 = crit + claims.power_quantile(seeds)
        for obs, name in (("stress", "<sigma_x>/sigma_n"), ("mu_bar", "mu_bar")):
            steps = [(a, b, b[obs] - a[obs], math.hypot(a[obs + "_se"], b[obs + "_se"]))
                     for a, b in zip(rows, rows[1:])]
            rises = [f"{a['phi']:g} -> {b['phi']:g} ({d:+.4f} +- {e:.4f})"
                     for a, b, d, e in steps if d > crit * e]
            line = (f"- N = {int(n)}, {name}: " + (
                f"no rise from one phi to the next beyond {crit:.2f} errors (t, {seeds} "
                f"seeds, {len(steps)} steps); a rise of {found80 * max(e for *_, e in steps):.4f}"
                " at any step would be found with 80% power"
                if not rises else f"rises beyond {crit:.2f} errors at " + ", ".join(rises)))
            paper = _paper_rise(int(n)) if obs == "mu_bar" else None
            if paper is not None and paper <= 0:
                line += "; the paper protocol's mu_bar has no rise at this N either"
            elif paper is not None:
                end, rest = rows[-1], rows[:-1]
                low = min(rest, key=lambda r: r[obs])
                rise = end[obs] - low[obs]
                pair = min(end["k"], low["k"])   # the two points' own seeds, not the curve's
                upper = rise + claims.critical(pair) * math.hypot(end[obs + "_se"],
                                                                  low[obs + "_se"])
                line += (f"; the stiff end lies {rise:+.4f} from the rest's lowest point "
                         f"(97.5% upper bound {upper:+.4f}), the paper protocol's rise at this "
                         f"N is {paper:.4f}: " + ("a rise as large is excluded" if upper < paper
                                                 else "a rise as large is not excluded"))
            verdicts.append(line)
    return "\n".join(out) + "\n\n" + "\n".join(verdicts) + "\n"


def pd_frame(means: dict):
    import pandas as pd

    return pd.DataFrame([{"N": k[0], "phi": k[1], "seed": k[2], **v} for k, v in means.items()])


def states_paper() -> str:
    sr, runs, means = _states()
    p = sr.paper_points(runs, means)
    out = ["| N | phi | T | seeds | paper's window: <sigma_x>/sigma_n | its chi | long run | "
           "quiet | coherent | coherent, 99th percentile | memory chi |",
           "|---|---|---|---|---|---|---|---|---|---|---|"]
    for _, r in p.iterrows():
        out.append(f"| {int(r.N)} | {r.phi:g} | {r['T']:g} | {int(r.seeds)} | {r.paper_mean:.4f} | "
                   f"{r.paper_chi:.1f} | {r.long_run:.4f} | {_g(r.quiet)} | {r.coherent:.4f} | "
                   f"{_g(r.coherent_p99)} | {r.memory_chi:.1f} |")
    return "\n".join(out) + "\n"


# ------------------------------------------------------------------------- the time step
@lru_cache(maxsize=1)
def _timestep():
    import timestep_report as tr
    from timestep import OUT

    runs = tr.load(OUT)
    return tr, runs, tr.bias(runs)


def timestep_bias() -> str:
    tr, runs, table = _timestep()
    out = ["| N | phi | C = dt omega_max | omega_c dt | seeds | bias of <sigma_x>/sigma_n | "
           "bias of mu_bar | steps per time unit |", "|---|---|---|---|---|---|---|---|"]
    for _, r in table.iterrows():
        if r.reference:
            out.append(f"| {int(r.N)} | {r.phi:g} | {r.C:g} | {r.wc_dt:.3f} | {int(r.seeds)} | "
                       "(reference) | (reference) | " f"{r.steps_per_t:.0f} |")
            continue
        out.append(f"| {int(r.N)} | {r.phi:g} | {r.C:g} | {r.wc_dt:.3f} | {int(r.seeds)} | "
                   f"{_pct(r.stress_bias)} +- {_se(r.stress_se)} | "
                   f"{_pct(r.mu_bar_bias)} +- {_se(r.mu_bar_se)} | {r.steps_per_t:.0f} |")
    return "\n".join(out) + "\n"


def timestep_presets() -> str:
    """Each preset before (one C for every phi) and after (the rule), side by side: its step,
    cost and measured bias, and the verdict against its target."""
    tr, runs, table = _timestep()
    pr = tr.presets(table)
    out = ["| preset (target) | N | phi | rule | C = dt omega_max | omega_c dt | steps per time "
           "unit | bias <sigma_x>/sigma_n | bias mu_bar | verdict |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for _, r in pr.iterrows():
        how = "" if r.measured else " (interpolated)"
        out.append(f"| {r.preset} ({100 * r.target:g}%) | {int(r.N)} | {r.phi:g} | {r.rule} | "
                   f"{r.C:.3g} | {r.wc_dt:.3f} | {r.steps_per_t:.0f} | "
                   f"{_pct(r.stress_bias)} +- {_se(r.stress_se)} | "
                   f"{_pct(r.mu_bar_bias)} +- {_se(r.mu_bar_se)} | {r.verdict}{how} |")
    return "\n".join(out) + "\n"


def timestep_cost() -> str:
    """Per preset and N: the cost of the rule against the one C before, over the phi measured
    (steps per time unit, after / before), and the worst verdict."""
    tr, runs, table = _timestep()
    pr = tr.presets(table)
    rank = {"meets": 0, "within noise": 1, "unresolved": 1, "fails": 2}
    out = ["| preset (target) | N | phi | steps per time unit before -> after | "
           "worst verdict before | worst verdict after |", "|---|---|---|---|---|---|"]
    for (name, n), g in pr.groupby(["preset", "N"], sort=False):
        b, a = g[g.rule == "before"], g[g.rule == "after"]
        steps = ", ".join(f"{x:.0f} -> {y:.0f}" for x, y in
                          zip(b.steps_per_t, a.steps_per_t))
        worst = [max(x.verdict, key=rank.get) for x in (b, a)]
        out.append(f"| {name} ({100 * g.target.iloc[0]:g}%) | {n} | "
                   f"{', '.join(f'{v:g}' for v in a.phi)} | {steps} | {worst[0]} | {worst[1]} |")
    return "\n".join(out) + "\n"


def _record(name: str) -> dict | None:
    """benchmarks/records/NAME.json, or None where it has not been measured yet."""
    import json

    f = HERE / "records" / f"{name}.json"
    return json.loads(f.read_text()) if f.exists() else None


# ------------------------------------------------------------------------- the main command
def _readme_record() -> dict:
    import json

    return json.loads((HERE / "readme_numbers.json").read_text())


def _sweep_wall(h: dict) -> float:
    """A measurement's wall time of the main command as README.md states it: for the current
    one (the record's ``sweep``), the time its printed output gives, where
    benchmarks/readme_numbers.py reads one (``printed_wall``); else the measured ``wall_s``."""
    import readme_numbers

    s = _readme_record().get("sweep") or {}
    printed = getattr(readme_numbers, "printed_wall", None)
    if printed is not None and s.get("output") and h.get("commit") == s.get("commit") \
            and h.get("bytes") == s.get("bytes"):
        wall = printed(s["output"])
        if wall is not None:
            return wall
    return h["wall_s"]


def main_command() -> str:
    """Every measurement of the main command (benchmarks/readme_numbers.py --sweep)."""
    from readme_numbers import duration, human

    out = ["| date | commit | `bkflow sweep --phi 1e-1:1e3` | on disk | runs (pairs) | at a time |",
           "|---|---|---|---|---|---|"]
    for h in _readme_record().get("sweep_history", []):
        out.append(f"| {h['date']} | {h['commit']} | {duration(_sweep_wall(h))} | "
                   f"{human(h['bytes'])} | {h['runs']} | {h['jobs']} |")
    return "\n".join(out) + "\n"


def readme_numbers() -> str:
    """The README's measured numbers as they stand (benchmarks/readme_numbers.json): the main
    command, the quick start and the test suite, each with the date and commit it was
    measured at."""
    from readme_numbers import duration, human

    rec = _readme_record()
    out = ["| what | command | measured | date, commit |", "|---|---|---|---|"]
    s = rec.get("sweep")
    if s:
        out.append(f"| the main command | `{s['command']}` | {duration(_sweep_wall(s))}, "
                   f"{human(s['bytes'])} on disk; {s['runs']} pairs of runs, {s['jobs']} at a "
                   f"time on {s['cores']} cores | {s.get('date', 'n/a')}, "
                   f"{s.get('commit', 'n/a')} |")
    r = rec.get("run")
    if r:
        out.append(f"| the quick start | `{r['command']}` | {duration(r['wall_s'])} the "
                   f"whole command, {human(r['bytes'])} on disk | {r.get('date', 'n/a')}, "
                   f"{r.get('commit', 'n/a')} |")
    t = rec.get("tests")
    if t:
        out.append(f"| the test suite | `pytest` (and `pytest -m \"not slow\"`) | {t['all']} "
                   f"tests in {duration(t['wall_s'])} ({t['fast']} in "
                   f"{duration(t['fast_wall_s'])}) on {t['cores']} cores, "
                   f"{'all passed' if t.get('passed') else 'not all passed'} | "
                   f"{t.get('date', 'n/a')}, {t.get('commit', 'n/a')} |")
    return "\n".join(out) + "\n"


def steady_sizes() -> str:
    """The main command's grid under the steady protocol at N = 400 and 900
    (benchmarks/readme_numbers.py --sizes): time, bytes and what its runs were."""
    from readme_numbers import duration, human

    rec = _readme_record().get("sizes")
    if not rec:
        return "(not measured yet: python benchmarks/readme_numbers.py --sizes)\n"
    out = ["| N | command | time | on disk | runs | their states |", "|---|---|---|---|---|---|"]
    for n, m in rec.items():
        if not isinstance(m, dict) or "wall_s" not in m:
            continue
        states = next((ln for ln in m["output"].splitlines() if " runs are steady" in ln), "")
        out.append(f"| {n} | `{m['command']}` | {duration(m['wall_s'])} | "
                   f"{human(m['bytes'])} | {m['runs']} | {states.split(';')[0]} |")
    goes = [(n, m["by_size"]) for n, m in rec.items()
            if isinstance(m, dict) and len(m.get("by_size") or {}) > 1]
    for n, by in goes:
        total = sum(v["run_s"] for v in by.values())
        out += ["", f"Where the time of `--sizes {n}` goes (the runs' LAMMPS seconds, each run "
                "and its companion, summed over both cores):", "",
                "| N | runs | seconds | share | runs to the cap | their seconds |",
                "|---|---|---|---|---|---|"]
        for size, v in by.items():
            out.append(f"| {size} | {v['runs']} | {v['run_s']:.0f} | "
                       f"{100 * v['run_s'] / total:.0f}% | {v['capped']} | "
                       f"{v['capped_s']:.0f} |")
    return "\n".join(out) + "\n"


def fixed_cost() -> str:
    """The fixed cost of a run, piece by piece (benchmarks/fixed_cost.py)."""
    rec = _record("fixed_cost")
    if rec is None:
        return "(not measured yet: python benchmarks/fixed_cost.py)\n"
    m = rec["median_s"]
    out = ["| piece | time (median of "
           f"{rec['rounds']}, {rec['date']}) |", "|---|---|"]
    for name, t in m.items():
        shown = name + (" (inside a process that has its imports)" if name.endswith("warm")
                        else " (a whole process)")
        out.append(f"| {shown} | {t:.2f} s |")
    out.append(f"| the 8000-unit run's own simulation | {rec['simulation_8000_s']:.2f} s |")
    out.append("")
    one = m.get("run 10, one run (paper)")
    warm = m.get("analyze 8000, warm")
    sim = rec["simulation_8000_s"]
    out.append(f"A run's fixed cost (run 10 without its analysis, less the interpreter) is "
               f"{m['run 10'] - m['python']:.2f} s for the steady protocol's pair"
               + (f", {one - m['python']:.2f} s for one run" if one is not None else "")
               + f"; the analysis of an 8000-unit run takes {m['analyze 8000']:.2f} s in a "
               f"process of its own, {m['analyze 8000'] / sim:.2f}x its simulation's time"
               + (f", and {warm:.2f} s ({warm / sim:.2f}x) where the imports are paid (a "
                  "sweep's workers)" if warm is not None else "") + ".")
    return "\n".join(out) + "\n"


def faults() -> str:
    """The fault fuzz's cases and verdicts (benchmarks/faults.py's record)."""
    rec = _record("faults")
    if rec is None:
        return "(not measured yet: python benchmarks/faults.py)\n"
    cases = rec["cases"]
    clean = sum(c["verdict"] == "CLEAN" for c in cases)
    skipped = sum(c["verdict"] == "SKIPPED" for c in cases)
    out = [f"Measured {rec['date']}, {rec['seconds']} s: **{clean} CLEAN of {len(cases)}**"
           + (f" ({skipped} skipped)" if skipped else "") + ".", "",
           "| # | case | exit | last line of stderr (or first of stdout) | verdict |",
           "|---|---|---|---|---|"]
    for k, c in enumerate(cases, 1):
        line = c["line"].replace("|", "/")
        out.append(f"| {k} | {c['case']} | {c['exit']} | {line} | {c['verdict']} |")
    return "\n".join(out) + "\n"


def fresh_attack() -> str:
    """What the fresh attack found (benchmarks/records/fresh_attack.json: its report)."""
    rec = _record("fresh_attack")
    out = [f"A fresh attack on {rec['date']} ({rec['who']}): about {rec['cases']} cases, "
           f"{rec['clean']} clean; {rec['faults']} faults, each fixed and now a case above or a "
           "test in tests/cli/test_faults.py:", ""]
    out += [f"- {f}" for f in rec["faults_found"]]
    out += ["", "Its clean areas: " + "; ".join(f"{n} {what}" for what, n in
                                                rec["clean_areas"].items()) + "."]
    return "\n".join(out) + "\n"


# ------------------------------------------------------------------- what a scene writes
def scene_bytes() -> str:
    """Per size and scene: bytes per 10^5 time units, the loop against friction's, and the
    analysis against the loop (benchmarks/scene_bytes.py's record)."""
    from readme_numbers import human

    rec = _record("scene_bytes")
    if rec is None:
        return "(not measured yet: python benchmarks/scene_bytes.py)\n"
    out = []
    for size, m in sorted(rec.get("sizes", {}).items(), key=lambda kv: len(kv[0])):
        lx, ly = (int(v) for v in size.split("x"))
        out += [f"N = {lx * ly} ({size}), phi = {m['phi']:g}, `--protocol paper --t-end "
                f"{m['t_end']:g}`, default time step; median of {m['rounds']} alternated "
                "rounds:", "",
                "| scene | bytes per 10^5 time units | LAMMPS loop / friction | loop s | "
                "`bkflow analyze` s | analysis / loop |", "|---|---|---|---|---|---|"]
        for scene, r in m["scenes"].items():
            out.append(f"| {scene} | {human(r['bytes_per_1e5'])} | "
                       f"{r['loop_over_friction']:.2f}x | {r['loop_s']:.2f} | "
                       f"{r['analyze_s']:.2f} | {r['analyze_s'] / r['loop_s']:.2f} |")
        out.append("")
    if "long" in rec:
        g = rec["long"]
        out.append(f"`{g['command']}`: {human(g['bytes_written'])} written by the run, "
                   f"{human(g['with_analysis'])} with its analysis; the loop {g['loop_s']:.0f} s, "
                   f"the whole command {g['whole_s']:.0f} s.")
        out.append("")
    return "\n".join(out)


def scene_goals() -> str:
    """Issue 32's goals against the records: the main command's bytes (readme_numbers.json,
    before and after), a run of 10^6 time units at phi = 1000 (scene_bytes.json ``long``), the
    costliest scene without frames against friction, the analysis against the simulation."""
    from readme_numbers import duration, human

    rec = _record("scene_bytes") or {}
    hist = _readme_record().get("sweep_history", [])
    before = next((h for h in hist if h["commit"] == "43a0f39"), None)
    now = hist[-1] if hist else None
    frames = ("clusters", "events", "fronts", "full")   # the scenes that record frames
    no_frames = [(size, scene, r["loop_over_friction"])
                 for size, m in rec.get("sizes", {}).items()
                 for scene, r in m["scenes"].items()
                 if scene not in frames and scene != "friction"]
    worst = max(no_frames, key=lambda x: x[2]) if no_frames else None
    default = [(size, m["scenes"]["figures"]) for size, m in rec.get("sizes", {}).items()
               if "figures" in m["scenes"]]
    long = rec.get("long")

    def met(ok):
        return "**met**" if ok else "**not met**"

    rows = ["| goal | measured | |", "|---|---|---|"]
    if before and now:
        rows.append(f"| the main command writes at most 50 MB | {human(now['bytes'])} in "
                    f"{duration(_sweep_wall(now))} (before: {human(before['bytes'])} in "
                    f"{duration(_sweep_wall(before))}) | {met(now['bytes'] <= 50e6)} |")
    if long:
        rows.append(f"| 10^6 time units at phi = 1000 in the default scene: at most 5 MB | "
                    f"{human(long['bytes_written'])} | {met(long['bytes_written'] <= 5e6)} |")
    if worst:
        rows.append(f"| no scene above 1.1x friction unless it records frames | the costliest "
                    f"without frames: {worst[1]} at {worst[0]}, {worst[2]:.2f}x | "
                    f"{met(worst[2] <= 1.1)} |")
    for size, r in default:
        ratio = r["analyze_s"] / r["loop_s"]
        rows.append(f"| the analysis at most a fifth of the simulation | {size}, default scene: "
                    f"`bkflow analyze` (a process of its own) {r['analyze_s']:.2f} s against "
                    f"the loop's {r['loop_s']:.2f} s ({ratio:.2f}) | {met(ratio <= 0.2)} |")
    for size, r in sorted(rec.get("warm", {}).items(), key=lambda kv: len(kv[0])):
        ratio = r["analyze_s"] / r["loop_s"]
        rows.append(f"| | {size}, default scene, t_end {r['t_end']:g}: the analysis where its "
                    f"imports are paid (a sweep's warm worker) {r['analyze_s']:.2f} s against "
                    f"the loop's {r['loop_s']:.2f} s ({ratio:.2f}) | {met(ratio <= 0.2)} |")
    return "\n".join(rows) + "\n"


# ------------------------------------------------------------------------- the presets
def accuracy_presets() -> str:
    """The accuracy presets as bkflow defines them now (bkflow.model.params.ACCURACY): the error
    target, the two constants of the time-step rule, the run lengths and the target error."""
    from bkflow.model.timestep import ACCURACY

    out = ["| preset | target bias of the time step | c_contact (omega_c dt) | c_stable "
           "(dt omega_max) | t_end, paper protocol | cap, steady protocol | target error of "
           "mu_bar |", "|---|---|---|---|---|---|---|"]
    for name, p in ACCURACY.items():
        out.append(f"| `{name}` | {100 * p.dt_error:g}% | {p.c_contact:g} | {p.c_stable:g} | "
                   f"{p.t_end:g} | {p.t_cap:g} | {p.target_error:g} |")
    return "\n".join(out) + "\n"


# ------------------------------------------------------------------------- many ranks
def _scaling_model():
    import scaling_model as sm

    return sm


def scaling() -> str:
    """One fused rank against two (benchmarks/scaling_model.py's MEASURED, the last line of
    ``python benchmarks/throughput.py --scaling``): time per step, atom-steps/s, the speed-up
    and the two ranks' halo exchange (the slower rank's, its wait included)."""
    sm = _scaling_model()
    out = ["| lattice | N | fused, 1 rank: us/step | fused, 2 ranks: us/step | fused, 1 rank: "
           "atom-steps/s | fused, 2 ranks: atom-steps/s | fused 2 / fused 1 | halo us/step | "
           "halo share of the step |", "|---|---|---|---|---|---|---|---|---|"]
    for lx, n, t1, t2, halo in sorted(sm.MEASURED, key=lambda r: r[1]):
        out.append(f"| {lx:.0f}x{n / lx:.0f} | {n:.0f} | {t1 * 1e6:.1f} | {t2 * 1e6:.1f} | "
                   f"{n / t1:.3e} | {n / t2:.3e} | {t1 / t2:.2f} | {halo * 1e6:.2f} | "
                   f"{100 * halo / t2:.0f}% |")
    return "\n".join(out) + "\n"


def scaling_model() -> str:
    """What ``python benchmarks/scaling_model.py`` prints: the model fitted to MEASURED and
    its predictions."""
    import contextlib
    import io

    sm = _scaling_model()
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        sm.main()
    lines = buf.getvalue().rstrip("\n").splitlines()
    # the first two lines (c(n), the fitted constants) are paragraphs of their own
    return "\n".join(["- " + lines[0], "- " + lines[1]] + lines[2:]) + "\n"


# ------------------------------------------------------------------------- the starts
#: the windows (time units from the start) in which each start's mean stress is compared
START_WINDOWS = ((0.0, 2e3), (2e3, 1e4), (1e4, 1e5))
START_ORDER = ("random", "partial", "stratified", "synchronized")


def states_starts() -> str:
    """How far each start's mean stress lies from its layer's long-run mean in the first
    windows of a run (the long runs of benchmarks/stiff_states.py, whole records from t = 0):
    relative deviation, the median over the seeds, per start."""
    import numpy as np

    from bkflow.observables.states import BLOCK_T

    sr, runs, means = _states()
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
                _pct(float(np.median(cell[(n, phi, win, st)])))
                if (n, phi, win, st) in cell else "n/a" for st in START_ORDER))
        seeds = max(len(v) for k, v in cell.items() if k[:2] == (n, phi))
        out.append(f"| {n} | {phi:g} | {seeds} | " + " | ".join(cells) + " |")
    return "\n".join(out) + "\n"


def states_starts_r() -> str:
    """The contacts' coherence R (the mean of |Z| over blocks) of each start in the first
    windows of a run, against its layer's long-run level (the long runs of
    benchmarks/stiff_states.py, from t = 0; the median over the seeds), at the stiff end."""
    import numpy as np

    from bkflow.observables.states import BLOCK_T

    sr, runs, means = _states()
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


# ---------------------------------------------------------------- the protocol, judged
def protocol_bias() -> str:
    """The steady protocol's estimate against each layer's long-run mean, per size and phi
    (benchmarks/protocol_bias.py's records of the model's defaults)."""
    import protocol_bias as pb

    rows = pb.bias_rows()
    if rows.empty:
        return "(not measured yet: python benchmarks/protocol_bias.py run --n 100)\n"
    return pb.before_after(rows) + "\n"


def protocol_offgrid() -> str:
    """The verdict and the estimate off the calibrated grid (benchmarks/protocol_bias.py's
    records of benchmarks/offgrid.py's variants): per variant and phi, then the rates."""
    import offgrid
    import protocol_bias as pb

    rows = pb.bias_rows()
    off = rows[rows.record.isin(list(offgrid.VARIANTS))] if not rows.empty else rows
    if off.empty:
        return "(not measured yet: python benchmarks/protocol_bias.py run ... --label VARIANT)\n"
    out = [pb.markdown(pb.aggregate(off)), "",
           "| set | runs | false metastable | false drifting | false steady |",
           "|---|---|---|---|---|"]
    defaults = rows.record.str.match(r"^N\d+(_|$)")
    for name, d in (("off the grid (the variants above)", off),
                    *((f"N = {n}, the model's defaults", rows[defaults & (rows.N == n)])
                      for n in (100, 400, 900))):
        if len(d):
            r = pb.rates(d)
            out.append(f"| {name} | {len(d)} | {r['false metastable']:.3f} | "
                       f"{r['false drifting']:.3f} | {r['false steady']:.3f} |")
    return "\n".join(out) + "\n"


def step_states() -> str:
    """The time step at the stiff end (benchmarks/step_states.py): each C's states and means
    against C = 1, paired by seed, and C = 1's bias against dt -> 0."""
    import step_states as ss

    t = ss.table()
    if t.empty or not (t.C != 1.0).any():
        return "(not measured yet: python benchmarks/step_states.py run)\n"
    out = ["| phi | C | seeds | quiet share | residence quiet / coherent | <sigma_x>/sigma_n "
           "quiet / coherent / all, against C = 1 | mu_bar quiet / coherent / all, against "
           "C = 1 |", "|---|---|---|---|---|---|---|"]

    def d(r, k):
        return f"{_pct(r[f'd_{k}'])} +- {_se(r[f'd_{k}_se'])}"

    for _, r in t.iterrows():
        out.append(f"| {r.phi:g} | {r.C:g} | {int(r.seeds)} | {r.quiet:.2f} +- "
                   f"{_g(r.quiet_sd, '.2f')} "
                   f"| {_g(r.res_quiet, '.2g')} / {_g(r.res_coherent, '.2g')} | "
                   f"{d(r, 's_quiet')} / {d(r, 's_coherent')} / {d(r, 's_all')} | "
                   f"{d(r, 'mu_quiet')} / {d(r, 'mu_coherent')} / {d(r, 'mu_all')} |")
    ex = ss.extrapolated(t)
    if len(ex):
        out += ["", "The long runs' own step (C = 1) against dt -> 0, extrapolated from C = 0.5 "
                "and 1 (second order):", "",
                "| phi | <sigma_x>/sigma_n quiet / coherent / all | mu_bar quiet / coherent / "
                "all |", "|---|---|---|"]
        for _, r in ex.iterrows():
            cells = [" / ".join(f"{_pct(r[k])} +- {_se(r[f'{k}_se'])}"
                                for k in (f"{o}_quiet", f"{o}_coherent", f"{o}_all"))
                     for o in ("s", "mu")]
            out.append(f"| {r.phi:g} | {cells[0]} | {cells[1]} |")
    return "\n".join(out) + "\n"


def work_precision() -> str:
    """Each accuracy preset at its own step: the bias of both observables against dt -> 0
    (benchmarks/work_precision.py's record)."""
    import pandas as pd
    import work_precision as wp

    from bkflow.model.timestep import ACCURACY

    t = pd.read_csv(wp.RECORD)
    pts = wp.preset_points(t)
    out = ["| preset (target) | N | phi | steps per time unit | bias <sigma_x>/sigma_n | "
           "bias mu_bar |", "|---|---|---|---|---|---|"]
    for _, r in pts.sort_values(["preset", "N", "phi"],
                                key=lambda c: c.map(list(ACCURACY).index)
                                if c.name == "preset" else c).iterrows():
        out.append(f"| {r.preset} ({100 * r.target:g}%) | {r.N} | {r.phi:g} | "
                   f"{r.steps_per_t:.0f} | {_pct(r.stress_bias)} +- {_se(r.stress_se)} | "
                   f"{_pct(r.mu_bar_bias)} +- {_se(r.mu_bar_se)} |")
    return "\n".join(out) + "\n"


BLOCKS = {"scene-bytes": scene_bytes, "scene-goals": scene_goals,
          "states-occupancy": states_occupancy, "states-longrun": states_longrun,
          "stiff-seeds": stiff_seeds, "stiff-long": stiff_long,
          "states-coverage": states_coverage, "states-verdict": states_verdict,
          "states-ergodicity": states_ergodicity, "states-needed": states_needed,
          "states-longest": states_longest,
          "states-paper": states_paper, "states-curve": states_curve,
          "timestep-bias": timestep_bias, "timestep-presets": timestep_presets,
          "timestep-cost": timestep_cost, "main-command": main_command,
          "steady-sizes": steady_sizes, "fixed-cost": fixed_cost,
          "faults": faults, "fresh-attack": fresh_attack,
          "readme-numbers": readme_numbers, "accuracy-presets": accuracy_presets,
          "scaling": scaling, "scaling-model": scaling_model, "states-starts": states_starts,
          "protocol-bias": protocol_bias, "protocol-offgrid": protocol_offgrid,
          "step-states": step_states, "work-precision": work_precision,
          "states-starts-r": states_starts_r}


def large_drops() -> str:
    """The stress drops of N = 14400 at the fixed and the size-scaled threshold, run by run
    (benchmarks/large_drops.py's record)."""
    rec = _record("large_drops")
    if rec is None:
        return "(not measured yet: python benchmarks/large_drops.py)\n"
    out = [f"`{rec['command']}`, each run's drops after the transient:", "",
           "| phi | seed | state | threshold | drops | decades spanned | alpha | p | "
           "power law | favoured |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rec["runs"]:
        for which in ("fixed", "scaled"):
            d = r[which]
            out.append(f"| {r['phi']:g} | {r['seed']} | {r['state']} | {d['threshold']:.3g} "
                       f"({which}) | {d['drops']} | {_g(d['decades'], '.2f')} | "
                       f"{_g(d['alpha'], '.2f')} | {_g(d['p'], '.3f')} | {d['verdict']} | "
                       f"{d['preferred']} |")
    return "\n".join(out) + "\n"


# ------------------------------------------------------------------- two states or one
def _layers(rows) -> str:
    """(N, phi) pairs as "N = 100: phi = 464, 1000; N = 900: phi = 1000" (none: "none")."""
    by_n = {}
    for r in rows:
        by_n.setdefault(r["N"], []).append(f"{r['phi']:g}")
    return "; ".join(f"N = {n}: phi = {', '.join(p)}" for n, p in by_n.items()) or "none"


def bimodality() -> str:
    """Whether the blocks of a layer fall into two groups: Sarle's coefficient of R and of the
    stress, and the quiet share under other block lengths and thresholds
    (benchmarks/bimodality.py's record)."""
    rec = _record("bimodality")
    if rec is None:
        return "(not measured yet: python benchmarks/bimodality.py)\n"
    lengths = [str(v) for v in rec["block_lengths"]]
    fs = " / ".join(f"{f:g}x" for f in rec["factors"])
    out = ["| N | phi | blocks | b of R (blocks of " + " / ".join(lengths) + ") | b of R, "
           "seed by seed | b of the stress | b without the synchronized start (R / stress) | "
           + " | ".join(f"quiet share, blocks of {v} ({fs})" for v in lengths) + " |",
           "|---|---|---|---|---|---|---|" + "---|" * len(lengths)]
    out += [_bimodality_row(r, lengths) for r in rec["layers"]]
    return "\n".join(out + ["", _bimodality_reading(rec, lengths[0])]) + "\n"


def _bimodality_row(r: dict, lengths: list) -> str:
    quiet = [" / ".join(f"{v:.3f}" for v in r["quiet"][k].values()) for k in lengths]
    return (f"| {r['N']} | {r['phi']:g} | {r['blocks']} | "
            + " / ".join(f"{r['sarle_R'][k]:.2f}" for k in lengths)
            + f" | {r['sarle_R_seeds'][0]:.2f} - {r['sarle_R_seeds'][1]:.2f} | "
            f"{r['sarle_stress'][lengths[0]]:.2f} | "
            f"{r['sarle_without_synchronized']['R']:.2f} / "
            f"{r['sarle_without_synchronized']['stress']:.2f} | " + " | ".join(quiet) + " |")


def _bimodality_reading(rec: dict, first: str) -> str:
    """The record in a sentence: where b suggests two modes, where blocks are quiet."""
    ls, cut = rec["layers"], rec["sarle_bimodal"]

    def where(test):
        return _layers([r for r in ls if test(r)])
    return (f"Reading: b above {cut:.3f} (two modes suggested), every seed pooled, blocks of "
            f"{first}: R at {where(lambda r: r['sarle_R'][first] > cut)}; the stress at "
            f"{where(lambda r: r['sarle_stress'][first] > cut)}; R of at least one seed at "
            f"{where(lambda r: r['sarle_R_seeds'][1] > cut)}. Quiet blocks at the threshold: "
            f"{where(lambda r: r['quiet'][first]['1'] > 0)}; at twice it, also "
            f"{where(lambda r: r['quiet'][first]['1'] == 0 < r['quiet'][first]['2'])}.")


# ---------------------------------------------------------------- the paper's claims
CLAIMS = ROOT / "workflows" / "paper" / "claims.json"


def claims_block(name: str):
    """The block ``name`` of workflows/paper/claims.py, rendered from its record claims.json
    (written by workflows/paper/reproduce.py)."""
    def block() -> str:
        import importlib.util
        import json

        if not CLAIMS.exists():
            return "(not measured yet: python workflows/paper/reproduce.py)\n"
        spec = importlib.util.spec_from_file_location("claims", CLAIMS.with_suffix(".py"))
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        return mod.RENDER[name](json.loads(CLAIMS.read_text()))
    return block


BLOCKS["large-drops"] = large_drops
BLOCKS["bimodality"] = bimodality
BLOCKS["relaxation"] = relaxation


def summary_keys() -> str:
    """docs/analysis.md's table of every summary key, from the registry that declares them."""
    from bkflow.analysis.registry import keys_table

    return keys_table() + "\n"


BLOCKS["summary-keys"] = summary_keys


def _first_sentence(path: Path) -> str:
    import ast

    doc = ast.get_docstring(ast.parse(path.read_text())) or ""
    first = " ".join(doc.split("\n\n")[0].split())
    # the first full stop that ends a sentence: not an abbreviation's, not inside a literal
    end = next((m.start() for m in re.finditer(r"\. (?=[A-Z])", first)
                if not re.search(r"(\bFig|\bal|\be\.g|\bi\.e|\bEq)$", first[:m.start()])
                and first[:m.start()].count("`") % 2 == 0), -1)
    # reStructuredText's literals as Markdown's
    return (first[:end + 1] if end >= 0 else first).replace("``", "`").replace("|", "\\|")


def layout() -> str:
    """docs/develop.md's table of the package: each group (its __init__'s words) and each of
    its modules (the first sentence of its docstring), in the layers' order of
    tests/test_house.py."""
    src = ROOT / "src" / "bkflow"
    rows = ["| group | module | what it does |", "|---|---|---|"]
    for group in ("model", "observables", "store", "lammps", "analysis", "sweeps", "figures",
                  "cli"):
        rows.append(f"| `{group}/` | | {_first_sentence(src / group / '__init__.py')} |")
        for path in sorted((src / group).glob("*.py")):
            if path.name != "__init__.py":
                rows.append(f"| | `{path.name}` | {_first_sentence(path)} |")
    for name in ("api.py", "cluster.py"):
        rows.append(f"| `{name}` | | {_first_sentence(src / name)} |")
    return "\n".join(rows) + "\n"


BLOCKS["layout"] = layout
BLOCKS.update({name: claims_block(name) for name in (
    "claims-verdicts", "claims-1", "claims-4", "claims-5", "claims-6", "claims-other",
    "claims-scheme", "claims-sizes")})

#: the largest lattice of the size trend, out of this machine's reach: its grid
LARGEST = {"phi": (10.0, 100.0, 1000.0), "size": (240, 60), "seeds": 2}


def largest_grid() -> str:
    """The grid of the largest lattice (N = 14400 at phi = 10, 100, 1000) under the steady
    protocol, and what it costs at most (bkflow.lammps.limits.cost of its runs: every run to
    its cap), in core-hours at the rate the estimate assumes."""
    from bkflow.lammps.limits import ATOM_STEPS_PER_SECOND, Cost, cost, fmt_bytes
    from bkflow.model.protocols import protocol_fields
    from bkflow.sweeps.grid import sweep_specs

    lx, ly = LARGEST["size"]
    specs = sweep_specs(list(LARGEST["phi"]), [LARGEST["size"]], LARGEST["seeds"],
                        **protocol_fields("steady"))
    total = sum((cost(s) for s in specs), Cost(0, 0, 0))
    phis = ",".join(f"{p:g}" for p in LARGEST["phi"])
    return (f"`bkflow sweep --phi {phis} --sizes {lx}x{ly} --seeds {LARGEST['seeds']} --init "
            f"--out runs/n{lx * ly}`: {len(specs)} runs, at most {total.atom_steps:.2g} "
            f"atom-steps, {total.atom_steps / ATOM_STEPS_PER_SECOND / 3600:.1f} core-hours at "
            f"{ATOM_STEPS_PER_SECOND:.0e} atom-steps/s (every run to its cap t_end = "
            f"{specs[0].t_end:g}), {fmt_bytes(total.disk_bytes)} on disk.\n")


BLOCKS["largest-grid"] = largest_grid


def render(text: str) -> str:
    """``text`` with every generated block it holds made anew."""
    def fill(m):
        name = m.group(2)
        if name not in BLOCKS:
            return m.group(0)
        return m.group(1) + BLOCKS[name]() + m.group(4)

    return BLOCK.sub(fill, text)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true")
    a = ap.parse_args(argv)
    stale = []
    for doc in DOCUMENTS:
        old = doc.read_text()
        new = render(old)
        if new != old:
            if a.write:
                doc.write_text(new)
                print(f"wrote {doc}")
            else:
                stale.append(str(doc))
    for s in stale:
        print(f"{s}: a generated block differs from its records; run "
              "python benchmarks/results_blocks.py --write", file=sys.stderr)
    return 1 if stale else 0


if __name__ == "__main__":
    sys.exit(main())
