"""Do two sweeps of the same grid agree? Stress series run by run, and the tables.

Made to check one engine path against another on real runs (``--path auto``, the fused path,
against ``--path general``), not only on the short lively starts of the tests: the same state
points (signac job ids) in both sweep directories are paired, and for each pair it prints the
largest difference of sigma_x over the whole series (the raw series: sweeps of scene
``series`` or ``full``), relative to the series' largest |sigma_x|; then, over results.csv,
the largest relative difference of mu_bar and of <sigma_x>/sigma_n and the largest
|difference| / combined standard error.

    python -m benchmarks.checks.paths_agree SWEEP_A SWEEP_B
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from benchmarks.harness import parser
from bkflow.store.rundir import RunDir


def series_rows(wa: Path, wb: Path, common: list[str]) -> list[tuple]:
    """Per job in both workspaces: (phi, lattice, seed, samples, largest relative difference
    of sigma_x, path A, path B)."""
    rows = []
    for job in common:
        (ta, sa), (tb, sb) = (RunDir(w / job).read_stress() for w in (wa, wb))
        sp = json.loads((wa / job / "signac_statepoint.json").read_text())
        paths = [json.loads((w / job / "meta.json").read_text()).get("engine", {}).get(
            "path", "general (before the engine record)") for w in (wa, wb)]
        same_t = ta.shape == tb.shape and np.array_equal(ta, tb)
        rel = (np.abs(sa - sb).max() / np.abs(sa).max()) if same_t else np.nan
        rows.append((sp["phi"], f"{sp['Lx']}x{sp['Ly']}", sp["seed"], len(sa), rel, *paths))
    return rows


def main(argv=None) -> None:
    ap = parser(__doc__)
    ap.add_argument("a")
    ap.add_argument("b")
    a = ap.parse_args(argv)
    wa, wb = Path(a.a) / "workspace", Path(a.b) / "workspace"
    common = sorted({p.name for p in wa.iterdir()} & {p.name for p in wb.iterdir()})
    if not common:
        raise SystemExit("no state point in common")
    rows = series_rows(wa, wb, common)
    print("| phi | lattice | seed | samples | max rel diff of sigma_x | path A | path B |")
    print("|---|---|---|---|---|---|---|")
    for r in sorted(rows):
        print(f"| {r[0]:g} | {r[1]} | {r[2]} | {r[3]} | {r[4]:.1e} | {r[5]} | {r[6]} |")
    worst = max(r[4] for r in rows)
    print(f"\n{len(rows)} runs in common; largest relative difference of a stress series: "
          f"{worst:.1e}")
    ra, rb = (pd.read_csv(Path(d) / "results.csv") for d in (a.a, a.b))
    m = ra.merge(rb, on=["phi", "Lx", "Ly"], suffixes=("_a", "_b"))
    for col in ("mu_bar", "mean_stress_ratio"):
        rel = np.abs(m[f"{col}_b"] / m[f"{col}_a"] - 1).max()
        z = (np.abs(m[f"{col}_b"] - m[f"{col}_a"])
             / np.hypot(m[f"{col}_sem_a"], m[f"{col}_sem_b"])).max()
        print(f"results.csv, {len(m)} rows: {col} largest relative difference {rel:.1e}, "
              f"largest |difference| / combined error {z:.1e}")


if __name__ == "__main__":
    main()
