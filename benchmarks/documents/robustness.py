"""The blocks of RESULTS.md's "Faults and robustness": the fault fuzz's record
(benchmarks/checks/faults/) and what a fresh attack found.
"""

from __future__ import annotations

from benchmarks.documents.cells import record


def faults() -> str:
    """The fault fuzz's cases and verdicts (benchmarks/checks/faults/run.py's record)."""
    rec = record("faults")
    if rec is None:
        return "(not measured yet: python -m benchmarks.checks.faults)\n"
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
    rec = record("fresh_attack")
    out = [f"A fresh attack on {rec['date']} ({rec['who']}): about {rec['cases']} cases, "
           f"{rec['clean']} clean; {rec['faults']} faults, each fixed and now a case above or a "
           "test in tests/cli/test_faults.py:", ""]
    out += [f"- {f}" for f in rec["faults_found"]]
    out += ["", "Its clean areas: " + "; ".join(f"{n} {what}" for what, n in
                                                rec["clean_areas"].items()) + "."]
    return "\n".join(out) + "\n"


#: the blocks this module makes, by name
BLOCKS = {"faults": faults,
          "fresh-attack": fresh_attack}
