"""Two builds of the plugin, the same bits: every output of a set of runs compared byte for byte
between plugin A and plugin B (e.g. the build before a refactoring and after it), and the fused
kernel's speed of each, side by side.

    python -m benchmarks.checks.same_bits --a DIR_A --b DIR_B [--out runs/bench/same_bits]
                                   [--speed-n 900] [--rounds 5]

DIR_A, DIR_B: directories holding a ``bkflowplugin.so`` and its ``build_info.json`` (an
installed ``bkflow_plugin`` package, or a CMake build directory: ``cmake -S plugins -B DIR``).
Each run is made in a subprocess with ``BKFLOW_PLUGIN_DIR`` (bkflow.lammps.plugin) and, for ``lmp``,
``LAMMPS_PLUGIN_PATH`` pointing at one of them; the decks are the same text for both.

The cases: every contact rule and damping scheme from the synchronized and the random starts
(and the stratified and partial starts), on the fused path and the general path, on one rank
through the engine (in pieces, scene full: the stress and phase series, snapshots, slip frames
and fronts) and on two ranks with ``mpirun -np 2 lmp``, and a run continued from a restart file
on each path. Prints one row per case (files compared, identical or not) and the fused
kernel's loop time with each build (N = --speed-n, phi = 100, alternated rounds).
"""

from __future__ import annotations

import filecmp
import itertools
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks.harness import ROOT, alternated, parser, tool

#: the lattice, seed, length and scene of every case
SPEC = {"Lx": 12, "Ly": 4, "seed": 3, "t_end": 60.0, "scene": "full"}
#: the contact rules and damping schemes, each with each
RULES = list(itertools.product(("reset", "reset/step", "coulomb"), ("implicit", "half")))


def cases() -> list[tuple[str, dict, str, str]]:
    """(name, RunSpec fields, path, how) of every case: how is "engine" (one rank, in pieces),
    "mpi" (two ranks, lmp) or "restart" (half, write_restart, continue)."""
    out = []
    for (rule, damping), start in itertools.product(RULES, ("synchronized", "random")):
        fields = {"phi": 100.0, "contact_rule": rule, "damping": damping, "start": start}
        for path in ("fused", "general"):
            out.append((f"{rule}/{damping}/{start}/{path}", fields, path, "engine"))
    for start in ("stratified", "partial"):
        for path in ("fused", "general"):
            out.append((f"reset/implicit/{start}/{path}", {"phi": 1000.0, "start": start}, path,
                        "engine"))
    for phi in (0.1, 1000.0):
        out.append((f"phi={phi:g}/2 ranks", {"phi": phi, "start": "random"}, "auto", "mpi"))
        for path in ("fused", "general"):
            out.append((f"phi={phi:g}/restart/{path}", {"phi": phi, "start": "random"}, path,
                        "restart"))
    return out


def run_child(fields: dict, path: str, how: str, out: str) -> None:
    """In this process (``--child-run``, with the plugin directory in the environment): one
    case, "engine" (the engine, in pieces) or "restart" (half, write_restart, continue)."""
    import contextlib

    import bkflow.lammps.engine
    from bkflow.lammps.deck import DeckOptions, continue_text, data_text, setup_text
    from bkflow.lammps.plugin import open_lammps
    from bkflow.model.params import RunSpec

    # the cases compare the plugins' bits, not the model's validity: the engine's stop on
    # contacts moved past their whole range in one step (which the coulomb rule at these time
    # steps meets, with either plugin) is turned off, so that every case runs to its end
    bkflow.lammps.engine.OVERSHOOT_ALLOWED = float("inf")
    spec = RunSpec(**SPEC, **fields)
    out = Path(out)
    if how == "engine":
        bkflow.lammps.engine.run(spec, out, progress=False, chunk_steps=997, path=path)
        return
    out.mkdir(parents=True)
    with contextlib.chdir(out):
        Path("data.bk").write_text(data_text(spec))
        lmp = open_lammps(log="log.1")
        lmp.commands_string(setup_text(spec, DeckOptions(stress="stress.1.csv",
                                                       phase="phase.1.csv", path=path)))
        half = spec.n_steps // 2
        lmp.command(f"run {half}")
        lmp.command("write_restart half.restart")
        lmp.close()
        lmp = open_lammps(log="log.2")
        lmp.commands_string(continue_text(spec, "half.restart",
                                          DeckOptions(data="", stress="stress.2.csv",
                                                      phase="phase.2.csv", snapshots="snap.2",
                                                      slips="slips.2", fronts="fronts.2",
                                                      path=path)))
        lmp.command(f"run {spec.n_steps - half}")
        lmp.close()
        Path("half.restart").unlink()  # holds the LAMMPS version string and a date


def _child(plugin: Path, *args, **kw) -> subprocess.CompletedProcess:
    """This module as a process of its own (``args``: its child mode) with the plugin of
    ``plugin`` (BKFLOW_PLUGIN_DIR, and LAMMPS_PLUGIN_PATH for ``lmp``)."""
    env = {**os.environ, "BKFLOW_PLUGIN_DIR": str(plugin), "LAMMPS_PLUGIN_PATH": str(plugin)}
    return subprocess.run([*kw.pop("prefix", []), sys.executable, "-m", __spec__.name, *args],
                          env=env, cwd=ROOT, check=True, capture_output=True, text=True, **kw)


def run_case(case, plugin: Path, out: Path) -> None:
    name, fields, path, how = case
    if how == "mpi":
        from bkflow.lammps.deck import DeckOptions
        from bkflow.lammps.deckfiles import write_deck
        from bkflow.model.params import RunSpec

        env = {**os.environ, "BKFLOW_PLUGIN_DIR": str(plugin),
               "LAMMPS_PLUGIN_PATH": str(plugin)}
        write_deck(RunSpec(**SPEC, **fields), out, DeckOptions(path=path))
        subprocess.run([tool("mpirun"), "-np", "2", tool("lmp"), "-in", "in.bk", "-log", "none",
                        "-screen", "none"], cwd=out, env=env, check=True, timeout=600)
        return
    _child(plugin, "--child-run", json.dumps([fields, path, how, str(out.resolve())]),
           timeout=600)


#: files that carry a time, a pid or a version rather than the run's numbers
NOT_COMPARED = {"meta.json", "log.lammps", "log.1", "log.2", ".bkflow.lock", ".bkflow-run"}


def compare(a: Path, b: Path) -> tuple[int, list[str]]:
    names = sorted(p.name for p in a.iterdir() if p.is_file() and p.name not in NOT_COMPARED)
    if sorted(p.name for p in b.iterdir() if p.is_file() and p.name not in NOT_COMPARED) \
            != names:
        return len(names), ["(different files)"]
    differ = [n for n in names if not filecmp.cmp(a / n, b / n, shallow=False)]
    return len(names), differ


def loop_child(n_side: int, steps: int, timed_: bool) -> None:
    """In this process (``--child-loop``): the fused kernel's loop of ``steps`` steps on a
    2n x n/2 lattice at phi = 100, in a scratch directory; its wall time printed if
    ``timed_``."""
    import contextlib
    import tempfile

    from bkflow.lammps.deck import SERIAL_COMM_CUTOFF, DeckOptions, data_text, setup_text
    from bkflow.lammps.plugin import open_lammps
    from bkflow.model.params import RunSpec

    spec = RunSpec(phi=100.0, Lx=2 * n_side, Ly=n_side // 2, scene="friction")
    with tempfile.TemporaryDirectory() as work, contextlib.chdir(work):
        Path("data.bk").write_text(data_text(spec))
        lmp = open_lammps(log="none")
        lmp.command(f"variable comm_cutoff index {SERIAL_COMM_CUTOFF}")
        lmp.commands_string(setup_text(spec, DeckOptions(stress=None, blocks=None, psi=None,
                                                         phase=None)))
        lmp.command("run 100 post no")
        t = time.perf_counter()
        lmp.command(f"run {steps} pre no post no")
        if timed_:
            print(time.perf_counter() - t)


def loop_time(plugin: Path, n_side: int, steps: int) -> float:
    out = _child(plugin, "--child-loop", str(n_side), str(steps), "1", timeout=600).stdout
    return float(out.strip().splitlines()[-1])


def instructions(plugin: Path, n_side: int, steps: int) -> float:
    """Instructions of ``steps`` steps of the loop: callgrind's total for a run of that
    length less that of a run of none (the start-up is the same in both)."""
    total = []
    for n in (0, steps):
        err = _child(plugin, "--child-loop", str(n_side), str(n), "0", timeout=3600,
                     prefix=["valgrind", "--tool=callgrind",
                             "--callgrind-out-file=/dev/null"]).stderr
        total.append(float(re.findall(r"Collected\s*:\s*(\d+)", err)[-1]))
    return total[1] - total[0]


def _speed(a) -> None:
    """The fused kernel's loop with each build, alternated rounds; instructions if asked."""
    side = int(round(np.sqrt(a.speed_n / 1.0)))
    n_atoms = 2 * side * (side // 2)
    times = alternated({tag: lambda _, p=plugin: loop_time(p.resolve(), side, a.steps)
                        for tag, plugin in (("a", a.a), ("b", a.b))}, a.rounds)
    ratios = np.array(times["b"]) / np.array(times["a"])
    q1, q3 = np.percentile(ratios, [25, 75])
    print(f"\nfused kernel, N = {n_atoms}, phi = 100, {a.steps} steps, {a.rounds} alternated "
          f"rounds: A {np.median(times['a']):.3f} s, B {np.median(times['b']):.3f} s "
          f"(medians); B / A per round: median {np.median(ratios):.3f}, quartiles "
          f"{q1:.3f}-{q3:.3f}")
    if a.instructions:
        ir = {tag: instructions(plugin.resolve(), side, a.instructions)
              for tag, plugin in (("a", a.a), ("b", a.b))}
        print(f"instructions of the loop ({a.instructions} steps, callgrind, the difference of "
              f"two run lengths): A {ir['a']:.4g}, B {ir['b']:.4g}, B / A = "
              f"{ir['b'] / ir['a']:.4f}")


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--child-run"]:
        return run_child(*json.loads(argv[1]))
    if argv[:1] == ["--child-loop"]:
        return loop_child(int(argv[1]), int(argv[2]), argv[3] == "1")
    ap = parser(__doc__)
    ap.add_argument("--a", required=True, type=Path, help="plugin directory A (before)")
    ap.add_argument("--b", required=True, type=Path, help="plugin directory B (after)")
    ap.add_argument("--out", type=Path, default=Path("runs/bench/same_bits"))
    ap.add_argument("--speed-n", type=int, default=900, help="atoms of the speed comparison "
                    "(a 2n x n/2 lattice for n = sqrt(N))")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--steps", type=int, default=20000, help="steps of each timed loop")
    ap.add_argument("--instructions", type=int, default=0, metavar="STEPS",
                    help="also count the loop's instructions under valgrind (callgrind) for "
                         "this many steps: noise-free, about 50x slower")
    a = ap.parse_args(argv)
    for d in (a.a, a.b):
        if not (d / "bkflowplugin.so").is_file():
            ap.error(f"{d} holds no bkflowplugin.so")
    shutil.rmtree(a.out, ignore_errors=True)
    t0 = time.perf_counter()
    print("| case | files compared | identical |")
    print("|---|---|---|")
    failed = 0
    for i, case in enumerate(cases()):
        outs = []
        for tag, plugin in (("a", a.a), ("b", a.b)):
            out = a.out / f"{i:02d}_{tag}"
            run_case(case, plugin.resolve(), out)
            outs.append(out)
        n, differ = compare(*outs)
        failed += bool(differ)
        print(f"| {case[0]} | {n} | {'yes' if not differ else 'NO: ' + ', '.join(differ)} |",
              flush=True)
    _speed(a)
    print(f"\n{'every output identical' if not failed else f'{failed} case(s) differ'}")
    print(f"({time.perf_counter() - t0:.0f} s)")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
