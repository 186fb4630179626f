"""Atom-steps per second of the full model against a deck of built-in LAMMPS styles only.

Both decks have the same lattice, time step and step count; the built-in deck is
bond_style harmonic + fix spring/self (one stiffness) + fix viscous + fix nve + enforce2d,
i.e. the same work without the shear-history friction and per-atom k_d^i. They are measured
alternately, several repeats each, in one process, and the ratio of medians is printed
(the machine is shared and noisy: ratios, not absolute times, are the result).

    python benchmarks/throughput.py [--repeats 5] [--steps 20000]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from bkflow.deck import DeckFiles, data_text, setup_text
from bkflow.params import RunSpec
from bkflow.plugin import open_lammps


def builtin_deck(spec: RunSpec, data: str) -> str:
    """The same lattice with built-in styles only (bond harmonic, K = k_b / 2)."""
    return "\n".join([
        "units lj", "dimension 2", "boundary p p p", "atom_style bond", "atom_modify map array",
        "bond_style harmonic", "fix kd all property/atom d_kd",
        f"read_data {data} fix kd NULL DriveStiffness",
        f"bond_coeff 1 {spec.k_b / 2!r} 1.0",
        "comm_modify cutoff 1.0", "neighbor 0.5 bin", "neigh_modify every 1 delay 0 check yes",
        f"timestep {spec.dt!r}",
        "fix nve all nve",
        f"fix drive all spring/self {spec.k_d!r}",
        f"fix damp all viscous {spec.gamma * spec.mass!r}",
        "fix 2d all enforce2d",
        "thermo 1000000",
    ]) + "\n"


def model_deck(spec: RunSpec, data: str) -> str:
    return ("variable comm_cutoff index 1.0\n"
            + setup_text(spec, DeckFiles(data=data, stress=None), thermo_every=10**6))


def rate(deck: str, spec: RunSpec, steps: int) -> float:
    lmp = open_lammps()
    lmp.commands_string(deck)
    lmp.command("run 1000")  # warm up: first neighbour list, caches
    t = time.perf_counter()
    lmp.command(f"run {steps}")
    wall = time.perf_counter() - t
    lmp.close()
    return spec.N * steps / wall


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--steps", type=int, default=20000)
    ap.add_argument("--phi", type=float, default=10.0)
    a = ap.parse_args(argv)
    tmp = Path(tempfile.mkdtemp())
    print(f"phi = {a.phi:g}, {a.steps} steps, median of {a.repeats} alternating repeats")
    print(f"{'N':>5} {'model atom-steps/s':>20} {'built-in atom-steps/s':>22} {'ratio':>7}")
    for (Lx, Ly) in ((20, 5), (60, 15)):
        spec = RunSpec(phi=a.phi, Lx=Lx, Ly=Ly)
        data = tmp / f"data_{Lx}x{Ly}.bk"
        data.write_text(data_text(spec))
        steps = a.steps if spec.N <= 100 else max(1000, a.steps // 4)
        model, builtin = [], []
        for _ in range(a.repeats):
            model.append(rate(model_deck(spec, str(data)), spec, steps))
            builtin.append(rate(builtin_deck(spec, str(data)), spec, steps))
        m, b = statistics.median(model), statistics.median(builtin)
        print(f"{spec.N:>5} {m:>20.3e} {b:>22.3e} {m / b:>7.2f}")


if __name__ == "__main__":
    main()
