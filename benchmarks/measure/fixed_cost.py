"""The fixed cost of a run: what a ``bkflow run`` costs beyond its simulation, piece by piece,
and the analysis against the simulation it reads.

    python -m benchmarks.measure.fixed_cost [--rounds 5]

Each piece is a whole process, timed as a user meets it, the pieces alternated round by round
(the machine is shared: medians of ``--rounds``), and written to
benchmarks/records/fixed_cost.json (RESULTS.md's block fixed-cost is generated from
it by benchmarks/documents/):

- ``python``: the interpreter alone (``python -c pass``), the floor of any command;
- ``import``: ``python -c "import bkflow.cli.commands"``;
- ``version``: ``bkflow --version``;
- ``run 10``: ``bkflow run --phi 10 --t-end 10 --scene friction --no-analyze`` (MPI and
  LAMMPS start-up, the plugin's load, the deck, 10 time units; the steady protocol: the run
  and its companion, two LAMMPS instances);
- ``run 10, one run (paper)``: the same under ``--protocol paper`` (one LAMMPS instance);
- ``run 10 + analysis``: the same with its analysis;
- ``analyze 8000``: ``bkflow analyze`` of a run of 8000 time units at phi = 10 (the default
  scene), beside that run's own simulation time (its meta.json's wall_time_s);
- ``analyze 8000, warm``: the same analysis in a process that has imported what the analysis
  uses (``bkflow.sweeps.local.warm``, as a sweep's workers have): the analysis' own time, without
  the imports a cold process pays once (timed inside one process, median of ``--rounds``).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.harness import (
    BKFLOW,
    RECORDS,
    ROOT,
    alternated,
    medians,
    parser,
    run_bkflow,
    timed,
    timed_process,
    write_json,
)

RECORD = RECORDS / "fixed_cost.json"


def warm_analysis(run: Path, rounds: int) -> list[float]:
    """In a process that has imported what the analysis uses (``bkflow.sweeps.local.warm``,
    as a sweep's workers have) and analysed ``run`` once: the time of each of ``rounds`` more
    analyses of it (this module's ``--warm RUN ROUNDS``, as a process of its own)."""
    p = subprocess.run([sys.executable, "-m", __spec__.name, "--warm", str(run), str(rounds)],
                       check=True, capture_output=True, text=True, cwd=ROOT)
    return json.loads(p.stdout.strip().splitlines()[-1])


def _warm(run: str, rounds: int) -> None:
    from bkflow.analysis.summary import analyze
    from bkflow.sweeps.local import warm

    warm(simulate=False)
    analyze(run)            # once, as the run's own analysis: what stays is in memory
    print(json.dumps([timed(analyze, run)[1] for _ in range(rounds)]))


def measure(rounds: int) -> dict:
    work = Path(tempfile.mkdtemp(prefix="bkflow-fixed-"))
    try:
        long = work / "long"
        run_bkflow("run", "--phi", "10", "--t-end", "8000", "--protocol", "paper", "--start",
                   "random", "--no-analyze", "--quiet", "--out", long, timeout=None)
        simulation = json.loads((long / "meta.json").read_text())["wall_time_s"]
        pieces = {
            "python": lambda k: [sys.executable, "-c", "pass"],
            "import": lambda k: [sys.executable, "-c", "import bkflow.cli.commands"],
            "version": lambda k: [BKFLOW, "--version"],
            "run 10": lambda k: [BKFLOW, "run", "--phi", "10", "--t-end", "10", "--scene",
                                 "friction", "--no-analyze", "--quiet", "--out",
                                 str(work / f"a{k}")],
            "run 10, one run (paper)": lambda k: [BKFLOW, "run", "--phi", "10", "--t-end",
                                                  "10", "--scene", "friction", "--protocol",
                                                  "paper", "--no-analyze", "--quiet", "--out",
                                                  str(work / f"p{k}")],
            "run 10 + analysis": lambda k: [BKFLOW, "run", "--phi", "10", "--t-end", "10",
                                            "--scene", "friction", "--quiet", "--out",
                                            str(work / f"b{k}")],
            "analyze 8000": lambda k: [BKFLOW, "analyze", str(long)],
        }
        times = alternated({name: lambda k, cmd=cmd: timed_process(cmd(k), cwd=work)
                            for name, cmd in pieces.items()}, rounds)
        times["analyze 8000, warm"] = warm_analysis(long, rounds)
        return {"rounds": rounds, "median_s": medians(times),
                "all_s": times, "simulation_8000_s": simulation,
                "cores": os.cpu_count(), "date": time.strftime("%Y-%m-%d")}
    finally:
        shutil.rmtree(work, ignore_errors=True)


def main(argv=None) -> int:
    ap = parser(__doc__)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--warm", nargs=2, metavar=("RUN", "ROUNDS"),
                    help="(the warm analysis' own process, which the measurement starts)")
    a = ap.parse_args(argv)
    if a.warm:
        return _warm(a.warm[0], int(a.warm[1]))
    rec = measure(a.rounds)
    write_json(RECORD, rec)
    for name, t in rec["median_s"].items():
        print(f"{name:>20}: {t:6.3f} s (median of {a.rounds})")
    print(f"{'simulation 8000':>20}: {rec['simulation_8000_s']:6.3f} s (the analysed run's)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
