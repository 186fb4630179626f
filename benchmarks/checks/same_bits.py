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

import argparse
import filecmp
import itertools
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

#: (name, RunSpec fields, path, how): how is "engine" (one rank, in pieces), "mpi" (two ranks,
#: lmp) or "restart" (half, write_restart, continue)
RULES = list(itertools.product(("reset", "reset/step", "coulomb"), ("implicit", "half")))


def cases() -> list[tuple[str, dict, str, str]]:
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


#: what one case runs, in a fresh Python with the plugin directory in the environment
CHILD = r'''
import json, sys
from pathlib import Path
import bkflow.lammps.engine
from bkflow.model.params import RunSpec
# the cases compare the plugins' bits, not the model's validity: the engine's stop on contacts
# moved past their whole range in one step (which the coulomb rule at these time steps meets,
# with either plugin) is turned off, so that every case runs to its end
bkflow.lammps.engine.OVERSHOOT_ALLOWED = float("inf")
fields, path, how, out = json.loads(sys.argv[1])
spec = RunSpec(Lx=12, Ly=4, seed=3, t_end=60.0, scene="full", **fields)
out = Path(out)
if how == "engine":
    from bkflow.lammps.engine import run
    run(spec, out, progress=False, chunk_steps=997, path=path)
elif how == "restart":
    import contextlib
    from bkflow.lammps.deck import DeckOptions, continue_text, data_text, setup_text
    from bkflow.lammps.plugin import open_lammps
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
'''


def run_case(case, plugin: Path, out: Path) -> None:
    name, fields, path, how = case
    env = {**os.environ, "BKFLOW_PLUGIN_DIR": str(plugin), "LAMMPS_PLUGIN_PATH": str(plugin)}
    if how == "mpi":
        from bkflow.lammps.deck import DeckOptions
        from bkflow.lammps.deckfiles import write_deck
        from bkflow.model.params import RunSpec

        spec = RunSpec(Lx=12, Ly=4, seed=3, t_end=60.0, scene="full", **fields)
        write_deck(spec, out, DeckOptions(path=path))
        lmp = Path(sys.executable).parent / "lmp"
        mpirun = Path(sys.executable).parent / "mpirun"
        subprocess.run([str(mpirun), "-np", "2", str(lmp), "-in", "in.bk", "-log", "none",
                        "-screen", "none"], cwd=out, env=env, check=True, timeout=600)
        return
    import json

    subprocess.run([sys.executable, "-c", CHILD, json.dumps([fields, path, how, str(out)])],
                   env=env, check=True, timeout=600)


#: files that carry a time, a pid or a version rather than the run's numbers
NOT_COMPARED = {"meta.json", "log.lammps", "log.1", "log.2", ".bkflow.lock", ".bkflow-run"}


def compare(a: Path, b: Path) -> tuple[int, list[str]]:
    names = sorted(p.name for p in a.iterdir() if p.is_file() and p.name not in NOT_COMPARED)
    if sorted(p.name for p in b.iterdir() if p.is_file() and p.name not in NOT_COMPARED) \
            != names:
        return len(names), ["(different files)"]
    differ = [n for n in names if not filecmp.cmp(a / n, b / n, shallow=False)]
    return len(names), differ


def loop_time(plugin: Path, n_side: int, steps: int) -> float:
    code = _loop_code(n_side, steps, True)
    env = {**os.environ, "BKFLOW_PLUGIN_DIR": str(plugin)}
    work = Path(f"/tmp/same_bits_speed_{os.getpid()}")
    work.mkdir(exist_ok=True)
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=work, check=True,
                         capture_output=True, text=True, timeout=600).stdout
    shutil.rmtree(work)
    return float(out.strip().splitlines()[-1])


def _loop_code(n_side: int, steps: int, timed: bool) -> str:
    return (
        "import time\n"
        "from bkflow.lammps.deck import SERIAL_COMM_CUTOFF, DeckOptions, data_text, setup_text\n"
        "from bkflow.model.params import RunSpec\n"
        "from bkflow.lammps.plugin import open_lammps\n"
        f"spec = RunSpec(phi=100.0, Lx={2 * n_side}, Ly={n_side // 2}, scene='friction')\n"
        "open('data.bk', 'w').write(data_text(spec))\n"
        "lmp = open_lammps(log='none')\n"
        "lmp.command(f'variable comm_cutoff index {SERIAL_COMM_CUTOFF}')\n"
        "lmp.commands_string(setup_text(spec, DeckOptions(stress=None, blocks=None, psi=None, "
        "phase=None)))\n"
        "lmp.command('run 100 post no')\n"
        "t = time.perf_counter()\n"
        f"lmp.command('run {steps} pre no post no')\n"
        + ("print(time.perf_counter() - t)\n" if timed else ""))


def instructions(plugin: Path, n_side: int, steps: int) -> float:
    """Instructions of ``steps`` steps of the loop: callgrind's total for a run of that
    length less that of a run of none (the start-up is the same in both)."""
    env = {**os.environ, "BKFLOW_PLUGIN_DIR": str(plugin)}
    work = Path(f"/tmp/same_bits_ir_{os.getpid()}")
    total = []
    for n in (0, steps):
        work.mkdir(exist_ok=True)
        out = subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null",
                              sys.executable, "-c", _loop_code(n_side, n, False)], env=env,
                             cwd=work, check=True, capture_output=True, text=True,
                             timeout=3600).stderr
        total.append(float(re.findall(r"Collected\s*:\s*(\d+)", out)[-1]))
        shutil.rmtree(work)
    return total[1] - total[0]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
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
    side = int(round(np.sqrt(a.speed_n / 1.0)))
    n_atoms = 2 * side * (side // 2)
    times = {"a": [], "b": []}
    for _ in range(a.rounds):  # alternated, so that the machine's drift hits both alike
        for tag, plugin in (("a", a.a), ("b", a.b)):
            times[tag].append(loop_time(plugin.resolve(), side, a.steps))
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
    print(f"\n{'every output identical' if not failed else f'{failed} case(s) differ'}")
    return 1 if failed else 0


if __name__ == "__main__":
    t0 = time.perf_counter()
    rc = main()
    print(f"({time.perf_counter() - t0:.0f} s)")
    raise SystemExit(rc)
