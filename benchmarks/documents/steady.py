"""The blocks of RESULTS.md's and REPRODUCTION.md's steady state: the relaxation from the
synchronized start, the long-run curve and its tests, the steady protocol judged against the
long runs (on and off the calibrated grid), the time step at the stiff end, two states or one,
and the drops of a large layer.
"""

from __future__ import annotations

import math

from benchmarks.documents.cells import CLAIMS, claims_module, num, pct, record, se
from benchmarks.documents.stiff_end import states
from benchmarks.harness import read_json


def relaxation() -> str:
    """The synchronized start's relaxation (benchmarks/measure/stationarity.py's record): per
    (N, phi), the median over seeds of tau and A / s_inf where a relaxation was fitted (and in
    how many seeds), of t_equil and of the late mean."""
    import numpy as np

    from benchmarks.measure.stationarity import RELAXATION_RECORD
    from benchmarks.report.stationarity import read_relaxation_record

    if not RELAXATION_RECORD.exists():
        return ("(not measured yet: python -m benchmarks.measure.stationarity "
                "relaxation)\n")
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


def _paper_rise(n: int) -> float | None:
    """How far the paper protocol's mu_bar (t_end = 16000, claims.json) rises from its
    minimum to its stiff end at N = n: the effect the long-run curve is tested against."""
    if not CLAIMS.exists():
        return None
    m = read_json(CLAIMS)["curves"].get("paper, t_end = 16000", {})
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
    from benchmarks.report.stiff_states import curve_table

    claims = claims_module()
    sr, runs, means = states()
    table = curve_table(means)
    out = ["| N | phi | seeds | <sigma_x>/sigma_n | mu_bar |", "|---|---|---|---|---|"]
    verdicts = []
    for n, g in table.groupby("N"):
        rows = []
        for r in g.sort_values("phi").to_dict("records"):
            r["k"] = r["seeds"]
            rows.append(r)
            out.append(f"| {int(n)} | {r['phi']:g} | {r['k']} | {r['stress']:.4f} +- "
                       f"{num(r['stress_se'], '.4f')} | {r['mu_bar']:.4f} +- "
                       f"{num(r['mu_bar_se'], '.4f')} |")
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


def protocol_bias() -> str:
    """The steady protocol's estimate against each layer's long-run mean, per size and phi
    (benchmarks/measure/protocol_bias.py's records of the model's defaults)."""
    from benchmarks.report import protocol_bias as pb

    rows = pb.bias_rows()
    if rows.empty:
        return "(not measured yet: python -m benchmarks.measure.protocol_bias --n 100)\n"
    return pb.before_after(rows) + "\n"


def protocol_offgrid() -> str:
    """The verdict and the estimate off the calibrated grid (benchmarks/measure/protocol_bias.py's
    records of benchmarks/measure/offgrid.py's variants): per variant and phi, then the rates."""
    from benchmarks.measure import offgrid
    from benchmarks.report import protocol_bias as pb

    rows = pb.bias_rows()
    off = rows[rows.record.isin(list(offgrid.VARIANTS))] if not rows.empty else rows
    if off.empty:
        return ("(not measured yet: python -m benchmarks.measure.protocol_bias ... "
                "--label VARIANT)\n")
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
    """The time step at the stiff end (benchmarks/measure/step_states.py): each C's states and means
    against C = 1, paired by seed, and C = 1's bias against dt -> 0."""
    from benchmarks.report import step_states as ss

    t = ss.table()
    if t.empty or not (t.C != 1.0).any():
        return "(not measured yet: python -m benchmarks.measure.step_states)\n"
    out = ["| phi | C | seeds | quiet share | residence quiet / coherent | <sigma_x>/sigma_n "
           "quiet / coherent / all, against C = 1 | mu_bar quiet / coherent / all, against "
           "C = 1 |", "|---|---|---|---|---|---|---|"]

    def d(r, k):
        return f"{pct(r[f'd_{k}'])} +- {se(r[f'd_{k}_se'])}"

    for _, r in t.iterrows():
        out.append(f"| {r.phi:g} | {r.C:g} | {int(r.seeds)} | {r.quiet:.2f} +- "
                   f"{num(r.quiet_sd, '.2f')} "
                   f"| {num(r.res_quiet, '.2g')} / {num(r.res_coherent, '.2g')} | "
                   f"{d(r, 's_quiet')} / {d(r, 's_coherent')} / {d(r, 's_all')} | "
                   f"{d(r, 'mu_quiet')} / {d(r, 'mu_coherent')} / {d(r, 'mu_all')} |")
    ex = ss.extrapolated(t)
    if len(ex):
        out += ["", "The long runs' own step (C = 1) against dt -> 0, extrapolated from C = 0.5 "
                "and 1 (second order):", "",
                "| phi | <sigma_x>/sigma_n quiet / coherent / all | mu_bar quiet / coherent / "
                "all |", "|---|---|---|"]
        for _, r in ex.iterrows():
            cells = [" / ".join(f"{pct(r[k])} +- {se(r[f'{k}_se'])}"
                                for k in (f"{o}_quiet", f"{o}_coherent", f"{o}_all"))
                     for o in ("s", "mu")]
            out.append(f"| {r.phi:g} | {cells[0]} | {cells[1]} |")
    return "\n".join(out) + "\n"


def large_drops() -> str:
    """The stress drops of N = 14400 at the fixed and the size-scaled threshold, run by run
    (benchmarks/measure/large_drops.py's record)."""
    rec = record("large_drops")
    if rec is None:
        return "(not measured yet: python -m benchmarks.measure.large_drops)\n"
    out = [f"`{rec['command']}`, each run's drops after the transient:", "",
           "| phi | seed | state | threshold | drops | decades spanned | alpha | p | "
           "power law | favoured |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rec["runs"]:
        for which in ("fixed", "scaled"):
            d = r[which]
            out.append(f"| {r['phi']:g} | {r['seed']} | {r['state']} | {d['threshold']:.3g} "
                       f"({which}) | {d['drops']} | {num(d['decades'], '.2f')} | "
                       f"{num(d['alpha'], '.2f')} | {num(d['p'], '.3f')} | {d['verdict']} | "
                       f"{d['preferred']} |")
    return "\n".join(out) + "\n"


def _layers(rows) -> str:
    """(N, phi) pairs as "N = 100: phi = 464, 1000; N = 900: phi = 1000" (none: "none")."""
    by_n = {}
    for r in rows:
        by_n.setdefault(r["N"], []).append(f"{r['phi']:g}")
    return "; ".join(f"N = {n}: phi = {', '.join(p)}" for n, p in by_n.items()) or "none"


def bimodality() -> str:
    """Whether the blocks of a layer fall into two groups: Sarle's coefficient of R and of the
    stress, and the quiet share under other block lengths and thresholds
    (benchmarks/report/bimodality.py's record)."""
    rec = record("bimodality")
    if rec is None:
        return "(not measured yet: python -m benchmarks.report.bimodality)\n"
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


#: the blocks this module makes, by name
BLOCKS = {"relaxation": relaxation,
          "states-curve": states_curve,
          "protocol-bias": protocol_bias,
          "protocol-offgrid": protocol_offgrid,
          "step-states": step_states,
          "large-drops": large_drops,
          "bimodality": bimodality}
