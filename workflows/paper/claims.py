"""The paper's claims: each one's test (its level, critical value and thresholds) and its
verdict, and the tables REPRODUCTION.md and numbers.md show, rendered from the record.

``claims_record.py`` computes the record from the sweeps' tables (``record``) and
``reproduce.py`` writes it to ``workflows/paper/claims.json``; numbers.md's "Claims" section and
REPRODUCTION.md's verdicts and per-claim tables are rendered from that record by the functions
here (``render_*``), REPRODUCTION.md's through ``benchmarks/documents/results_blocks.py``,
which loads this file alone (it imports no module beside it). tests/test_results_blocks.py
fails when a document and the record differ, so that no number of the reproduction is typed twice.

The tests (errors are standard errors over seeds; a difference is significant where it
exceeds Student's t quantile of one-sided level ``ALPHA`` (a two-sided 5%) with seeds - 1
degrees of freedom times the combined error, the level divided by the number of places a test
looked (Bonferroni: claim 1's minimum is picked from every interior phi, claim 2's largest
difference from every stiff phi); a test's power is the difference it finds with 80%
probability, (critical + t_0.8) combined errors):

1. mu_bar(phi) is non-monotonic: its lowest point is interior and below both ends by more
   than the corrected critical value (``claims_record.minimum``); read at the paper's 1%
   threshold and at a size-scaled one (1% times 100/N: the same number of particles per drop
   at every N).
2. Psi(inf) rises from about 0.5 to about 1 and does not depend on N for phi >= 100: Psi(inf)
   at the ends of each curve, and the largest difference between sizes at phi >= 100 in
   combined errors.
3. <l_x>/<l_y> peaks where mu_bar dips: the phi of each, per curve and N.
4. Four regimes C, LC, DP, DT in this order from stiff to soft (20x5): the share of each
   (bkflow.observables.clusters.regime, parity-free) per phi, which appear (5% of the clusters
   at some phi), and the order of the phi where each is most frequent.
5. With Lx <= Ly no DT: the DT share of each lattice (all phi), its error over seeds.
6. The energy argument: for every cluster, is its shape (row, column, whole box, patch) the
   one Eq. 2 makes cheapest for its size and mean slip?
7. Stress drops follow a power law: Clauset et al.'s test in every run.
"""

from __future__ import annotations

import math

#: the one-sided level of every test (a two-sided 5%), before the correction for the places
#: a test looked (``critical``)
ALPHA = 0.025
#: the power a test's "found with 80% power" difference is stated at
POWER = 0.8
#: a regime "appears" when it holds this share of the clusters at some phi
APPEARS = 0.05
#: the paper's order of the regimes from soft to stiff layers (its Fig. 4a)
PAPER_ORDER = ("DT", "DP", "LC", "C")
#: Psi(inf) counts as independent of N where the sizes differ by less than this (1% of its
#: stiff-end value): with enough seeds a difference of 0.005 is significant, yet invisible on
#: the paper's Fig. 3
PSI_SAME = 0.01
#: the curves every claim is decided on: the paper's protocol at its longest run, and the
#: steady protocol (numbers.md has the shorter runs too)
DECIDING = ("paper, t_end = 16000", "steady protocol")
#: the regimes of claim 4, as bkflow.observables.clusters.regime names them
REGIMES = ("C", "W", "LC", "DP", "DT")
#: claim 6's classes: claim 4's regimes (one classification of a cluster, the regime rule of
#: bkflow.observables.clusters on its extents), a whole-box slip one class whether the layer
#: is crystalline (C) or not (W): Eq. 2 knows no Psi
SHAPES = ("whole", "LC", "DP", "DT")
#: Cohen's kappa from which the agreement of two classifications counts as substantial, and
#: up to which as fair or worse (Landis and Koch, Biometrics 33, 159 (1977): 0.21-0.40 fair,
#: 0.41-0.60 moderate, 0.61-0.80 substantial)
KAPPA_SUBSTANTIAL, KAPPA_FAIR = 0.6, 0.4


def critical(seeds: int, looks: int = 1) -> float:
    """How many combined standard errors a difference must exceed: Student's t quantile of
    one-sided level ALPHA / looks (Bonferroni over the ``looks`` places a test picked its
    difference from) with seeds - 1 degrees of freedom (infinite with fewer than 2 seeds:
    nothing is significant)."""
    from scipy.stats import t

    return float(t.ppf(1 - ALPHA / max(1, looks), seeds - 1)) if seeds >= 2 else math.inf


def power_quantile(seeds: int) -> float:
    """The t quantile of POWER with seeds - 1 degrees of freedom: a test of critical value c
    finds a difference of (c + this) combined errors with probability POWER."""
    from scipy.stats import t

    return float(t.ppf(POWER, seeds - 1)) if seeds >= 2 else math.inf


# ---------------------------------------------------------------------------- rendering
def num_text(v, fmt=".4f") -> str:
    return "n/a" if v is None else format(v, fmt)


def _phi(v) -> str:
    """phi to three digits, without an exponent (1000, 215, 0.464)."""
    if v is None:
        return "n/a"
    return f"{v:.0f}" if v >= 100 else f"{v:.3g}"


#: each claim's test as REPRODUCTION's verdict table states it, and as ``verdict1`` ...
#: ``verdict7`` apply it (tests/workflows/test_claims.py applies these words to claims.json
#: itself and compares)
TESTS = {
    1: "interior minimum below both ends by more than t(seeds - 1) combined errors at one-sided "
       f"{ALPHA:g} / (the interior phi it was picked from); reproduced at every N, partly at "
       "some, not reproduced at none; deeper with N: each N's minimum below the smaller N's by "
       "more than t(seeds - 1) combined errors",
    2: f"the ends of each curve below 0.7 and above 0.95, the sizes at phi >= 100 within "
       f"{PSI_SAME:g} (the paper's resolution): reproduced, else partly; and whether they "
       "differ statistically (t, corrected for every pair of sizes at every stiff phi)",
    3: "the phi of <l_x>/<l_y>'s peak equals the phi of mu_bar's interior minimum at every N: "
       "reproduced, else not reproduced",
    4: f"a regime appears at >= {APPEARS:.0%} of the clusters at some phi; reproduced: "
       "C, LC, DP, DT all appear and the phi where each is most frequent rises in the paper's "
       "order DT, DP, LC, C; not reproduced: fewer than three of them appear, or no adjacent "
       "pair of those that do is in order; partly otherwise",
    5: "reproduced: DT share + t(seeds - 1) errors below 1% on every Lx <= Ly; partly: DT on "
       "every Lx <= Ly below half the smallest DT of the Lx > Ly lattices (less DT, not none); "
       "not reproduced otherwise",
    6: f"observed shape against Eq. 2's cheapest for the cluster's size and slip: reproduced "
       f"where Cohen's kappa >= {KAPPA_SUBSTANTIAL:g} (substantial) at every N; not reproduced "
       f"where kappa <= {KAPPA_FAIR:g} (fair or worse) at some N, or a shape the clusters take "
       f"(>= {APPEARS:.0%} at some phi) is never Eq. 2's cheapest; partly otherwise",
    7: "Clauset et al.'s test (p < 0.1 rejects) in every run: reproduced where it is plausible "
       "in most runs, not reproduced where rejected in most, undecided otherwise"}


def verdict1(c: dict) -> str:
    m = c["claim1"].get("mu_bar", {})
    yes = [n for n, r in m.items() if r["non_monotonic"]]
    if not m:
        return "n/a"
    word = "reproduced" if len(yes) == len(m) else "partly" if yes else "not reproduced"
    s = c["claim1"].get("mu_bar_scaled", {})
    scaled = [n for n, r in s.items() if r["non_monotonic"]]
    uncorrected = _dips_uncorrected(m)
    return (f"**{word}**: non-monotonic at N = {', '.join(yes) or 'none'} of {', '.join(m)} "
            f"(the dip's z, N by N, against its corrected critical value: {_dip_zs(m)}"
            + (f"; uncorrected, at N = {', '.join(uncorrected)}" if uncorrected != yes else "")
            + ")"
            + (f"; size-scaled threshold: at {', '.join(scaled) or 'none'}" if s else "")
            + "; deeper with N: " + {True: "yes", False: "no", None: "undecided (no dip at "
                                     "every N)"}[c["claim1"]["deeper_with_N"]])


def _dips_uncorrected(m: dict) -> list[str]:
    """The N whose minimum (``m``: claim 1's per N) a reader who fixed its phi beforehand would
    find significant (no correction for the phi it was picked from)."""
    return [n for n, r in m.items() if r["interior"]
            and min(r["z_lo"], r["z_hi"]) > r["critical_one"]]


def _dip_zs(m: dict) -> str:
    """Each N's dip (``m``: claim 1's per N) in combined errors against its critical value."""
    return ", ".join(f"{min(r['z_lo'], r['z_hi']):.1f} against {r['critical']:.1f}"
                     if r["interior"] else "at an end" for r in m.values())


def verdict2(c: dict) -> str:
    k = c["claim2"]
    lo = min((v[0] for v in k["ends"].values() if v[0] is not None), default=math.nan)
    hi = max((v[1] for v in k["ends"].values() if v[1] is not None), default=math.nan)
    w = k["stiff_size_spread"]
    within = w["diff"] is not None and w["diff"] < PSI_SAME
    word = "reproduced" if lo < 0.7 and hi > 0.95 and within else "partly"
    differ = (f"statistically different ({num_text(w['z'], '.1f')} errors > "
              f"{num_text(w['critical'], '.1f')})" if w.get("significant") else
              f"not statistically different ({num_text(w['z'], '.1f')} errors <= "
              f"{num_text(w['critical'], '.1f')})")
    return (f"**{word}**: {lo:.2f} to {hi:.3f}; the sizes at phi >= 100 "
            f"{'within' if within else 'not within'} {PSI_SAME:g} ({num_text(w['diff'])}), and "
            f"{differ}")


def verdict3(c: dict) -> str:
    k = c["claim3"]
    # only a peak and a dip inside the range pair up: two monotonic curves meet at an end
    same = [n for n, v in k.items() if v["lx_over_ly_max"] == v["mu_bar_min"]
            and v.get("interior")]
    opposite = [n for n, v in k.items() if v["lx_over_ly_max"] == v["mu_bar_large_max"]
                and v["lx_over_ly_max"] != max(float(p) for p in c["claim4"]["shares"])]
    word = "reproduced" if k and len(same) == len(k) else "not reproduced"
    return (f"**{word}**: peaks at phi = " + ", ".join(f"{_phi(v['lx_over_ly_max'])} (N = {n})"
                                                      for n, v in k.items())
            + (f"; where mu_bar (large drops) is highest at N = {', '.join(opposite)}"
               if opposite else ""))


def verdict4(c: dict) -> str:
    k = c["claim4"]
    four = all(r in k["appear"] for r in PAPER_ORDER)
    kept, pairs = k["pairs_in_order"]
    seen = sum(r in k["appear"] for r in PAPER_ORDER)
    word = ("reproduced" if four and k["paper_order_kept"] else
            "not reproduced" if seen < 3 or kept == 0 else "partly")
    return (f"**{word}**: {', '.join(k['appear'])} appear; {kept} of {pairs} adjacent pairs of "
            "the paper's order kept")


def verdict5(rec: dict) -> str:
    a = rec.get("claim5") or {}
    tall = {k: v for k, v in a.items() if int(k.split("x")[0]) <= int(k.split("x")[1])}
    if not tall:
        return "not run"
    absent = all(_dt_below_1pct(v) for v in tall.values())
    word = "reproduced" if absent else "partly" if _less_dt(a, tall) else "not reproduced"
    return (f"**{word}**: DT " + ", ".join(f"{v['DT']:.3f} at {k}" for k, v in a.items()
                                           if v["DT"] is not None)
            + ("" if absent else "; no Lx <= Ly is below 1%" if not any(
                _dt_below_1pct(v) for v in tall.values()) else ""))


def _less_dt(a: dict, tall: dict) -> bool:
    """Whether every lattice with Lx <= Ly (``tall``, of claim 5's ``a``) has less than half
    the smallest DT share of the lattices with Lx > Ly."""
    wide = [v["DT"] for k, v in a.items() if k not in tall and v["DT"] is not None]
    return bool(wide) and all((v["DT"] or 0) < 0.5 * min(wide) for v in tall.values())


def _dt_below_1pct(v: dict) -> bool:
    """Whether a lattice's DT share (``v``: claim 5's) lies below 1% by claim 5's test: its
    share plus t(seeds - 1) errors."""
    return v["upper"] is not None and v["upper"] < 0.01


def verdict6(c: dict) -> str:
    k = c.get("claim6")
    if not k:
        return "not run"
    ks = [v["kappa"] for v in k.values() if v["kappa"] is not None]
    never = sorted({s for v in k.values() for s in v.get("never_predicted", [])})
    word = ("reproduced" if ks and min(ks) >= KAPPA_SUBSTANTIAL and not never else
            "not reproduced" if not ks or min(ks) <= KAPPA_FAIR or never else "partly")
    return (f"**{word}**: the observed shape is Eq. 2's cheapest for "
            + ", ".join(f"{v['cheapest']:.0%} (kappa {num_text(v['kappa'], '.2f')}, N = {n})"
                        for n, v in k.items())
            + (f"; Eq. 2 never predicts a {' or '.join(never)}, which the clusters take"
               if never else ""))


def verdict7(c: dict) -> str:
    k = c["claim7"]
    word = ("reproduced" if k["plausible"] > k["runs"] / 2 else
            "not reproduced" if k["rejected"] > k["runs"] / 2 else "undecided")
    return (f"**{word}**: rejected in {k['rejected']} of {k['runs']} runs, "
            f"a lognormal favoured in {k['lognormal_favoured']}")


#: the verdict table's rows: the claim, and its verdict from a curve's record (claim 5: from
#: the whole record, the aspect sweep's)
CLAIMS = {1: ("1. mu_bar(phi) non-monotonic, minimum ~40% below mu_s, deeper with N", verdict1),
          2: ("2. Psi(inf) from ~0.5 to ~1, N-independent for phi >= 100", verdict2),
          3: ("3. <l_x>/<l_y> peaks where mu_bar dips", verdict3),
          4: ("4. Four regimes C, LC, DP, DT (20x5)", verdict4),
          5: ("5. With Lx <= Ly no DT", None),
          6: ("6. Energy argument: each slip takes Eq. 2's cheapest shape", verdict6),
          7: ("7. Stress drops follow a power law", verdict7)}


def render_verdicts(rec: dict) -> str:
    """REPRODUCTION.md's verdict table: each claim, the test it is decided by (``TESTS``), and
    its verdict under each deciding curve."""
    cs = [rec["curves"].get(label) for label in DECIDING]
    rows = ["| claim | test | " + " | ".join(DECIDING) + " |", "|---|---|---|---|"]
    for n, (claim, verdict) in CLAIMS.items():
        cells = (["(the aspect sweep: the paper's protocol, t_end = 8000) " + verdict5(rec),
                  "(the paper's protocol only)"] if verdict is None else
                 [verdict(c) if c else "not run" for c in cs])
        rows.append(f"| {claim} | {TESTS[n]} | " + " | ".join(cells) + " |")
    return "\n".join(rows) + "\n"


def render_claim1(rec: dict) -> str:
    rows = ["| curve | reading | N | seeds | phi at min | min | 1 - min/mu_s | z (low end) | "
            "z (high end) | critical (interior phi looked at; uncorrected) | non-monotonic | "
            "dip found with 80% power |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    names = {"mu_bar": "1% threshold", "mu_bar_scaled": "1% x 100/N",
             "mu_bar_large": "large drops"}
    for label, c in rec["curves"].items():
        for field, per in c["claim1"].items():
            if field not in names:
                continue
            for n, m in per.items():
                rows.append(f"| {label} | {names[field]} | {n} | {m['seeds']} | "
                            f"{_phi(m['phi'])} | {num_text(m['min'])} | "
                            f"{num_text(m['below_mu_s'], '.3f')} | {num_text(m['z_lo'], '.1f')} | "
                            f"{num_text(m['z_hi'], '.1f')} | {num_text(m['critical'], '.2f')} "
                            f"({m['looks']}; {num_text(m['critical_one'], '.2f')}) | "
                            f"{'**yes**' if m['non_monotonic'] else 'no'} | "
                            f"{num_text(m['dip80'], '.4f')} |")
    rows.append("")
    for label, c in rec["curves"].items():
        k = c["claim1"]
        ranges = "; ".join(f"{names[f]} {num_text(lo, '.0%')} to {num_text(hi, '.0%')}"
                           for f, (lo, hi) in k["below_mu_s_range"].items())
        states = ", ".join(f"{v} {s}" for s, v in sorted(k["stiff_states"].items()))
        deeper = {True: "the dips do", False: "the dips do not",
                  None: "with no dip at every N, nothing can"}[k["deeper_with_N"]]
        rows.append(f"- {label}: every point (numbers.md's table, each N and phi) lies below "
                    f"mu_s by, {ranges}; {deeper} deepen with N beyond the critical value; the "
                    f"runs at phi >= 46: {states}.")
    return "\n".join(rows) + "\n"


def render_claim4(rec: dict) -> str:
    rows = ["| curve | phi | C | W | LC | DP | DT | x not spanned (DP + DT) | clusters |",
            "|---|---|---|---|---|---|---|---|---|"]
    for label, c in rec["curves"].items():
        for phi, s in c["claim4"]["shares"].items():
            cells = [s[k] for k in REGIMES]
            nx = None if cells[3] is None else cells[3] + (cells[4] or 0)
            rows.append(f"| {label} | {phi} | " + " | ".join(num_text(v, ".2f") for v in cells)
                        + f" | {num_text(nx, '.2f')} | {s['clusters']} |")
    rows.append("")
    for label, c in rec["curves"].items():
        k = c["claim4"]
        rows.append(f"- {label}: most frequent at phi = " + ", ".join(
            f"{r} {_phi(p)}" for r, p in sorted(k["peak_phi"].items(), key=lambda t: t[1])))
    return "\n".join(rows) + "\n"


def render_claim5(rec: dict) -> str:
    rows = ["| lattice | N | Lx/Ly | clusters | DT | its error (seeds) | DT + t(seeds - 1) errors "
            "| W |",
            "|---|---|---|---|---|---|---|---|"]
    for k, v in (rec.get("claim5") or {}).items():
        lx, ly = (int(s) for s in k.split("x"))
        rows.append(f"| {k} | {v['N']} | {lx / ly:g} | {v['clusters']} | "
                    f"{num_text(v['DT'], '.3f')} | {num_text(v['DT_sem'], '.3f')} ({v['seeds']}) "
                    f"| {num_text(v['upper'], '.3f')} | {num_text(v['W'], '.3f')} |")
    return "\n".join(rows) + "\n"


def render_claim6(rec: dict) -> str:
    names = " / ".join(SHAPES)
    rows = [f"| curve | N | phi | clusters | shape is the cheapest | seen: {names} | Eq. 2's "
            f"cheapest: {names} |", "|---|---|---|---|---|---|---|"]
    for label, c in rec["curves"].items():
        for n, k in (c.get("claim6") or {}).items():
            for phi, v in k["per_phi"].items():
                seen = " / ".join(num_text(v[f"seen_{s}"], ".2f") for s in SHAPES)
                best = " / ".join(num_text(v[f"predicted_{s}"], ".2f") for s in SHAPES)
                rows.append(f"| {label} | {n} | {phi} | {v['clusters']} | "
                            f"{num_text(v['cheapest'], '.2f')} | {seen} | {best} |")
    return "\n".join(rows) + "\n"


def render_other(rec: dict) -> str:
    """Claims 2, 3 and 7 in a few lines each."""
    out = []
    for label, c in rec["curves"].items():
        k2 = c["claim2"]
        ends = "; ".join(f"N = {n}: {num_text(a, '.3f')} to {num_text(b, '.3f')}"
                         for n, (a, b) in k2["ends"].items())
        w = k2["stiff_size_spread"]
        lower, of = k2["soft_smaller_at_larger_N"]
        out.append(f"- {label}, Psi(inf): {ends}. At phi >= 100 the sizes differ by at most "
                   f"{num_text(w['diff'])} (at phi = {_phi(w['phi'])}; the most significant "
                   f"difference {num_text(w['z'], '.1f')} combined errors, at phi = "
                   f"{_phi(w.get('z_at'))}); below phi = 100 the smallest N lies above the "
                   f"largest at {lower} of {of} phi.")
        k3 = c["claim3"]
        out.append(f"- {label}, <l_x>/<l_y>: " + "; ".join(
            f"N = {n}: peaks at phi = {_phi(v['lx_over_ly_max'])} "
            f"({num_text(v['lx_over_ly_peak'], '.2f')}), "
            f"mu_bar lowest at {_phi(v['mu_bar_min'])}, mu_bar (large drops) highest at "
            f"{_phi(v['mu_bar_large_max'])}" for n, v in k3.items()) + ".")
        k7 = c["claim7"]
        lo, hi = k7["exponent_range"]
        out.append(f"- {label}, stress drops: a power law rejected in {k7['rejected']} of "
                   f"{k7['runs']} runs, plausible in {k7['plausible']} (no fit: "
                   f"{k7['no fit']}); a lognormal favoured in {k7['lognormal_favoured']}; "
                   f"maximum-likelihood exponents {num_text(lo, '.2f')} to {num_text(hi, '.2f')}.")
    return "\n".join(out) + "\n"


def render_scheme(rec: dict) -> str:
    """The paper's first-order scheme against the second-order one, same protocol and step."""
    k = rec.get("scheme")
    if not k:
        return ("(not run yet: python workflows/paper/reproduce.py --protocols "
                "paper_first_order)\n")
    rows = ["| N | phi | mu_bar, second order | mu_bar, first order | difference / combined "
            "error |", "|---|---|---|---|---|"]
    for n, v in k.items():
        for i, phi in enumerate(v["phi"]):
            rows.append(f"| {n} | {_phi(phi)} | {num_text(v['second'][i])} +- "
                        f"{num_text(v['second_sem'][i])} | {num_text(v['first'][i])} +- "
                        f"{num_text(v['first_sem'][i])} | {num_text(v['z'][i], '+.1f')} |")
    rows.append("")
    for n, v in k.items():
        big = [_phi(p) for p, z in zip(v["phi"], v["z"]) if z is not None
               and abs(z) > v["critical"]]
        d2, d1 = v["dip_second"], v["dip_first"]
        rel = [f / sec - 1 for f, sec in zip(v["first"], v["second"])
               if f is not None and sec is not None]
        rows.append(
            f"- N = {n}: the first-order mu_bar lies {100 * min(rel):+.1f}% to "
            f"{100 * max(rel):+.1f}% from the second-order one; the schemes differ beyond "
            f"{v['critical']:.2f} errors (t, corrected "
            f"for {len(v['phi'])} phi) at " + (", ".join(f"phi = {p}" for p in big) or "no phi")
            + f"; the second-order curve is lowest at phi = {_phi(d2.get('phi'))} "
            f"({'non-monotonic' if d2.get('non_monotonic') else 'no significant dip'}), the "
            f"first-order one at phi = {_phi(d1.get('phi'))} "
            f"({'non-monotonic' if d1.get('non_monotonic') else 'no significant dip'}).")
    return "\n".join(rows) + "\n"


def render_sizes(rec: dict) -> str:
    """The steady curve as the lattice grows: mu_bar per N at every phi all sizes share, and
    its trend against log10 N."""
    k = rec.get("sizes")
    if not k:
        return "(not run yet: python workflows/paper/reproduce.py)\n"
    ns = k["sizes"]
    rows = ["| phi | " + " | ".join(f"N = {n}" for n in ns) + " | slope per decade of N | "
            "z (critical) | found with 80% power |", "|---" * (len(ns) + 4) + "|"]
    for phi, v in k["phi"].items():
        cells = {n: f"{num_text(m)} +- {num_text(e)} ({s})" for n, m, e, s in
                 zip(v["N"], v["mean"], v["sem"], v["seeds"])}
        rows.append(f"| {phi} | " + " | ".join(cells.get(n, "") for n in ns)
                    + f" | {num_text(v['slope_per_decade'], '+.5f')} +- "
                    f"{num_text(v['slope_err'], '.5f')}"
                    f" | {num_text(v['z'], '+.1f')} ({num_text(v['critical'], '.2f')}) | "
                    f"{num_text(v['found80'], '.5f')} |")
    falls = [p for p, v in k["phi"].items() if v["falls"]]
    rises = [p for p, v in k["phi"].items() if v["rises"]]
    fitted = sorted({n for v in k["phi"].values() for n in v["fitted"]})
    rows += ["", f"- mu_bar of the steady state falls with N beyond the critical value at phi = "
             f"{', '.join(falls) or 'none'}; rises at phi = {', '.join(rises) or 'none'} (mean "
             "+- standard error over the seeds, their count in brackets; the slope fitted on N "
             f"= {', '.join(map(str, fitted))}, the sizes with at least 3 seeds, its z against "
             "Student's t corrected for the phi tested)."]
    return "\n".join(rows) + "\n"


RENDER = {"claims-verdicts": render_verdicts, "claims-1": render_claim1,
          "claims-4": render_claim4, "claims-5": render_claim5, "claims-6": render_claim6,
          "claims-other": render_other, "claims-scheme": render_scheme,
          "claims-sizes": render_sizes}


def render_all(rec: dict) -> str:
    """numbers.md's "Claims" section: every block REPRODUCTION.md shows, from the record."""
    parts = ["## Claims (the record claims.json; REPRODUCTION.md shows the same blocks)", ""]
    for name, fn in RENDER.items():
        parts += [f"### {name}", "", fn(rec)]
    return "\n".join(parts)
