"""The reproduction's sweeps: each protocol's runs (``protocols``, the directory OUT/<name>
each goes into), the curves its figures and tables compare, read from the sweeps' tables
(``curves``). The share of their slip clusters in a regime is claims_record.cluster_share."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from bkflow.model.params import PAPER_SIZES, RunSpec
from bkflow.model.protocols import protocol_fields
from bkflow.store.tables import read_tables
from bkflow.sweeps.grid import phi_values, sweep_specs

PHI = "1e-1:1e3"
#: the aspect-ratio check: N = 100 as the paper, and N = 400 with every side even (an odd
#: side's whole-box extent is shorter, so claim 5 is also decided where parity plays no part)
ASPECT_SIZES = [(20, 5), (10, 10), (5, 20), (40, 10), (20, 20), (10, 40)]
#: the paper's protocol: the synchronized start run for a finite length, at three lengths
PAPER_LENGTHS = (1000.0, 4000.0, 16000.0)
#: the paper's literal integrator (docs/model.md "Integration"): the damping with the half-step
#: velocity and a broken contact re-formed at the step's end, first order in dt; run under the
#: paper's protocol at its longest length, at the same time step as the other curves, so that
#: the two schemes differ only in their step's bias
FIRST_ORDER = {"damping": "half", "contact_rule": "reset/step"}
#: the steady protocol as the main command runs it (bkflow sweep's default cap: the stiff
#: layers' pairs that have not agreed by then end metastable, with the bracket of their two
#: starts); at N = 100 these are the very runs of the README's `bkflow sweep --phi 1e-1:1e3`
STEADY_CAP = protocol_fields("steady")["t_end"]
#: beyond the paper: N = 3600 in the steady state, one phi per decade, a shorter cap
LARGE_SIZE, LARGE_PHI, LARGE_CAP = (120, 30), "1e-1,1,10,100,1e3", 16000.0
#: the synchronized start beside its companion until steady, on a few points: does the
#: paper's start reach the same steady state?
SYNC_STEADY_PHI, SYNC_STEADY_CAP = "10,100,1e3", 64000.0


def protocols(seeds: int, dt_factor: float,
              sizes=(100, 400, 900)) -> dict[str, list[RunSpec]]:
    """Every sweep of the reproduction: name -> its RunSpecs (the directory OUT/name);
    ``sizes``: the N of the paper's grid to run (paper and steady protocols)."""
    grid_sizes = [PAPER_SIZES[n] for n in sizes]
    grid = phi_values(PHI)
    paper = protocol_fields("paper", dt_factor=dt_factor)
    steady = protocol_fields("steady", dt_factor=dt_factor)
    return {
        "paper": [s for t_end in PAPER_LENGTHS for s in
                  sweep_specs(grid, grid_sizes, seeds, **{**paper, "t_end": t_end})],
        "paper_first_order": sweep_specs(grid, grid_sizes, seeds,
                                         **{**paper, "t_end": PAPER_LENGTHS[-1], **FIRST_ORDER}),
        "steady": sweep_specs(grid, grid_sizes, seeds, **{**steady, "t_end": STEADY_CAP}),
        "steady_3600": sweep_specs(phi_values(LARGE_PHI), [LARGE_SIZE], min(seeds, 2),
                                   **{**steady, "t_end": LARGE_CAP}),
        "sync_steady": sweep_specs(phi_values(SYNC_STEADY_PHI), [PAPER_SIZES[100]], seeds,
                                   **{**steady, "start": "synchronized",
                                      "t_end": SYNC_STEADY_CAP}),
        "aspect": sweep_specs(grid, ASPECT_SIZES, seeds, **paper),
    }


#: the curves compared in the figures and tables: label -> (protocol directory, selection)
CURVES = {
    "paper, t_end = 1000": ("paper", {"t_end": 1000.0}),
    "paper, t_end = 4000": ("paper", {"t_end": 4000.0}),
    "paper, t_end = 16000": ("paper", {"t_end": 16000.0}),
    "paper, first-order scheme, t_end = 16000": ("paper_first_order", {}),
    "steady protocol": ("steady", {}),
    "steady protocol, N = 3600": ("steady_3600", {}),
    "synchronized start until steady": ("sync_steady", {}),
}
#: (field, its name in numbers.md, its axis label in the figures)
OBSERVABLES = (("mu_bar", "mu_bar (slips above 1% of mu_s sigma_n)",
                "$\\overline{\\mu}$, slips above\n1% of $\\mu_s\\sigma_n$"),
               ("mu_bar_large", "mu_bar (large drops: drop > mean drop)",
                "$\\overline{\\mu}$, large drops:\ndrop > mean drop"),
               ("mean_stress_ratio", "<sigma_x>/sigma_n", r"$\langle\sigma_x\rangle/\sigma_n$"))


def sweep_tables(out: Path, name: str, where: dict | None = None):
    """(runs, results) of a protocol's sweep, restricted to ``where``; None when not run."""
    try:
        runs, res = read_tables(out / name)
    except (FileNotFoundError, pd.errors.EmptyDataError):
        return None
    for k, v in (where or {}).items():
        runs, res = runs[np.isclose(runs[k], v)], res[np.isclose(res[k], v)]
    return (runs, res) if len(runs) else None


def curves(out: Path) -> dict:
    """label -> (runs, results) of every curve that has been run."""
    found = {}
    for label, (name, where) in CURVES.items():
        t = sweep_tables(out, name, where)
        if t is not None:
            found[label] = t
    return found

