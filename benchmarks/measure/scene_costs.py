"""What each scene writes and costs: ``bkflow run --protocol paper --scene S`` of one lattice with
every scene in turn, alternated, ``--rounds`` times, at N = 100 and 900; then ``bkflow
analyze`` of each. The trajectories are the same in every scene (tests/plugins/test_ledger.py:
keeping the energy ledger changes no bit), so only the outputs differ. Recorded in
benchmarks/records/scene_bytes.json (resumable: a size already measured is kept unless
``--again``); RESULTS.md's blocks ``scene-bytes`` and ``scene-goals`` are generated from it
(benchmarks/documents/speed.py).

- bytes per 10^5 time units: what the run's files that grow with its length hold (all but the
  deck, the data file, the restart file, meta.json and the mark), scaled to 10^5 time units;
- the LAMMPS loop's wall time (meta.json ``wall_time_s``) against the friction scene's, the
  median of the rounds, each round every scene in turn (the machine's noise is shared), and
  the whole process's;
- ``bkflow analyze`` as a process of its own against the run's loop;
- the rupture fronts a scene recorded (meta.json ``fronts``: scenes ``fronts`` and ``full``,
  the latter the first FRONTS_IN_FULL slips').

``--warm`` times the analysis of a default-scene run in a process whose imports are paid.
``--long`` adds one run of 10^6 time units at phi = 1000, N = 100, in the default scene (a
byte budget of 5 MB).

    python -m benchmarks.measure.scene_costs [--sizes 20x5 60x15] [--phi 100] [--rounds 3]
        [--t-end T] [--warm] [--long] [--again]
"""

from __future__ import annotations

import json
import statistics
import tempfile
from pathlib import Path

from benchmarks.harness import (
    RECORDS,
    alternated,
    medians,
    parser,
    read_json,
    run_bkflow,
    timed,
    write_json,
)
from bkflow.model.scenes import DEFAULT_SCENE, SCENES

RECORD = RECORDS / "scene_bytes.json"
#: the run's files that do not grow with its length
FIXED = ("in.bk", "data.bk", "meta.json", ".bkflow-run")
#: time units per size: long enough that the fixed files do not dominate
T_END = {"20x5": 20000.0, "60x15": 4000.0}


def growing_bytes(meta: dict) -> int:
    """What the files of a run (its meta.json ``meta``) that grow with its length hold."""
    return sum(b for name, b in meta["file_bytes"].items()
               if name not in FIXED and not name.startswith("restart."))


def _meta(out: Path) -> dict:
    return json.loads((out / "meta.json").read_text())


def measure(size: str, phi: float, t_end: float, rounds: int, work: Path) -> dict:
    """Every scene of one lattice, alternated ``rounds`` times (module doc)."""
    scenes = ["friction"] + [s for s in SCENES if s != "friction"]
    loop, analysis = ({s: [] for s in scenes} for _ in range(2))

    def one(scene: str) -> float:
        out = work / f"{size}-{scene}"
        whole = timed(run_bkflow, "run", "--phi", repr(phi), "--size", size, "--t-end",
                      repr(t_end), "--protocol", "paper", "--scene", scene, "--no-analyze",
                      "--quiet", "--overwrite", "--out", out)[1]
        analysis[scene].append(timed(run_bkflow, "analyze", out)[1])
        loop[scene].append(_meta(out)["wall_time_s"])
        return whole

    whole = medians(alternated({s: lambda _, s=s: one(s) for s in scenes}, rounds))
    base = statistics.median(loop["friction"])
    rec = {}
    for scene in scenes:
        meta = _meta(work / f"{size}-{scene}")
        lp = statistics.median(loop[scene])
        rec[scene] = {"bytes_written": meta["bytes_written"],
                      "growing_bytes": growing_bytes(meta), "files": meta["file_bytes"],
                      "fronts": meta.get("fronts"), "loop_s": lp, "whole_s": whole[scene],
                      "analyze_s": statistics.median(analysis[scene]),
                      "loop_over_friction": lp / base,
                      "bytes_per_1e5": growing_bytes(meta) * 1e5 / t_end}
    return {"size": size, "phi": phi, "t_end": t_end, "rounds": rounds, "scenes": rec}


def long_run(work: Path) -> dict:
    """One run of 10^6 time units at phi = 1000, N = 100, in the default scene."""
    out = work / "long"
    whole = timed(run_bkflow, "run", "--phi", "1000", "--n", "100", "--t-end", "1000000",
                  "--protocol", "paper", "--quiet", "--overwrite", "--out", out)[1]
    meta = _meta(out)
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

    out = work / f"warm-{size}"
    run_bkflow("run", "--phi", repr(phi), "--size", size, "--t-end", repr(t_end), "--protocol",
               "paper", "--no-analyze", "--quiet", "--overwrite", "--out", out)
    analyze(out)   # the imports, paid once
    times = [timed(analyze, out)[1] for _ in range(rounds)]
    return {"size": size, "phi": phi, "t_end": t_end, "analyze_s": statistics.median(times),
            "loop_s": _meta(out)["wall_time_s"]}


def table(m: dict) -> str:
    """One size's measurement as a markdown table."""
    rows = [f"{m['size']}, phi = {m['phi']:g}, t_end = {m['t_end']:g}, median of "
            f"{m['rounds']} alternated rounds\n",
            "| scene | bytes per 10^5 time units | loop s | / friction | whole run s | "
            "`bkflow analyze` s | fronts recorded |", "|---|---|---|---|---|---|---|"]
    for scene, r in m["scenes"].items():
        fr = r["fronts"]
        recorded = "" if fr is None else f"{fr['written']} of {fr['events']} slips"
        rows.append(f"| {scene} | {r['bytes_per_1e5'] / 1e6:.1f} MB | {r['loop_s']:.2f} | "
                    f"{r['loop_over_friction']:.2f} | {r['whole_s']:.2f} | "
                    f"{r['analyze_s']:.2f} | {recorded} |")
    return "\n".join(rows)


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("--sizes", nargs="+", default=list(T_END))
    ap.add_argument("--phi", type=float, default=100.0)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--t-end", type=float, default=None,
                    help="time units of each run (default: T_END of its size, else 4000)")
    ap.add_argument("--long", action="store_true")
    ap.add_argument("--warm", action="store_true",
                    help="the analysis in a warm process (imports paid), per size")
    ap.add_argument("--again", action="store_true")
    a = ap.parse_args(argv)
    from bkflow.store.provenance import record as provenance

    record = read_json(RECORD) or {}
    work = Path(tempfile.mkdtemp(prefix="bkscenecosts"))
    t_end = {size: a.t_end or T_END.get(size, 4000.0) for size in a.sizes}

    def save(key, value):
        record[key] = value
        record["provenance"] = provenance()
        write_json(RECORD, record, sort_keys=True)

    for size in a.sizes:
        if size in record.get("sizes", {}) and not a.again:
            continue
        m = measure(size, a.phi, t_end[size], a.rounds, work)
        save("sizes", {**record.get("sizes", {}), size: m})
        print(table(m) + "\n", flush=True)
    if a.warm and ("warm" not in record or a.again):
        save("warm", {size: warm_analysis(size, a.phi, t_end[size], work) for size in a.sizes})
        print(json.dumps(record["warm"], indent=1))
    if a.long and ("long" not in record or a.again):
        save("long", long_run(work))
        print(json.dumps(record["long"], indent=1))


if __name__ == "__main__":
    main()
