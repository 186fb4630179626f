"""The fixed cost of a run: what a ``bkflow run`` costs beyond its simulation, piece by piece,
and the analysis against the simulation it reads.

    python benchmarks/fixed_cost.py [--rounds 5]

Each piece is a whole process, timed as a user meets it, the pieces alternated round by round
(the machine is shared: medians of ``--rounds``), and written to
benchmarks/records/fixed_cost.json (RESULTS.md's block fixed-cost is generated from
it by results_blocks.py):

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

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
RECORD = HERE / "records" / "fixed_cost.json"
BKFLOW = str(Path(sys.executable).with_name("bkflow"))


def _timed(cmd: list[str], cwd: Path) -> float:
    t0 = time.perf_counter()
    subprocess.run(cmd, cwd=cwd, check=True, capture_output=True)
    return time.perf_counter() - t0


WARM = """
import json, sys, time
from bkflow.analysis.summary import analyze
from bkflow.sweeps.local import warm
warm(simulate=False)
analyze(sys.argv[1])            # once, as the run's own analysis: what stays is in memory
times = []
for _ in range(int(sys.argv[2])):
    t0 = time.perf_counter()
    analyze(sys.argv[1])
    times.append(time.perf_counter() - t0)
print(json.dumps(times))
"""


def _warm_analysis(run: Path, rounds: int) -> list[float]:
    p = subprocess.run([sys.executable, "-c", WARM, str(run), str(rounds)], check=True,
                       capture_output=True, text=True)
    return json.loads(p.stdout.strip().splitlines()[-1])


def measure(rounds: int) -> dict:
    work = Path(tempfile.mkdtemp(prefix="bkflow-fixed-"))
    try:
        long = work / "long"
        subprocess.run([BKFLOW, "run", "--phi", "10", "--t-end", "8000", "--protocol", "paper",
                        "--start", "random", "--no-analyze", "--quiet", "--out", str(long)],
                       check=True, capture_output=True)
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
        times: dict[str, list[float]] = {name: [] for name in pieces}
        for k in range(rounds):
            for name, cmd in pieces.items():
                times[name].append(_timed(cmd(k), work))
        times["analyze 8000, warm"] = _warm_analysis(long, rounds)
        return {"rounds": rounds, "median_s": {n: statistics.median(v) for n, v in times.items()},
                "all_s": times, "simulation_8000_s": simulation,
                "cores": os.cpu_count(), "date": time.strftime("%Y-%m-%d")}
    finally:
        shutil.rmtree(work, ignore_errors=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    a = ap.parse_args(argv)
    rec = measure(a.rounds)
    RECORD.parent.mkdir(parents=True, exist_ok=True)
    RECORD.write_text(json.dumps(rec, indent=1) + "\n")
    for name, t in rec["median_s"].items():
        print(f"{name:>20}: {t:6.3f} s (median of {a.rounds})")
    print(f"{'simulation 8000':>20}: {rec['simulation_8000_s']:6.3f} s (the analysed run's)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
