"""Throughput (atom-steps/s) of the full model against a deck of built-in LAMMPS styles, over
N, phi and MPI ranks, plus the cost of the friction scene's output and a timing breakdown.

Both decks have the same lattice, time step and step count; the built-in deck is
bond_style harmonic + fix spring/self (one stiffness) + fix viscous + fix nve + enforce2d,
i.e. the same work without the shear-history friction and per-atom k_d^i. Every case runs
as ``[mpirun -np R] lmp -in deck`` (the plugin loads itself) and the rate comes from LAMMPS's
own "Loop time" of the timed run, after a warm-up run. Model and built-in decks alternate,
``--repeats`` times each, and the ratio of medians is printed (the machine is shared and
noisy: ratios measured side by side, not absolute times, are the result).

One rank uses comm cutoff 1 l (what ``bkflow run`` sets); two ranks use the deck's default,
bond_limit + 1 = 11 l, which any bond up to the engine's guard needs.

Also measured, one rank: the model with the friction scene's only output (sigma_x every
~0.1 time units, ``fix print``) against no output at all; and LAMMPS's timing breakdown
(Bond/Neigh/Comm/Output/Modify/Other) at each N.

    python benchmarks/throughput.py [--sizes 20x5 40x10 60x15 120x30 240x60]
        [--phi 0.1 10 1000] [--ranks 1 2] [--repeats 3] [--atom-steps 2e7]
"""

from __future__ import annotations

import argparse
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from bkflow.deck import DeckFiles, data_text, setup_text
from bkflow.params import RunSpec, parse_size
from bkflow.rundir import DATA, DECK, LOG, STRESS

BIN = Path(sys.executable).parent


def builtin_deck(spec: RunSpec, data: str, cutoff: float) -> str:
    """The same lattice with built-in styles only (bond harmonic, K = k_b / 2)."""
    return "\n".join([
        "units lj", "dimension 2", "boundary p p p", "atom_style bond", "atom_modify map array",
        "bond_style harmonic", "fix kd all property/atom d_kd",
        f"read_data {data} fix kd NULL DriveStiffness",
        f"bond_coeff 1 {spec.k_b / 2!r} 1.0",
        f"comm_modify cutoff {cutoff}", "neighbor 0.5 bin", "neigh_modify every 1 delay 0 check yes",
        f"timestep {spec.dt!r}",
        "fix nve all nve",
        f"fix drive all spring/self {spec.k_d!r}",
        f"fix damp all viscous {spec.gamma * spec.mass!r}",
        "fix 2d all enforce2d",
        "thermo 1000000",
    ]) + "\n"


def model_deck(spec: RunSpec, data: str, cutoff: float, stress: str | None = None) -> str:
    return (f"variable comm_cutoff index {cutoff}\n"
            + setup_text(spec, DeckFiles(data=data, stress=stress), thermo_every=10**7))


def write_data(work: Path, spec: RunSpec) -> Path:
    """The data file of ``spec``'s lattice, in a folder of its own under ``work``."""
    folder = work / f"{spec.Lx}x{spec.Ly}_phi{spec.phi:g}"
    folder.mkdir(parents=True, exist_ok=True)
    data = folder / DATA
    data.write_text(data_text(spec))
    return data


LOOP = re.compile(r"Loop time of ([0-9.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) atoms")


def measure(deck: str, steps: int, ranks: int, work: Path) -> tuple[float, dict]:
    """(atom-steps/s of the timed run, {section: % of its time})."""
    f = work / DECK
    f.write_text(deck + "run 500\nrun %d\n" % steps)
    cmd = [str(BIN / "lmp"), "-in", str(f), "-log", str(work / LOG), "-screen", "none"]
    if ranks > 1:
        cmd = [str(BIN / "mpirun"), "-np", str(ranks)] + cmd
    subprocess.run(cmd, check=True, cwd=work, capture_output=True, timeout=3600)
    text = (work / LOG).read_text()
    loops = LOOP.findall(text)
    wall, _, n_steps, atoms = loops[-1]
    timed = text[text.rfind("Loop time"):]
    breakdown = {m.group(1): float(m.group(2)) for m in re.finditer(
        r"^(Pair|Bond|Neigh|Comm|Output|Modify|Other)\s*\|.*\|\s*([0-9.]+)\s*$", timed, re.M)}
    return int(atoms) * int(n_steps) / float(wall), breakdown


def alternated(decks: dict, steps: int, repeats: int, work: Path) -> dict:
    """Median atom-steps/s of each deck (one rank), the decks run in turn ``repeats`` times."""
    rates = {k: [] for k in decks}
    for _ in range(repeats):
        for k, deck in decks.items():
            rates[k].append(measure(deck, steps, 1, work)[0])
    return {k: statistics.median(v) for k, v in rates.items()}


def compare_output(a) -> None:
    """The stress series' cost: none, fix bk/stress (buffered) and fix print (per line)."""
    from bkflow.deck import SUBSTRATE_FIX

    work = Path(tempfile.mkdtemp())
    print(f"median of {a.repeats} alternating repeats, ~{a.atom_steps:.0e} atom-steps each\n")
    print("| N | no output | fix bk/stress | fix print | bk/stress cost | fix print cost |")
    print("|---|---|---|---|---|---|")
    for size in a.sizes:
        lx, ly = parse_size(size)
        spec = RunSpec(phi=10.0, Lx=lx, Ly=ly)
        data = write_data(work, spec)
        steps = max(200, int(a.atom_steps / spec.N))
        stress = str(work / STRESS)
        old = (f'fix stressp all print {spec.stress_nevery} "$(time:%.10g),'
               f'$(f_{SUBSTRATE_FIX}[1]:%.17g)" file {stress} screen no title "t,sigma_x"\n')
        m = alternated({"none": model_deck(spec, str(data), 1.0),
                        "bk/stress": model_deck(spec, str(data), 1.0, stress=stress),
                        "print": model_deck(spec, str(data), 1.0) + old},
                       steps, a.repeats, work)
        print(f"| {spec.N} | {m['none']:.3e} | {m['bk/stress']:.3e} | {m['print']:.3e} | "
              f"{m['none'] / m['bk/stress']:.3f} | {m['none'] / m['print']:.3f} |", flush=True)


def compare_schemes(a) -> None:
    """Cost of the second-order time stepping: the same deck with each scheme, alternating."""
    work = Path(tempfile.mkdtemp())
    print(f"median of {a.repeats} alternating repeats, ~{a.atom_steps:.0e} atom-steps each\n")
    print("| N | phi | reset + implicit | reset/step + half | new / old |")
    print("|---|---|---|---|---|")
    for size in a.sizes:
        lx, ly = parse_size(size)
        for phi in a.phi:
            new = RunSpec(phi=phi, Lx=lx, Ly=ly)
            old = new.replace(contact_rule="reset/step", damping="half")
            data = write_data(work, new)
            steps = max(200, int(a.atom_steps / new.N))
            m = alternated({"new": model_deck(new, str(data), 1.0),
                            "old": model_deck(old, str(data), 1.0)}, steps, a.repeats, work)
            n, o = m["new"], m["old"]
            print(f"| {new.N} | {phi:g} | {n:.3e} | {o:.3e} | {n / o:.3f} |", flush=True)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", nargs="+", default=["20x5", "40x10", "60x15", "120x30", "240x60"])
    ap.add_argument("--phi", type=float, nargs="+", default=[0.1, 10.0, 1000.0])
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--atom-steps", type=float, default=2e7)
    ap.add_argument("--compare-output", action="store_true",
                    help="instead: no output vs fix bk/stress vs the fix print line bkflow "
                         "used before, phi = 10, one rank")
    ap.add_argument("--compare-schemes", action="store_true",
                    help="instead: the default time stepping (reset + implicit damping) against "
                         "the old one (reset/step + half), one rank")
    a = ap.parse_args(argv)
    if a.compare_schemes:
        return compare_schemes(a)
    if a.compare_output:
        return compare_output(a)
    work = Path(tempfile.mkdtemp())
    print(f"median of {a.repeats} alternating repeats, ~{a.atom_steps:.0e} atom-steps each\n")
    print("| N | phi | ranks | model atom-steps/s | built-in atom-steps/s | model / built-in |")
    print("|---|---|---|---|---|---|")
    output_rows, breakdown_rows = [], []
    for size in a.sizes:
        lx, ly = parse_size(size)
        for phi in a.phi:
            spec = RunSpec(phi=phi, Lx=lx, Ly=ly)
            data = write_data(work, spec)
            steps = max(200, int(a.atom_steps / spec.N))
            for ranks in a.ranks:
                cutoff = 1.0 if ranks == 1 else spec.bond_limit + 1.0
                model, builtin, quiet, loud = [], [], [], []
                for _ in range(a.repeats):
                    r, br = measure(model_deck(spec, str(data), cutoff), steps, ranks, work)
                    model.append(r)
                    builtin.append(measure(builtin_deck(spec, str(data), cutoff), steps, ranks,
                                           work)[0])
                    if ranks == 1 and phi == 10.0:
                        quiet.append(r)
                        loud.append(measure(model_deck(spec, str(data), cutoff,
                                                       stress=str(work / STRESS)),
                                            steps, ranks, work)[0])
                m, b = statistics.median(model), statistics.median(builtin)
                print(f"| {spec.N} | {phi:g} | {ranks} | {m:.3e} | {b:.3e} | {m / b:.2f} |",
                      flush=True)
                if quiet:
                    q, lo = statistics.median(quiet), statistics.median(loud)
                    output_rows.append(f"| {spec.N} | {q:.3e} | {lo:.3e} | {q / lo:.3f} |")
                    breakdown_rows.append(f"| {spec.N} | {m:.3e} | " + " | ".join(
                        f"{br.get(k, 0):.1f}" for k in ("Bond", "Neigh", "Comm", "Output",
                                                        "Modify", "Other")) + " |")
    print("\nfriction scene's output (sigma_x every ~0.1 time units) against none, phi = 10, "
          "one rank:\n")
    print("| N | no output | friction scene | cost ratio |")
    print("|---|---|---|---|")
    print("\n".join(output_rows))
    print("\nLAMMPS timing breakdown of the model, phi = 10, one rank (% of loop time; the "
          "whole fix is 'Modify', 'Bond' is empty since the fix does the bonds):\n")
    print("| N | atom-steps/s | Bond | Neigh | Comm | Output | Modify | Other |")
    print("|---|---|---|---|---|---|---|---|")
    print("\n".join(breakdown_rows))


if __name__ == "__main__":
    main()
