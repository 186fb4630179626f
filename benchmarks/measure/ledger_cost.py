"""What the energy ledger costs, and that a scene without it costs what it did: the LAMMPS
loop of one lattice (fused path, one rank) with the ledger off and on (fix bk/substrate
``energy``, fix bk/stress ``energy``), and, given ``--baseline-plugin DIR`` (a build of the
plugin from before the ledger: ``git worktree add /tmp/old <commit>``, cmake and ninja in
/tmp/old/plugins), the friction scene's loop with that build against this one, in separate
processes (BKFLOW_PLUGIN_DIR), alternating, median of ``--rounds``.

    python -m benchmarks.measure.ledger_cost [--size 60x15] [--phi 100] [--steps 100000]
        [--rounds 5] [--baseline-plugin DIR]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile

CHILD = r"""
import sys, time
from bkflow.lammps.deck import DeckOptions, data_text, setup_text
from bkflow.cli.assignments import parse_size
from bkflow.model.params import RunSpec
from bkflow.lammps.plugin import open_lammps
size, phi, steps, energy, d = sys.argv[1], float(sys.argv[2]), int(sys.argv[3]), *sys.argv[4:6]
lx, ly = parse_size(size)
spec = RunSpec(phi=phi, Lx=lx, Ly=ly, seed=1, scene="friction", start="random")
open(f"{d}/data.bk", "w").write(data_text(spec))
lmp = open_lammps()
deck = setup_text(spec, DeckOptions(data=f"{d}/data.bk", stress=f"{d}/stress.csv", phase=None,
                                    thermo_every=10**8, path="auto", energy=energy != "off"))
if energy == "sums":  # the running sums only: stress.csv without the ledger's columns
    deck = deck.replace(" file " + f"{d}/stress.csv energy", " file " + f"{d}/stress.csv")
lmp.commands_string(deck)
lmp.command("run 1000")
t = time.perf_counter()
lmp.command(f"run {steps}")
print(time.perf_counter() - t)
"""


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("--size", default="60x15")
    p.add_argument("--phi", type=float, default=100.0)
    p.add_argument("--steps", type=int, default=100000)
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--baseline-plugin", default=None)
    a = p.parse_args(argv)
    cases = {"ledger off": ("off", None), "ledger on": ("on", None),
             "the running sums only (no energies in stress.csv)": ("sums", None)}
    if a.baseline_plugin:
        cases["ledger off, the baseline build"] = ("off", a.baseline_plugin)
    times = {k: [] for k in cases}
    with tempfile.TemporaryDirectory() as d:
        for _ in range(a.rounds):
            for name, (energy, plugin) in cases.items():
                env = dict(os.environ)
                if plugin:
                    env["BKFLOW_PLUGIN_DIR"] = plugin
                out = subprocess.run([sys.executable, "-c", CHILD, a.size, repr(a.phi),
                                      str(a.steps), energy, d], env=env, check=True,
                                     capture_output=True, text=True).stdout
                times[name].append(float(out.split()[-1]))
    base = statistics.median(times["ledger off"])
    print(f"{a.size}, phi = {a.phi:g}, {a.steps} steps of the friction deck (fused path, "
          f"stress.csv every sample), median of {a.rounds} alternated rounds\n")
    print("| case | loop s | / ledger off |")
    print("|---|---|---|")
    for name, t in times.items():
        m = statistics.median(t)
        print(f"| {name} | {m:.3f} | {m / base:.3f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
