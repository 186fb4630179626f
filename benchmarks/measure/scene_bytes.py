"""What each scene writes and costs, now that the runs reduce their series in the run (issue 32):
``bkflow run --protocol paper --scene S`` of one lattice with every scene in turn, alternated,
``--rounds`` times, at N = 100 and 900; then ``bkflow analyze`` of each. Recorded in
benchmarks/records/scene_bytes.json (resumable: a size already measured is kept unless
``--again``); RESULTS.md's block ``scene-bytes`` is generated from it
(``benchmarks/documents/results_blocks.py``).

- bytes per 10^5 time units: what the run's files that grow with its length hold (all but the
  deck, the data file, the restart file, meta.json and the mark), scaled to 10^5 time units;
- the LAMMPS loop's wall time (meta.json ``wall_time_s``) against the friction scene's, the
  median of the rounds, each round every scene in turn (the machine's noise is shared);
- ``bkflow analyze`` as a process of its own against the run's loop.

``--warm`` times the analysis of a default-scene run in a process whose imports are paid.
``--long`` adds one run of 10^6 time units at phi = 1000, N = 100, in the default scene (the
issue's byte budget: 5 MB).

    python -m benchmarks.measure.scene_bytes [--sizes 20x5 60x15] [--phi 100] [--rounds 3] [--long]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.harness import RECORDS
from bkflow.model.params import DEFAULT_SCENE, SCENES

RECORD = RECORDS / "scene_bytes.json"
#: the run's files that do not grow with its length
FIXED = ("in.bk", "data.bk", "meta.json", ".bkflow-run")
#: time units per size: long enough that the fixed files do not dominate
T_END = {"20x5": 20000.0, "60x15": 4000.0}


def growing_bytes(out: Path) -> int:
    meta = json.loads((out / "meta.json").read_text())
    return sum(b for name, b in meta["file_bytes"].items()
               if name not in FIXED and not name.startswith("restart."))


def measure(size: str, phi: float, t_end: float, rounds: int, work: Path) -> dict:
    bkflow = str(Path(sys.executable).parent / "bkflow")
    scenes = ["friction"] + [s for s in SCENES if s != "friction"]
    loop, analysis, whole = ({s: [] for s in scenes} for _ in range(3))
    rec = {}
    for _ in range(rounds):
        for scene in scenes:
            out = work / f"{size}-{scene}"
            t0 = time.perf_counter()
            subprocess.run([bkflow, "run", "--phi", repr(phi), "--size", size, "--t-end",
                            repr(t_end), "--protocol", "paper", "--scene", scene,
                            "--no-analyze", "--quiet", "--overwrite", "--out", str(out)],
                           check=True, capture_output=True, timeout=7200)
            whole[scene].append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            subprocess.run([bkflow, "analyze", str(out)], check=True, capture_output=True,
                           timeout=7200)
            analysis[scene].append(time.perf_counter() - t0)
            meta = json.loads((out / "meta.json").read_text())
            loop[scene].append(meta["wall_time_s"])
            rec[scene] = {"bytes_written": meta["bytes_written"],
                          "growing_bytes": growing_bytes(out),
                          "files": meta["file_bytes"]}
    base = statistics.median(loop["friction"])
    for scene in scenes:
        rec[scene].update(
            loop_s=statistics.median(loop[scene]), whole_s=statistics.median(whole[scene]),
            analyze_s=statistics.median(analysis[scene]),
            loop_over_friction=statistics.median(loop[scene]) / base,
            bytes_per_1e5=rec[scene]["growing_bytes"] * 1e5 / t_end)
    return {"size": size, "phi": phi, "t_end": t_end, "rounds": rounds, "scenes": rec}


def long_run(work: Path) -> dict:
    bkflow = str(Path(sys.executable).parent / "bkflow")
    out = work / "long"
    t0 = time.perf_counter()
    subprocess.run([bkflow, "run", "--phi", "1000", "--n", "100", "--t-end", "1000000",
                    "--protocol", "paper", "--quiet", "--overwrite", "--out", str(out)],
                   check=True, capture_output=True, timeout=7200)
    whole = time.perf_counter() - t0
    meta = json.loads((out / "meta.json").read_text())
    files = {p.name: p.stat().st_size for p in out.iterdir() if p.is_file()}
    return {"command": "bkflow run --phi 1000 --n 100 --t-end 1000000 --protocol paper "
                       f"(scene {DEFAULT_SCENE})",
            "bytes_written": meta["bytes_written"], "with_analysis": sum(files.values()),
            "files": files, "loop_s": meta["wall_time_s"], "whole_s": whole}


def warm_analysis(size: str, phi: float, t_end: float, work: Path, rounds: int = 3) -> dict:
    """The analysis of a default-scene run in a process whose imports are paid (a sweep's
    warm worker, a notebook): ``bkflow.analysis.summary.analyze`` timed in-process after a first
    call, the median of ``rounds``, against the run's LAMMPS loop."""
    from bkflow.analysis.summary import analyze

    bkflow = str(Path(sys.executable).parent / "bkflow")
    out = work / f"warm-{size}"
    subprocess.run([bkflow, "run", "--phi", repr(phi), "--size", size, "--t-end", repr(t_end),
                    "--protocol", "paper", "--no-analyze", "--quiet", "--overwrite", "--out",
                    str(out)], check=True, capture_output=True, timeout=7200)
    analyze(out)   # the imports, paid once
    times = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        analyze(out)
        times.append(time.perf_counter() - t0)
    meta = json.loads((out / "meta.json").read_text())
    return {"size": size, "phi": phi, "t_end": t_end, "analyze_s": statistics.median(times),
            "loop_s": meta["wall_time_s"]}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("--sizes", nargs="+", default=list(T_END))
    ap.add_argument("--phi", type=float, default=100.0)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--long", action="store_true")
    ap.add_argument("--warm", action="store_true",
                    help="the analysis in a warm process (imports paid), per size")
    ap.add_argument("--again", action="store_true")
    a = ap.parse_args(argv)
    record = json.loads(RECORD.read_text()) if RECORD.exists() else {}
    work = Path(tempfile.mkdtemp(prefix="bkscenebytes"))
    from bkflow.store.provenance import record as provenance

    for size in a.sizes:
        if size in record.get("sizes", {}) and not a.again:
            continue
        m = measure(size, a.phi, T_END.get(size, 4000.0), a.rounds, work)
        record.setdefault("sizes", {})[size] = m
        record["provenance"] = provenance()
        RECORD.write_text(json.dumps(record, indent=1, sort_keys=True) + "\n")
        print(json.dumps({s: {k: v for k, v in r.items() if k != "files"}
                          for s, r in m["scenes"].items()}, indent=1))
    if a.warm and ("warm" not in record or a.again):
        record["warm"] = {size: warm_analysis(size, a.phi, T_END.get(size, 4000.0), work)
                          for size in a.sizes}
        record["provenance"] = provenance()
        RECORD.write_text(json.dumps(record, indent=1, sort_keys=True) + "\n")
        print(json.dumps(record["warm"], indent=1))
    if a.long and ("long" not in record or a.again):
        record["long"] = long_run(work)
        record["provenance"] = provenance()
        RECORD.write_text(json.dumps(record, indent=1, sort_keys=True) + "\n")
        print(json.dumps(record["long"], indent=1))


if __name__ == "__main__":
    main()
