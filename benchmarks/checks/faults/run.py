"""Fuzz bkflow with bad inputs and faults: every one must end CLEAN (the rules are
benchmarks/checks/faults/fuzz.py's).

    python -m benchmarks.checks.faults [--keep DIR]
    python -m benchmarks.checks.faults --only PART     # one part of PARTS, by its name

Runs each case as a user would (the ``bkflow`` command, in a scratch directory) and prints a
table: case, exit code, the last line of stderr (or the first of stdout), verdict; the whole
fuzz is recorded in benchmarks/records/faults.json, from which RESULTS.md's table is made.

Some cases need root (a read-only and a full file system are tmpfs mounts); they are listed as
SKIPPED where mounting is not allowed. A case's name begins with the label of its class, the
labels RESULTS.md and tests/cli/test_faults*.py use: bad inputs, paths, directories, damaged
files, two writers, full disks, interrupts and pipes unlabelled; [1] hangs (a dead worker),
[2] work before the limits, [3] a sweep into the user's files, [4] a deck over the user's, [5]
figures and movies written whole or not at all, [6] parameter domains, [7] the environment
named, not blamed on the run, [8] one analysis per figure set, [9] lmp -in in a finished run,
[10] options and counts, [11] a hand-edited workspace, [12] other tracebacks, [13] signals,
[14] the documented commands; [T1] nothing outside the directory touched, [T2] job scripts as
Slurm reads them, [T3] a stale record marked current, [T4] a set changed in part, [T5] cut
derived files, [T6] damage the command repairs, [T7] a foreign companion, [T8] the API's
errors, [T9] --set through the options' checks, [T10] the advice, [T11] printed commands safe
to paste, [T12] a planted mark; [F] a fresh attack's cases; [F1]-[F18] runs and records that
are not what they seem, and requests at the edges.
"""

from __future__ import annotations

import shutil
import signal
import tempfile
import time
from pathlib import Path

from benchmarks.checks.faults import containment, inputs, processes, requests
from benchmarks.checks.faults.fuzz import Fuzz, Result
from benchmarks.checks.faults.runs_and_records import runs_and_records
from benchmarks.harness import RECORDS, parser, write_json

#: the record of the last whole fuzz (benchmarks/RESULTS.md's table is generated from it)
RECORD = RECORDS / "faults.json"
#: every part of the fuzz, in the order it runs (the order of the record's cases)
PARTS = (inputs.arguments, inputs.paths, inputs.directories, inputs.damaged,
         processes.writers, processes.disk_full, processes.interrupts, processes.pipes,
         processes.hangs, processes.absurd_grids, requests.users_tables, requests.users_decks,
         requests.whole_figures, requests.whole_movies, requests.misread, requests.options,
         inputs.workspace, requests.tracebacks, processes.signals, requests.docs, requests.cluster,
         containment.outside_untouched, containment.job_scripts, containment.plot_and_collect,
         containment.partial_sets, containment.foreign_companion, containment.api_errors,
         containment.set_checks, containment.advice, containment.paste_safe,
         containment.planted_mark, containment.fresh_attack, runs_and_records)


def table(results: list[Result], seconds: float) -> str:
    """The results as RESULTS.md's table, and a count."""
    rows = ["| # | case | exit | last line of stderr (or first of stdout) | verdict |",
            "|---|---|---|---|---|"]
    rows += [f"| {k} | {r.case} | {r.code} | {r.first.replace('|', '/')} | {r.verdict} |"
             for k, r in enumerate(results, 1)]
    clean = sum(r.verdict == "CLEAN" for r in results)
    skipped = sum(r.verdict == "SKIPPED" for r in results)
    return "\n".join(rows) + (f"\n\n{clean} CLEAN, {skipped} SKIPPED, "
                              f"{len(results) - clean - skipped} not clean, of {len(results)} "
                              f"cases in {seconds:.0f} s")


def record(results: list[Result], seconds: float, scratch: Path) -> None:
    """The whole fuzz, written to RECORD (the scratch directory's path as SCRATCH)."""
    write_json(RECORD, {
        "date": time.strftime("%Y-%m-%d"), "seconds": round(seconds),
        "cases": [{"case": r.case, "exit": r.code,
                   "line": r.first.replace(str(scratch), "SCRATCH"), "verdict": r.verdict}
                  for r in results]})
    print(f"wrote {RECORD}")


def main(argv=None) -> int:
    names = {part.__name__: part for part in PARTS}
    ap = parser(__doc__)
    ap.add_argument("--keep", default=None, help="scratch directory to keep (default: a temp)")
    ap.add_argument("--only", default=None, choices=sorted(names),
                    help="run only this part of the fuzz")
    a = ap.parse_args(argv)
    # started in the background (`cmd &` in a script), this process has SIGINT ignored, and so
    # would every bkflow it starts (an ignored signal stays ignored across exec): the Ctrl-C
    # cases need it as a terminal would deliver it
    signal.signal(signal.SIGINT, signal.default_int_handler)
    root = Path(a.keep or tempfile.mkdtemp(prefix="bkflow-faults-"))
    root.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    fuzz = Fuzz(root)
    for part in PARTS if a.only is None else (names[a.only],):
        part(fuzz)
    seconds = time.time() - t0
    print(table(fuzz.results, seconds))
    if a.only is None:   # the whole fuzz is the record RESULTS.md's table is made from
        record(fuzz.results, seconds, root)
    if not a.keep:
        shutil.rmtree(root, ignore_errors=True)
    clean = sum(r.verdict in ("CLEAN", "SKIPPED") for r in fuzz.results)
    return 0 if clean == len(fuzz.results) else 1
