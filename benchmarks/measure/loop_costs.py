"""What a record costs in the LAMMPS loop: the friction scene's deck (the fused path, one rank)
with and without the energy ledger (``ledger``), and with and without the contacts' phase fix
at several sampling intervals (``phase``; fix bk/phase, docs/model.md "Contact phase").

    python -m benchmarks.measure.loop_costs ledger [--size 60x15] [--phi 100] [--steps 100000]
        [--rounds 5] [--baseline-plugin DIR] [--instructions]
    python -m benchmarks.measure.loop_costs phase [--phi 10 1000] [--sizes 20x5 60x15]
        [--every 0.1 1 5] [--t-end 1000] [--rounds 5] [--instructions]

Each case's loop runs in a process of its own (this module's ``--child``), after a warm-up of
1000 steps, the cases alternated ``--rounds`` times; the median loop wall time of each is
printed with its ratio to the deck without the record. ``ledger``: the ledger off and on (fix
bk/substrate ``energy``, fix bk/stress ``energy``), and, given ``--baseline-plugin DIR`` (a
build of the plugin from before the ledger: ``git worktree add /tmp/old <commit>``, cmake and
ninja in /tmp/old/plugins), the ledger off with that build (BKFLOW_PLUGIN_DIR), so that a run
without the ledger is seen to cost what it did. ``phase``: per phi and lattice, the deck without
the phase fix and with it at each sampling interval --every (time units; the default includes
RunSpec.phase_every). With --instructions the loop's instructions are counted instead
(valgrind's callgrind: a loop of the steps less a loop of none, each in its own process),
which a shared, noisy machine does not disturb.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.harness import ROOT, alternated, medians, parser
from bkflow.cli.assignments import parse_size
from bkflow.lammps.deck import SERIAL_COMM_CUTOFF, DeckOptions, data_text, setup_text
from bkflow.model.params import RunSpec

#: the steps each loop runs before the timed one
WARM_UP = 1000


def loop_child(case: dict) -> None:
    """In this process (``--child CASE``): the loop of one case, timed; its seconds printed."""
    spec = RunSpec.from_dict(case["spec"])
    from bkflow.lammps.plugin import open_lammps

    # in a scratch directory: every file the deck writes (its records too) goes there
    with tempfile.TemporaryDirectory() as tmp, contextlib.chdir(tmp):
        work = Path(tmp)
        (work / "data.bk").write_text(data_text(spec))
        lmp = open_lammps(log="none")
        lmp.command(f"variable comm_cutoff index {SERIAL_COMM_CUTOFF}")
        lmp.commands_string(setup_text(spec, DeckOptions(
            data=str(work / "data.bk"), stress=str(work / "stress.csv"),
            phase=str(work / "phase.csv") if case["phase"] else None, thermo_every=10**8,
            path="auto", energy=case["energy"])))
        lmp.command(f"run {WARM_UP} post no")
        t0 = time.perf_counter()
        if case["steps"]:
            lmp.command(f"run {case['steps']} pre no post no")
        print(time.perf_counter() - t0)
        lmp.close()


def _child_command(case: dict) -> list[str]:
    return [sys.executable, "-m", __spec__.name, "--child", json.dumps(case)]


def _env(plugin: str | None) -> dict:
    return {**os.environ, "BKFLOW_PLUGIN_DIR": plugin} if plugin else dict(os.environ)


def loop_seconds(case: dict, plugin: str | None = None) -> float:
    """The loop wall time of ``case`` in a process of its own (with the plugin of ``plugin``,
    a build directory, where given)."""
    out = subprocess.run(_child_command(case), env=_env(plugin), cwd=ROOT, check=True,
                         capture_output=True, text=True).stdout
    return float(out.split()[-1])


def loop_instructions(case: dict, plugin: str | None = None) -> int:
    """The instructions of the loop of ``case``: callgrind's total for a process that runs
    its steps less that of one that runs none (the start-up is the same in both)."""
    total = []
    for steps in (case["steps"], 0):
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "cg.out"
            subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}",
                            *_child_command({**case, "steps": steps})], env=_env(plugin),
                           cwd=ROOT, check=True, capture_output=True)
            total.append(int(re.search(r"^(?:summary|totals): (\d+)", out.read_text(),
                                       re.M).group(1)))
    return total[0] - total[1]


def _case(spec: RunSpec, steps: int, energy: bool = False, phase: bool = False) -> dict:
    return {"spec": spec.to_dict(), "steps": steps, "energy": energy, "phase": phase}


def _rounds(a) -> int:
    """Rounds of a measurement: instructions are counted once (they do not vary)."""
    return 1 if a.instructions else a.rounds


def ledger(a) -> None:
    """The ledger off and on (and off with the baseline build), the friction deck."""
    lx, ly = parse_size(a.size)
    spec = RunSpec(phi=a.phi, Lx=lx, Ly=ly, seed=1, scene="friction", start="random")
    cases = {"ledger off": (_case(spec, a.steps), None),
             "ledger on": (_case(spec, a.steps, energy=True), None)}
    if a.baseline_plugin:
        cases["ledger off, the baseline build"] = (_case(spec, a.steps), a.baseline_plugin)
    measure = loop_instructions if a.instructions else loop_seconds
    m = medians(alternated({name: lambda _, c=c, p=p: measure(c, p)
                            for name, (c, p) in cases.items()}, _rounds(a)))
    what = "loop instructions" if a.instructions else "loop s"
    print(f"{a.size}, phi = {a.phi:g}, {a.steps} steps of the friction deck (fused path, "
          f"stress.csv every sample), median of {_rounds(a)} alternated rounds\n")
    print(f"| case | {what} | / ledger off |")
    print("|---|---|---|")
    for name, v in m.items():
        print(f"| {name} | {v:.4g} | {v / m['ledger off']:.3f} |")


def phase(a) -> None:
    """The deck without the phase fix and with it at each interval, per phi and lattice."""
    what = "loop instructions" if a.instructions else "loop s"
    print(f"| lattice | phi | phase_every | samples | {what}, no phase | with phase | ratio |")
    print("|---|---|---|---|---|---|---|")
    measure = loop_instructions if a.instructions else loop_seconds
    for size in a.sizes:
        lx, ly = parse_size(size)
        for phi in a.phi:
            base = RunSpec(phi=phi, Lx=lx, Ly=ly, t_end=a.t_end, scene="friction")
            specs = {None: base, **{e: base.replace(phase_every=e) for e in a.every}}
            m = medians(alternated({e: lambda _, e=e, s=s: measure(
                _case(s, s.n_steps, phase=e is not None)) for e, s in specs.items()},
                _rounds(a)))
            for e, spec in list(specs.items())[1:]:
                print(f"| {size} | {phi:g} | {e:g} | {spec.n_steps // spec.phase_nevery} | "
                      f"{m[None]:.4g} | {m[e]:.4g} | {m[e] / m[None]:.3f} |", flush=True)


def main(argv=None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--child"]:
        return loop_child(json.loads(argv[1]))
    ap = parser(__doc__)
    sub = ap.add_subparsers(dest="record", required=True)
    led = sub.add_parser("ledger", allow_abbrev=False, help="the energy ledger")
    led.add_argument("--size", default="60x15")
    led.add_argument("--phi", type=float, default=100.0)
    led.add_argument("--steps", type=int, default=100000)
    led.add_argument("--baseline-plugin", default=None)
    pha = sub.add_parser("phase", allow_abbrev=False, help="the contacts' phase fix")
    pha.add_argument("--phi", type=float, nargs="+", default=[10.0, 1000.0])
    pha.add_argument("--sizes", nargs="+", default=["20x5", "60x15"])
    pha.add_argument("--every", type=float, nargs="+", default=[0.1, RunSpec.phase_every, 5.0])
    pha.add_argument("--t-end", type=float, default=1000.0)
    for p in (led, pha):
        p.add_argument("--rounds", type=int, default=5)
        p.add_argument("--instructions", action="store_true",
                       help="count the loop's instructions (valgrind) instead of timing it")
    a = ap.parse_args(argv)
    (ledger if a.record == "ledger" else phase)(a)


if __name__ == "__main__":
    main()
