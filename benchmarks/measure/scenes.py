"""What each scene costs and what the analysis finds, on real runs.

For every phi and lattice asked for, runs the four scenes (friction, order, clusters, full)
back to back with the same seed, so the trajectories are identical and only the outputs
differ, and prints two markdown tables: wall time and bytes written per scene (with the wall
time relative to the friction scene of the same phi, measured in the same run), and the
summary numbers of the full scene (bkflow analyze).

    python -m benchmarks.measure.scenes [--phi 1 30 1000] [--sizes 20x5] [--t-end T] [--dt-factor C]
        [--seed 1]

Runs use the default accuracy preset (RunSpec's t_end and dt_factor) unless --t-end and
--dt-factor say otherwise.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from bkflow.analysis.summary import analyze
from bkflow.cli.assignments import parse_size
from bkflow.lammps.engine import run
from bkflow.model.params import SCENES, RunSpec
from bkflow.store.rundir import DATA, DECK, LOG, STRESS


def _mb(b):
    return f"{b / 1e6:.2f} MB"


def _fmt(v, f):
    return "n/a" if v is None else format(v, f)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("--phi", type=float, nargs="+", default=[1.0, 30.0, 1000.0])
    ap.add_argument("--sizes", nargs="+", default=["20x5"])
    ap.add_argument("--t-end", type=float, default=RunSpec.t_end,
                    help="run length (default: the default accuracy preset's)")
    ap.add_argument("--dt-factor", type=float, default=RunSpec.dt_factor,
                    help="C in dt = C / sqrt(...) (default: the default accuracy preset's)")
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args(argv)

    cost_rows, summary_rows = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for size in a.sizes:
            Lx, Ly = parse_size(size)
            for phi in a.phi:
                walls = {}
                for scene in SCENES:
                    spec = RunSpec(phi=phi, Lx=Lx, Ly=Ly, seed=a.seed, t_end=a.t_end,
                                   dt_factor=a.dt_factor, scene=scene)
                    out = Path(tmp) / f"{size}_{phi:g}_{scene}"
                    res = run(spec, out, progress=False)
                    t0 = time.perf_counter()
                    s = analyze(out)
                    t_an = time.perf_counter() - t0
                    walls[scene] = res.meta["wall_time_s"]
                    # what the scene's per-atom outputs add to what every run writes
                    per_atom = res.meta["bytes_written"] - sum(
                        res.meta["file_bytes"].get(f, 0) for f in (DECK, DATA, LOG, STRESS))
                    cost_rows.append(
                        f"| {size} | {phi:g} | {scene} | {res.meta['wall_time_s']:.2f} s | "
                        f"{walls[scene] / walls['friction']:.3f} | "
                        f"{_mb(res.meta['bytes_written'])} | {_mb(per_atom)} | {t_an:.2f} s |")
                    print(cost_rows[-1], flush=True)
                    if scene == "full":
                        by = ", ".join(f"{k}: {_fmt(v, '.4f')}"
                                       for k, v in s["mu_bar_by_threshold"].items())
                        summary_rows.append(
                            f"| {size} | {phi:g} | {_fmt(s['mu_bar'], '.4f')} +- "
                            f"{_fmt(s['mu_bar_err'], '.4f')} | {s['n_slips']} | "
                            f"{_fmt(s['mean_stress_ratio'], '.4f')} | {by} | "
                            f"{_fmt(s['psi_inf'], '.3f')} | {_fmt(s['lx_mean_over_Lx'], '.3f')} | "
                            f"{_fmt(s['ly_mean_over_Ly'], '.3f')} | "
                         f"{_fmt(s['lx_over_ly'], '.2f')} | "
                            f"{s['regime']} | {_fmt(s['drop_exponent'], '.2f')} +- "
                            f"{_fmt(s['drop_exponent_err'], '.2f')} (x_min "
                            f"{_fmt(s['drop_x_min'], '.3g')}, {s['drop_n_tail']}) |")
    print("\n| lattice | phi | scene | wall (run) | wall / friction | bytes written | "
          "of which per-atom | analyze |")
    print("|---|---|---|---|---|---|---|---|")
    print("\n".join(cost_rows))
    print("\n| lattice | phi | mu_bar | slips | <sigma_x>/sigma_n | mu_bar by threshold | "
          "Psi(inf) | <l_x/Lx> | <l_y/Ly> | <l_x>/<l_y> | regime | drop exponent |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    print("\n".join(summary_rows))


if __name__ == "__main__":
    main()
