"""Reproduce the paper's claims with one command, under its protocol and in the steady state.

    python workflows/paper/reproduce.py [--out runs/paper] [--jobs J] [--seeds 3]
        [--protocols paper,steady,steady_3600,sync_steady,aspect] [--figures DIR]
        [--numbers FILE]

Every sweep uses the default time step (the default accuracy preset's) and the default scene,
seeds 1..3, 13 phi from 1e-1 to 1e3 (3 per decade) unless said otherwise; each goes into OUT/<name>:

paper        the paper's protocol (bkflow run --protocol paper): the synchronized start
             (every contact formed at t = 0) run for a finite length, t_end = 1000, 4000 and
             16000, at N = 100, 400, 900 (20x5, 40x10, 60x15): how the curves move with run
             length, and which of their points are metastable.
steady       the steady protocol (bkflow run, the default): each run from the random start
             beside its companion from the partial start, until both are steady and agree
             within 0.5%, capped at the default preset's cap (the main command's), at N = 100,
             400, 900 (--sizes: which of them; at N = 100 the README's sweep).
steady_3600  the same at N = 3600 (120x30), beyond the paper, one phi per decade, 2 seeds,
             capped at 16000.
sync_steady  the synchronized start beside its partial companion until steady (cap 64000) at
             N = 100, phi = 10, 100, 1000: does the paper's start reach the same steady state?
aspect       the aspect-ratio check ("with Lx <= Ly the DT regime does not appear"): N = 100
             on 20x5, 10x10 and 5x20, and N = 400 on 40x10, 20x20 and 10x40 (every side
             even), the paper's protocol, t_end = 8000.

Then the figures (``bkflow plot`` of each protocol, and the comparisons below) as PNG into
workflows/paper/figures/, and workflows/paper/numbers.md: every number REPRODUCTION.md cites,
computed from the sweeps' tables. Finished runs are never redone: re-running resumes, and a
changed analysis re-analyses without running LAMMPS.

Beside this script, one module for each part: paper_sweeps.py (the sweeps, and the curves read
from their tables), paper_numbers.py (numbers.md's tables), paper_figures.py (the figures of
the curves), aspect_check.py (claim 5's tables and figures), energy_argument.py (claim 6's),
claims_record.py (the claims' statistics: the record claims.json) and claims.py (the claims'
tests, and their verdicts and tables rendered from that record).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from bkflow.figures.writer import plot
from bkflow.model.params import RunSpec
from bkflow.store import files
from bkflow.sweeps.local import available_cores, fmt_duration, sweep

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
# the modules beside this script (workflows/paper/), each of one part of the reproduction
from aspect_check import aspect_figures  # noqa: E402
from claims import render_all  # noqa: E402
from claims_record import record  # noqa: E402
from energy_argument import energy_argument, energy_figure  # noqa: E402
from paper_figures import protocols_figure, relaxation_figure, sizes_figure  # noqa: E402
from paper_numbers import numbers  # noqa: E402
from paper_sweeps import ASPECT_SIZES, CURVES, curves, protocols, sweep_tables  # noqa: E402


def run_sweep(name, specs, jobs, out):
    print(f"{name}: {len(specs)} runs into {out}", flush=True)
    rep = sweep(specs, out, jobs=jobs)
    print(f"{name}: {len(rep.finished)} run(s) in {fmt_duration(rep.wall_time_s)}, "
          f"{rep.finished_before} finished earlier, {len(rep.failed)} failed", flush=True)
    for job, msg in rep.failed.items():
        print(f"  failed {job}: {msg}", file=sys.stderr)
    return rep


def figures(out: Path, figs: Path) -> list[Path]:
    """Every figure of the reproduction from the sweeps under ``out`` into ``figs``: ``bkflow
    plot`` of each curve that has been run, and the comparisons of its own modules."""
    written = []
    for label, (name, where) in CURVES.items():
        if sweep_tables(out, name, where) is None:
            continue
        sub = figs / label.split(" (")[0].replace(", ", "_").replace(" = ", "").replace(" ", "_")
        paths, _ = plot(out / name, sub, formats=("png",), where=where)
        written += paths
    for make in (protocols_figure, relaxation_figure, sizes_figure):
        path = make(out, figs)
        if path is not None:
            written.append(path)
    if sweep_tables(out, "aspect") is not None:
        written += aspect_figures(out / "aspect", figs)
    path = energy_figure(energy_argument(out), figs)
    if path is not None:
        written.append(path)
    return written


def claim_record(out: Path, prov: dict | None = None) -> dict:
    """The claims' record (claims_record.py) of the sweeps under ``out``; ``prov``: the provenance
    taken before this script wrote anything (its own figures and records would make the tree
    dirty), else now."""
    from bkflow.store.provenance import record as provenance

    cs = curves(out)
    aspect = sweep_tables(out, "aspect")
    return record(cs, {label: out / CURVES[label][0] for label in cs},
                  (aspect[0], out / "aspect") if aspect is not None else None,
                  ASPECT_SIZES, prov if prov is not None else provenance())


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("--out", default="runs/paper", help="where the runs go (default runs/paper)")
    p.add_argument("--jobs", type=int, default=available_cores())
    p.add_argument("--seeds", type=int, default=10,
                   help="seeds per point (default 10, the seeds the claims are decided on)")
    p.add_argument("--dt-factor", type=float, default=RunSpec.dt_factor)
    p.add_argument("--sizes", default="100,400,900",
                   help="the N of the paper's grid to run, of 100, 400, 900 (default: all)")
    p.add_argument("--protocols", default=",".join(protocols(1, RunSpec.dt_factor)),
                   help="which sweeps to run (default: all)")
    p.add_argument("--figures", default=str(HERE / "figures"))
    p.add_argument("--numbers", default=str(HERE / "numbers.md"),
                   help="where the numbers REPRODUCTION.md cites go (default: beside it)")
    p.add_argument("--claims", default=str(HERE / "claims.json"),
                   help="the record of the claims' tests, which REPRODUCTION.md's generated "
                        "blocks show (default: beside it)")
    a = p.parse_args(argv)
    from bkflow.store.provenance import record as provenance

    prov = provenance()   # the tree as it was asked to run: before this writes its outputs
    out, figs = Path(a.out), Path(a.figures)
    figs.mkdir(parents=True, exist_ok=True)
    try:
        sizes = tuple(int(n) for n in a.sizes.split(","))
    except ValueError:
        p.error(f"--sizes {a.sizes}: give N values, e.g. 100,400")
    if not set(sizes) <= {100, 400, 900}:
        p.error(f"--sizes {a.sizes}: the paper's grid has N = 100, 400, 900")
    every = protocols(a.seeds, a.dt_factor, sizes)
    chosen = [n.strip() for n in a.protocols.split(",") if n.strip()]
    unknown = set(chosen) - set(every)
    if unknown:
        p.error(f"unknown protocol(s) {', '.join(sorted(unknown))}; choose from "
                f"{', '.join(every)}")
    wall, failed = {}, False
    for name in chosen:
        t0 = time.perf_counter()
        rep = run_sweep(name, every[name], a.jobs, out / name)
        if rep.finished:  # what this invocation ran or re-analysed, and how long it took
            wall[name] = (fmt_duration(time.perf_counter() - t0)
                          + f" ({len(rep.finished)} runs run or re-analysed)")
        failed |= bool(rep.failed)
    written = figures(out, figs)
    for pth in written:
        print(f"wrote {pth}")
    # the record as the documents read it back (JSON's order and types), rendered from that
    rec = json.loads(json.dumps(claim_record(out, prov)))
    with files.atomic_file(Path(a.claims)) as f:
        f.write(json.dumps(rec, indent=1) + "\n")
    print(f"wrote {a.claims}")
    Path(a.numbers).write_text(numbers(out, wall) + "\n" + render_all(rec))
    print(f"wrote {a.numbers}")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
