"""What recording the contacts' phases costs (fix bk/phase, phase.csv; docs/model.md "Contact
phase"): the LAMMPS loop of the engine's deck with and without it, side by side.

    python -m benchmarks.measure.phase_cost [--phi 10 1000] [--sizes 20x5 60x15] [--every 0.1 1 5]
                                    [--t-end 1000] [--rounds 5] [--instructions]

For every phi and lattice, the friction scene's deck (the fused path, one rank) runs
--t-end time units without the phase fix and with it at each sampling interval --every
(time units; the default is RunSpec.phase_every), in alternated rounds; the median loop wall
time of each is printed with its ratio to the deck without the fix. With --instructions the
loop's instructions are counted instead (valgrind's callgrind: a run of --t-end less a run of
no steps, each in its own process), which a shared, noisy machine does not disturb.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from bkflow.cli.assignments import parse_size
from bkflow.lammps.deck import SERIAL_COMM_CUTOFF, DeckOptions, data_text, setup_text
from bkflow.lammps.plugin import open_lammps
from bkflow.model.params import RunSpec


def loop_time(spec: RunSpec, phase: bool, work: Path) -> float:
    (work / "data.bk").write_text(data_text(spec))
    lmp = open_lammps(log="none")
    try:
        lmp.command(f"variable comm_cutoff index {SERIAL_COMM_CUTOFF}")
        lmp.commands_string(setup_text(spec, DeckOptions(data=str(work / "data.bk"),
                                                       stress=str(work / "stress.csv"),
                                                       phase=str(work / "phase.csv")
                                                       if phase else None)))
        lmp.command("run 100 post no")  # warm-up
        t0 = time.perf_counter()
        lmp.command(f"run {spec.n_steps} pre no post no")
        return time.perf_counter() - t0
    finally:
        lmp.close()


def _child(argv) -> None:
    """In a process of its own (under valgrind): the loop of one spec, with or without the
    phase fix, for the given number of steps."""
    spec = RunSpec.from_dict(json.loads(argv[0]))
    phase, steps = argv[1] == "1", int(argv[2])
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        (work / "data.bk").write_text(data_text(spec))
        lmp = open_lammps(log="none")
        lmp.command(f"variable comm_cutoff index {SERIAL_COMM_CUTOFF}")
        lmp.commands_string(setup_text(spec, DeckOptions(
            data=str(work / "data.bk"), stress=str(work / "stress.csv"),
            phase=str(work / "phase.csv") if phase else None)))
        lmp.command("run 100 post no")
        if steps:
            lmp.command(f"run {steps} pre no post no")
        lmp.close()


def instructions(spec: RunSpec, phase: bool, steps: int) -> int:
    """Instructions of the loop's process (callgrind's total)."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "cg.out"
        subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}",
                        sys.executable, __file__, "--child", json.dumps(spec.to_dict()),
                        "1" if phase else "0", str(steps)],
                       check=True, capture_output=True)
        m = re.search(r"^(?:summary|totals): (\d+)", out.read_text(), re.M)
        return int(m.group(1))


def main(argv=None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--child"]:
        return _child(argv[1:])
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("--phi", type=float, nargs="+", default=[10.0, 1000.0])
    ap.add_argument("--sizes", nargs="+", default=["20x5", "60x15"])
    ap.add_argument("--every", type=float, nargs="+", default=[0.1, RunSpec.phase_every, 5.0])
    ap.add_argument("--t-end", type=float, default=1000.0)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--instructions", action="store_true",
                    help="count the loop's instructions (valgrind) instead of timing it")
    a = ap.parse_args(argv)
    if a.instructions:
        print("| lattice | phi | phase_every | samples | loop instructions, no phase | with "
              "phase | ratio |")
        print("|---|---|---|---|---|---|---|")
        for size in a.sizes:
            lx, ly = parse_size(size)
            for phi in a.phi:
                base = RunSpec(phi=phi, Lx=lx, Ly=ly, t_end=a.t_end, scene="friction")
                n = base.n_steps
                off = instructions(base, False, n) - instructions(base, False, 0)
                for e in a.every:
                    spec = base.replace(phase_every=e)
                    on = instructions(spec, True, n) - instructions(spec, True, 0)
                    print(f"| {size} | {phi:g} | {e:g} | {n // spec.phase_nevery} | {off:.4g} "
                          f"| {on:.4g} | {on / off:.3f} |", flush=True)
        return
    print("| lattice | phi | phase_every | samples | loop, no phase (s) | loop with phase (s) "
          "| ratio |")
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for size in a.sizes:
            lx, ly = parse_size(size)
            for phi in a.phi:
                base = RunSpec(phi=phi, Lx=lx, Ly=ly, t_end=a.t_end, scene="friction")
                cases = [(None, base)] + [(e, base.replace(phase_every=e)) for e in a.every]
                times = {e: [] for e, _ in cases}
                for _ in range(a.rounds):  # alternated: the machine's drift hits all alike
                    for e, spec in cases:
                        times[e].append(loop_time(spec, e is not None, work))
                off = float(np.median(times[None]))
                for e, spec in cases[1:]:
                    on = float(np.median(times[e]))
                    print(f"| {size} | {phi:g} | {e:g} | {spec.n_steps // spec.phase_nevery} "
                          f"| {off:.3f} | {on:.3f} | {on / off:.3f} |", flush=True)


if __name__ == "__main__":
    main()
