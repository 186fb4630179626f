"""Throughput of bkflow's engine: the floor kernel, the fused path and the general path, side by
side; the whole process of ``bkflow run``; scaling with N on one and two ranks.

Default (RESULTS.md's "The engine against the floor"): at each lattice (default N = 100, 900,
3600, 14400; phi = 100, C = 0.1, the friction scene) three codes run the same steps, alternating,
``--rounds`` times, and the medians are printed in ns per atom-step with their ratios:

  floor  benchmarks/measure/floor_kernel.c, a tight single-thread C kernel of the same model
         (gcc -O3 -march=native -fno-math-errno; checked against the plugin to 1e-9 first,
         benchmarks/measure/floor.py)
  new    the engine's deck (``fix bk/substrate ... integrate``: the fused path on one rank),
         ``lmp -in in.bk -var comm_cutoff 0.1`` as the engine runs it
  old    the general path (``--path general``): fix nve + fix bk/substrate + fix enforce2d, the
         engine as it was before the fused path (the plugin's general path keeps it
         instruction for instruction), its LAMMPS settings, comm cutoff 1.0

LAMMPS's "Loop time" is the time of the loop; the floor's is its own clock around its loop.

``--whole``: the whole process, ``bkflow run --scene friction --no-analyze`` (imports, deck,
LAMMPS start, loop, meta.json), wall clock, new (``--path auto``; ``--new-bkflow``, or this
bkflow) against old: the bkflow of ``--old-bkflow`` (an environment built from git tag
``before-speed``, the engine before the fused path: see benchmarks/RESULTS.md) if given, else
``--path general`` of this bkflow (which shares the fused path's Python side, so it
understates the gain). Compare two regular
installs (``pip install .``): an editable install under PYTHONDONTWRITEBYTECODE compiles its
modules at every start.

``--scaling``: atom-steps/s against N (900 to 230400) of one fused rank, two fused ranks and
two general ranks (``mpirun -np 2``), side by side, with the ratios and the two fused ranks'
halo exchange time per step (the fix's log line); its last line, MEASURED, feeds
benchmarks/report/scaling_model.py.

    python -m benchmarks.measure.throughput [--sizes 20x5 60x15 120x30 240x60] [--rounds 3]
    python -m benchmarks.measure.throughput --whole [--sizes 20x5 60x15] [--old-bkflow PATH]
    python -m benchmarks.measure.throughput --scaling [--sizes 60x15 120x30 240x60 480x120
        960x240]
    python -m benchmarks.measure.throughput --compare-output | --compare-schemes
"""

from __future__ import annotations

import os

# NumPy's OpenBLAS threads spin while idle: on a 2-core machine they steal the timed core
for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import re  # noqa: E402
import subprocess  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from benchmarks.harness import (  # noqa: E402
    BKFLOW,
    alternated,
    medians,
    parser,
    timed_process,
    tool,
)
from benchmarks.measure.floor import CPU_USE, LOOP, Floor, build, check  # noqa: E402
from bkflow.cli.assignments import parse_size  # noqa: E402
from bkflow.lammps.deck import DeckOptions, data_text, setup_text  # noqa: E402
from bkflow.model.lattice import lattice_for  # noqa: E402
from bkflow.model.params import RunSpec  # noqa: E402
from bkflow.store.layout import DATA, DECK, LOG, STRESS  # noqa: E402

#: the engine's comm cutoff on one rank (bkflow.lammps.deck.SERIAL_COMM_CUTOFF) and the
#: general path's
NEW_CUTOFF, OLD_CUTOFF = 0.1, 1.0


def spec_for(size: str, t_end: float, atom_steps: float | None, phi=100.0) -> RunSpec:
    lx, ly = parse_size(size)
    spec = RunSpec(phi=phi, Lx=lx, Ly=ly, dt_factor=0.1, t_end=t_end, scene="friction", seed=1)
    if atom_steps and spec.N * spec.n_steps > atom_steps:
        spec = spec.replace(t_end=max(20.0, atom_steps / spec.N * spec.dt))
    return spec


def loop_time(deck: str, work: Path, ranks: int = 1, cutoff: float = NEW_CUTOFF):
    """(wall s, CPU s, steps, atoms, log text) of the timed run of ``lmp -in deck``."""
    f = work / DECK
    f.write_text(deck)
    cmd = [tool("lmp"), "-in", str(f), "-var", "comm_cutoff", repr(cutoff), "-log",
           str(work / LOG), "-screen", "none"]
    if ranks > 1:
        cmd = [tool("mpirun"), "-np", str(ranks)] + cmd
    subprocess.run(cmd, check=True, cwd=work, capture_output=True, timeout=7200)
    text = (work / LOG).read_text()
    wall, _, steps, atoms = LOOP.findall(text)[-1]
    cpu = float(wall) * float(CPU_USE.findall(text)[-1]) / 100.0
    return float(wall), cpu, int(steps), int(atoms), text


def decks(spec: RunSpec) -> dict[str, tuple[str, float]]:
    """{code: (deck, comm cutoff)} of the LAMMPS codes."""
    run = f"\nrun             {spec.n_steps}\n"
    files = DeckOptions(data=DATA, stress=STRESS)
    return {"new": (setup_text(spec, files.replace(path="auto")) + run, NEW_CUTOFF),
            "old": (setup_text(spec, files.replace(path="general")) + run, OLD_CUTOFF)}


def codes_table(a) -> None:
    dll = build(Path(tempfile.mkdtemp(prefix="bkfloor")))
    if not a.no_check and not check(dll):
        raise SystemExit("the floor kernel does not match the plugin: no timing")
    work = Path(tempfile.mkdtemp(prefix="bkthroughput"))
    codes = ("floor", "new", "old")
    rows = {}
    for size in a.sizes:
        spec = spec_for(size, a.t_end, a.atom_steps)
        (work / DATA).write_text(data_text(spec))
        lat = lattice_for(spec)
        ds = decks(spec)
        times = {c: [] for c in codes}
        paths = set()
        for _ in range(a.rounds):
            for c in codes:
                if c == "floor":
                    times[c].append(Floor(dll, spec, lat.k_d, lat.positions,
                                          np.zeros((spec.N, 2)), anchor=lat.positions)
                                    .time_per_atom_step(spec)[0])
                    continue
                deck, cutoff = ds[c]
                wall, _, steps, atoms, log = loop_time(deck, work, cutoff=cutoff)
                times[c].append(wall * 1e9 / (steps * atoms))
                if c == "new":
                    paths.add("fused" if "bk/substrate fused:" in log else "general")
        med = medians(times)
        rows[spec.N] = (spec, med, paths)
        print(f"N = {spec.N}: " + ", ".join(f"{c} {med[c]:.2f}" for c in codes), flush=True)
    print(f"\nwall ns per atom-step, median of {a.rounds} alternated rounds (phi = 100, C = 0.1, "
          "scene friction, one rank; LAMMPS: Loop time)\n")
    print("| N | steps | floor | new | old | new / floor | old / floor | old / new | new path |")
    print("|---|---|---|---|---|---|---|---|---|")
    for n, (spec, m, paths) in rows.items():
        print(f"| {n} | {spec.n_steps} | {m['floor']:.2f} | {m['new']:.2f} | {m['old']:.2f} | "
              f"{m['new'] / m['floor']:.2f} | {m['old'] / m['floor']:.2f} | "
              f"{m['old'] / m['new']:.2f} | {', '.join(sorted(paths))} |", flush=True)


def whole(a) -> None:
    """Wall time of the whole ``bkflow run`` process, new against old, alternating."""
    work = Path(tempfile.mkdtemp(prefix="bkwhole"))
    new = [a.new_bkflow] if a.new_bkflow else [BKFLOW]
    old = [a.old_bkflow] if a.old_bkflow else [BKFLOW]
    what_old = f"{a.old_bkflow}" if a.old_bkflow else "this bkflow, --path general"
    print(f"new: {new[0]}\nold: {what_old}\n")
    rows = []
    for size in a.sizes:
        spec = spec_for(size, a.t_end, None)
        args = ["run", "--phi", repr(spec.phi), "--size", size, "--dt-factor", "0.1",
                "--t-end", repr(spec.t_end), "--scene", "friction", "--no-analyze", "--quiet",
                "--overwrite"]
        cmds = {"new": new + args + ["--path", "auto"],
                "old": old + args + ([] if a.old_bkflow else ["--path", "general"])}
        m = medians(alternated({k: lambda _, k=k, cmd=cmd: timed_process(
            cmd + ["--out", work / k], timeout=7200) for k, cmd in cmds.items()}, a.rounds))
        atom_steps = spec.N * spec.n_steps
        rows.append(f"| {spec.N} | {spec.n_steps} | {m['new']:.2f} | {m['old']:.2f} | "
                    f"{m['new'] * 1e9 / atom_steps:.1f} | {m['old'] * 1e9 / atom_steps:.1f} | "
                    f"{m['old'] / m['new']:.2f} |")
        print(rows[-1], flush=True)
    print(f"\nwhole process, `bkflow run --scene friction --no-analyze` (phi = 100, C = 0.1, "
          f"t_end = {a.t_end:g}), wall s, median of {a.rounds} alternated rounds\n")
    print("| N | steps | new s | old s | new ns/atom-step | old ns/atom-step | old / new |")
    print("|---|---|---|---|---|---|---|")
    print("\n".join(rows))


#: ``--scaling``: (path, ranks) of each code, side by side
SCALING = {"fused, 1 rank": ("auto", 1), "fused, 2 ranks": ("auto", 2),
           "general, 2 ranks": ("general", 2)}
HALO = re.compile(r"(\d+) halo exchanges of (\d+) bytes .*? ([\d.e+-]+) to ([\d.e+-]+) us each")


def scaling(a) -> None:
    """atom-steps/s against N: one fused rank, two fused ranks, two general ranks, with the
    two-rank runs' halo exchange time (the fix's log line), for
    benchmarks/report/scaling_model.py (its last line is that module's MEASURED)."""
    work = Path(tempfile.mkdtemp(prefix="bkscaling"))
    rows, fits = [], []
    for size in a.sizes:
        spec = spec_for(size, a.t_end, a.atom_steps)
        (work / DATA).write_text(data_text(spec))
        rates = {k: [] for k in SCALING}
        halo = []
        for _ in range(a.rounds):
            for k, (path, ranks) in SCALING.items():
                deck = setup_text(spec, DeckOptions(data=DATA, stress=STRESS, path=path)) + \
                    f"\nrun             {spec.n_steps}\n"
                cutoff = NEW_CUTOFF if ranks == 1 else spec.bond_limit + 1.0
                wall, _, steps, atoms, log = loop_time(deck, work, ranks, cutoff)
                want = k.split(",")[0]
                got = "fused" if "bk/substrate fused:" in log else "general"
                if got != want:
                    raise SystemExit(f"{k}: the deck ran the {got} path")
                rates[k].append(steps * atoms / wall)
                if want == "fused" and ranks > 1:
                    n, nbytes, fast, slow = HALO.findall(log)[-1]
                    halo.append(float(slow) * 1e-6 * int(n) / steps)
        m = medians(rates)
        h = float(np.median(halo))
        t2 = spec.N / m["fused, 2 ranks"]
        cells = " | ".join(f"{m[k]:.3e}" for k in SCALING)
        rows.append(f"| {spec.Lx}x{spec.Ly} | {spec.N} | {spec.n_steps} | {cells} | "
                    f"{m['fused, 2 ranks'] / m['fused, 1 rank']:.2f} | "
                    f"{m['general, 2 ranks'] / m['fused, 1 rank']:.2f} | "
                    f"{h * 1e6:.2f} | {100 * h / t2:.0f}% |")
        fits.append((spec.Lx, spec.N, spec.N / m["fused, 1 rank"], t2, h))
        print(rows[-1], flush=True)
    print(f"\natom-steps/s (LAMMPS Loop time), median of {a.rounds} alternated rounds, phi = 100, "
          "C = 0.1, scene friction; halo: the two fused ranks' exchange time per step (the "
          "slower rank's, waits included) and its share of the step\n")
    print("| lattice | N | steps | " + " | ".join(SCALING)
          + " | fused 2 / fused 1 | general 2 / fused 1 | halo us/step | halo share |")
    print("|---|---|---|" + "---|" * (len(SCALING) + 4))
    print("\n".join(rows))
    print("\n# (Lx, N, t_1 s/step, t_2 s/step, halo s/step), for "
          "benchmarks/report/scaling_model.py")
    print("MEASURED = " + repr([tuple(float(f"{v:.6g}") for v in r) for r in fits]))


# ------------------------------------------------------------------- earlier comparisons
def deck_rates(decks_: dict, steps: int, repeats: int, work: Path) -> dict:
    """Median atom-steps/s of each deck (one rank), the decks run in turn ``repeats`` times."""
    def rate(deck: str) -> float:
        wall, _, n, atoms, _ = loop_time(deck + f"\nrun {steps}\n", work)
        return n * atoms / wall

    return medians(alternated({k: lambda _, deck=deck: rate(deck)
                               for k, deck in decks_.items()}, repeats))


def _write_data(work: Path, spec: RunSpec) -> str:
    folder = work / f"{spec.Lx}x{spec.Ly}_phi{spec.phi:g}"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / DATA).write_text(data_text(spec))
    return str(folder / DATA)


def compare_output(a) -> None:
    """The stress series' cost: none, fix bk/stress (buffered) and fix print (per line)."""
    from bkflow.lammps.deck import SUBSTRATE_FIX

    work = Path(tempfile.mkdtemp())
    print("| N | no output | fix bk/stress | fix print | bk/stress cost | fix print cost |")
    print("|---|---|---|---|---|---|")
    for size in a.sizes:
        lx, ly = parse_size(size)
        spec = RunSpec(phi=10.0, Lx=lx, Ly=ly, scene="series")   # the raw stress series
        data = _write_data(work, spec)
        steps = max(200, int((a.atom_steps or 2e7) / spec.N))
        stress = str(work / STRESS)
        old = (f'fix stressp all print {spec.stress_nevery} "$(time:%.10g),'
               f'$(f_{SUBSTRATE_FIX}[1]:%.17g)" file {stress} screen no title "t,sigma_x"\n')
        base = setup_text(spec, DeckOptions(data=data, stress=None, blocks=None, psi=None,
                                            thermo_every=10**7))
        m = deck_rates({"none": base,
                        "bk/stress": setup_text(spec, DeckOptions(data=data, stress=stress,
                                                                  thermo_every=10**7)),
                        "print": base + "\n" + old}, steps, a.rounds, work)
        print(f"| {spec.N} | {m['none']:.3e} | {m['bk/stress']:.3e} | {m['print']:.3e} | "
              f"{m['none'] / m['bk/stress']:.3f} | {m['none'] / m['print']:.3f} |", flush=True)


def compare_schemes(a) -> None:
    """Cost of the second-order time stepping: the same deck with each scheme, alternating."""
    work = Path(tempfile.mkdtemp())
    print("| N | phi | reset + implicit | reset/step + half | new / old |")
    print("|---|---|---|---|---|")
    for size in a.sizes:
        lx, ly = parse_size(size)
        for phi in (0.1, 10.0, 1000.0):
            new = RunSpec(phi=phi, Lx=lx, Ly=ly)
            old = new.replace(contact_rule="reset/step", damping="half")
            data = _write_data(work, new)
            steps = max(200, int((a.atom_steps or 2e7) / new.N))
            quiet = DeckOptions(data=data, stress=None, blocks=None, psi=None,
                                thermo_every=10**7)
            m = deck_rates({"new": setup_text(new, quiet), "old": setup_text(old, quiet)},
                            steps, a.rounds, work)
            print(f"| {new.N} | {phi:g} | {m['new']:.3e} | {m['old']:.3e} | "
                  f"{m['new'] / m['old']:.3f} |", flush=True)


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("--sizes", nargs="+", default=None,
                    help="lattices LXxLY (default 20x5 60x15 120x30 240x60; --whole 20x5 60x15; "
                         "--scaling 60x15 120x30 240x60 480x120 960x240)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--t-end", type=float, default=1000.0)
    ap.add_argument("--atom-steps", type=float, default=4e8,
                    help="cap on the atom-steps of one timed run (large N run fewer steps)")
    ap.add_argument("--no-check", action="store_true", help="skip the floor kernel's check")
    ap.add_argument("--whole", action="store_true", help="the whole bkflow run process")
    ap.add_argument("--old-bkflow", default=None,
                    help="--whole: the bkflow command of an older engine (a git-tag build)")
    ap.add_argument("--new-bkflow", default=None,
                    help="--whole: the bkflow command to measure (default: this one); "
                         "give a regular install (pip install .) to compare like with like")
    ap.add_argument("--scaling", action="store_true")
    ap.add_argument("--compare-output", action="store_true")
    ap.add_argument("--compare-schemes", action="store_true")
    a = ap.parse_args(argv)
    if a.sizes is None:
        a.sizes = (["20x5", "60x15"] if a.whole else
                   ["60x15", "120x30", "240x60", "480x120", "960x240"] if a.scaling else
                   ["20x5", "60x15", "120x30", "240x60"])
    if a.whole:
        return whole(a)
    if a.scaling:
        return scaling(a)
    if a.compare_output:
        return compare_output(a)
    if a.compare_schemes:
        return compare_schemes(a)
    return codes_table(a)


if __name__ == "__main__":
    main()
