"""What each scene costs, side by side: ``bkflow run`` of one lattice under the paper's protocol
(a fixed run, no companion) with every scene in turn, alternating, ``--rounds`` times; the median
wall time of the LAMMPS loop, of the whole process and of ``bkflow analyze``, and the bytes each
scene writes. The trajectories are the same in every scene (tests/plugins/test_ledger.py:
keeping the energy ledger changes no bit), so only the outputs differ.

    python -m benchmarks.measure.scene_costs [--size 60x15] [--phi 100] [--t-end 8000] [--rounds 3]
        [--scenes friction clusters events full]
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

from bkflow.model.params import SCENES


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("--size", default="60x15")
    ap.add_argument("--phi", type=float, default=100.0)
    ap.add_argument("--t-end", type=float, default=8000.0)
    ap.add_argument("--dt-factor", type=float, default=0.1)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--scenes", nargs="+", choices=SCENES, default=list(SCENES))
    a = ap.parse_args(argv)
    scenes = ["friction"] + [s for s in a.scenes if s != "friction"]
    work = Path(tempfile.mkdtemp(prefix="bkscenes"))
    bkflow = str(Path(sys.executable).parent / "bkflow")
    loop, whole, analysis = ({s: [] for s in scenes} for _ in range(3))
    size = {}
    for _ in range(a.rounds):
        for scene in scenes:
            out = work / scene
            t0 = time.perf_counter()
            subprocess.run([bkflow, "run", "--phi", repr(a.phi), "--size", a.size, "--t-end",
                            repr(a.t_end), "--dt-factor", repr(a.dt_factor), "--protocol",
                            "paper", "--scene", scene, "--no-analyze", "--quiet", "--overwrite",
                            "--out", str(out)], check=True, capture_output=True, timeout=7200)
            whole[scene].append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            subprocess.run([bkflow, "analyze", str(out)], check=True, capture_output=True,
                           timeout=7200)
            analysis[scene].append(time.perf_counter() - t0)
            meta = json.loads((out / "meta.json").read_text())
            loop[scene].append(meta["wall_time_s"])
            size[scene] = meta["bytes_written"]
    base = statistics.median(loop["friction"])
    print(f"`bkflow run --phi {a.phi:g} --size {a.size} --t-end {a.t_end:g} --dt-factor "
          f"{a.dt_factor:g} --protocol paper --scene S --no-analyze`, then `bkflow analyze`; "
          f"median of {a.rounds} alternated rounds\n")
    print("| scene | LAMMPS loop s | / friction | whole run s | bkflow analyze s | "
          "bytes written |")
    print("|---|---|---|---|---|---|")
    for scene in scenes:
        lp = statistics.median(loop[scene])
        print(f"| {scene} | {lp:.2f} | {lp / base:.3f} | {statistics.median(whole[scene]):.2f} "
              f"| {statistics.median(analysis[scene]):.2f} | {size[scene] / 1e6:.1f} MB "
              f"({size[scene] / size['friction']:.1f}x) |")


if __name__ == "__main__":
    main()
