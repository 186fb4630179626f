"""The cost of recording rupture fronts: ``bkflow run`` of one lattice with the scene
``friction`` (sigma_x only), ``fronts`` (+ fix bk/fronts) and ``full`` (everything, the fronts
of the first FRONTS_IN_FULL slips), alternating, ``--rounds`` times; the median wall time of
the LAMMPS loop and of the whole process, and the bytes each scene writes.

    python -m benchmarks.measure.fronts [--size 60x15] [--phi 100] [--t-end 8000] [--rounds 3]
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

SCENES = ("friction", "fronts", "full")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("--size", default="60x15")
    ap.add_argument("--phi", type=float, default=100.0)
    ap.add_argument("--t-end", type=float, default=8000.0)
    ap.add_argument("--rounds", type=int, default=3)
    a = ap.parse_args(argv)
    work = Path(tempfile.mkdtemp(prefix="bkfronts"))
    bkflow = str(Path(sys.executable).parent / "bkflow")
    loop = {s: [] for s in SCENES}
    whole = {s: [] for s in SCENES}
    size = {}
    for _ in range(a.rounds):
        for scene in SCENES:
            out = work / scene
            t0 = time.perf_counter()
            subprocess.run([bkflow, "run", "--phi", repr(a.phi), "--size", a.size, "--t-end",
                            repr(a.t_end), "--scene", scene, "--no-analyze", "--quiet",
                            "--overwrite", "--out", str(out)], check=True,
                           capture_output=True, timeout=7200)
            whole[scene].append(time.perf_counter() - t0)
            meta = json.loads((out / "meta.json").read_text())
            loop[scene].append(meta["wall_time_s"])
            size[scene] = (sum(p.stat().st_size for p in out.iterdir()), meta.get("fronts"))
    base_loop = statistics.median(loop["friction"])
    base_size = size["friction"][0]
    print(f"`bkflow run --phi {a.phi:g} --size {a.size} --t-end {a.t_end:g} --scene S "
          f"--no-analyze` (default C = 0.2), median of {a.rounds} alternated rounds\n")
    print("| scene | LAMMPS loop s | / friction | whole process s | bytes written | "
          "fronts recorded |")
    print("|---|---|---|---|---|---|")
    for scene in SCENES:
        lp = statistics.median(loop[scene])
        fr = size[scene][1]
        recorded = "" if fr is None else f"{fr['written']} of {fr['events']} slips"
        print(f"| {scene} | {lp:.2f} | {lp / base_loop:.2f} | "
              f"{statistics.median(whole[scene]):.2f} | {size[scene][0] / 1e6:.1f} MB "
              f"({size[scene][0] / base_size:.1f}x) | "
              f"{recorded} |")


if __name__ == "__main__":
    main()
