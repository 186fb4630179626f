"""Readers and writers at the edge of the analysis: every file access of bkflow.analysis.

Dumps (``snapshots.lammpstrj``, ``slips.lammpstrj``) are read with MDAnalysis's LAMMPS dump
reader, unwrapped with the image flags; the stress series with pandas. MDAnalysis holds
coordinates in single precision, so positions come back to about 1e-7 relative (1e-5 l at
the 80 l a run drifts by t = 4000): far below S_x = 0.01 l and the Psi resolution that
matters.
"""

from __future__ import annotations

import json
import math
import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd


@dataclass(frozen=True)
class Frames:
    """Frames of a dump: steps (F,), unwrapped positions (F, N, 2) ordered by atom id, box."""

    steps: np.ndarray
    positions: np.ndarray
    box: tuple[float, float]

    def __len__(self) -> int:
        return len(self.steps)


def read_stress(path) -> tuple[np.ndarray, np.ndarray]:
    """The stress series ``stress.csv``: (t, sigma_x) as float arrays."""
    df = pd.read_csv(path)
    missing = {"t", "sigma_x"} - set(df.columns)
    if missing:
        raise ValueError(f"{path}: no column(s) {', '.join(sorted(missing))}; is it a bkflow "
                         "stress.csv?")
    return df["t"].to_numpy(dtype=float), df["sigma_x"].to_numpy(dtype=float)


def read_frames(path, n_atoms: int | None = None) -> Frames:
    """All frames of a LAMMPS text dump with columns id x y (z) ix iy (iz), unwrapped.

    An empty file (a scene that recorded no event) gives zero frames of ``n_atoms`` atoms.
    """
    import MDAnalysis as mda

    path = Path(path)
    if path.stat().st_size == 0:
        n = n_atoms or 0
        return Frames(np.empty(0, dtype=np.int64), np.empty((0, n, 2)), (math.nan, math.nan))
    with warnings.catch_warnings():
        # masses guessed from a dump, and time units: irrelevant here (steps are used)
        warnings.simplefilter("ignore")
        u = mda.Universe(str(path), topology_format="LAMMPSDUMP", format="LAMMPSDUMP",
                         unwrap_images=True, dt=1.0)
        if n_atoms is not None and u.atoms.n_atoms != n_atoms:
            raise ValueError(f"{path}: {u.atoms.n_atoms} atoms, expected {n_atoms}")
        steps = np.empty(len(u.trajectory), dtype=np.int64)
        pos = np.empty((len(u.trajectory), u.atoms.n_atoms, 2))
        box = (math.nan, math.nan)
        for k, ts in enumerate(u.trajectory):
            steps[k] = ts.data["step"]
            pos[k] = ts.positions[:, :2]
            box = (float(ts.dimensions[0]), float(ts.dimensions[1]))
    return Frames(steps, pos, box)


def read_json(path) -> dict:
    return json.loads(Path(path).read_text())


def json_ready(obj):
    """NaN and inf become null: JSON has no such numbers and readers choke on them."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {str(k): json_ready(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_ready(v) for v in obj]
    if isinstance(obj, np.generic):
        return json_ready(obj.item())
    return obj


def write_json_atomic(path, obj) -> None:
    """Write JSON through a temporary file and a rename, so a reader never sees half of it."""
    path = Path(path)
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(json_ready(obj), indent=2, sort_keys=True, allow_nan=False) + "\n")
    os.replace(tmp, path)


def write_table(path, columns: dict) -> None:
    """Write a CSV of named columns (full double precision), atomically."""
    path = Path(path)
    tmp = path.with_suffix(path.suffix + ".tmp")
    pd.DataFrame(columns).to_csv(tmp, index=False, float_format="%.17g")
    os.replace(tmp, path)
