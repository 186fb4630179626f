"""File formats at the edge of bkflow: LAMMPS dumps, CSV tables and JSON, read and written.

Which file of a run directory holds what is :mod:`bkflow.rundir`'s business; this module only
knows formats. Dumps are read with MDAnalysis's LAMMPS dump reader, unwrapped with the image
flags; tables with pandas (both imported only when used, so that the engine does not pay for
them). MDAnalysis holds coordinates in single precision, so positions come back to about 1e-7
relative (1e-5 l at the 80 l a run drifts by t = 4000): far below S_x = 0.01 l and the Psi
resolution that matters.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: one float format for every table bkflow writes: full double precision
FLOAT_FORMAT = "%.17g"

_UMASK = os.umask(0)
os.umask(_UMASK)


@dataclass(frozen=True)
class Frames:
    """Frames of a dump: steps (F,) and unwrapped positions (F, N, 2) ordered by atom id."""

    steps: np.ndarray
    positions: np.ndarray

    def __len__(self) -> int:
        return len(self.steps)


def read_columns(path, columns) -> dict[str, np.ndarray]:
    """The named float columns of a CSV file (pandas); a clear ValueError when one is absent."""
    import pandas as pd

    df = pd.read_csv(path)
    missing = set(columns) - set(df.columns)
    if missing:
        raise ValueError(f"{path}: no column(s) {', '.join(sorted(missing))}")
    return {c: df[c].to_numpy(dtype=float) for c in columns}


def read_table(path):
    """A CSV table as a pandas DataFrame."""
    import pandas as pd

    return pd.read_csv(path)


def read_frames(path, n_atoms: int | None = None) -> Frames:
    """All frames of a LAMMPS text dump with columns id x y (z) ix iy (iz), unwrapped.

    An empty file (a scene that recorded no event) gives zero frames of ``n_atoms`` atoms.
    """
    import MDAnalysis as mda

    path = Path(path)
    if path.stat().st_size == 0:
        return Frames(np.empty(0, dtype=np.int64), np.empty((0, n_atoms or 0, 2)))
    with warnings.catch_warnings():
        # masses guessed from a dump, and time units: irrelevant here (steps are used)
        warnings.simplefilter("ignore")
        u = mda.Universe(str(path), topology_format="LAMMPSDUMP", format="LAMMPSDUMP",
                         unwrap_images=True, dt=1.0)
        if n_atoms is not None and u.atoms.n_atoms != n_atoms:
            raise ValueError(f"{path}: {u.atoms.n_atoms} atoms, expected {n_atoms}")
        steps = np.empty(len(u.trajectory), dtype=np.int64)
        pos = np.empty((len(u.trajectory), u.atoms.n_atoms, 2))
        for k, ts in enumerate(u.trajectory):
            steps[k] = ts.data["step"]
            pos[k] = ts.positions[:, :2]
    return Frames(steps, pos)


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


def _replace_atomically(path: Path, write) -> None:
    """Write through a uniquely named temporary file beside ``path``, flushed to disk, then
    renamed over it: a reader sees the old file or the whole new one, never half."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.fchmod(fd, 0o666 & ~_UMASK)  # mkstemp makes 0600: readable as any file the user writes
    try:
        with os.fdopen(fd, "w", newline="") as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        _unlink_quietly(tmp)
        raise


def _unlink_quietly(path) -> None:
    try:
        os.unlink(path)
    except OSError:
        pass


def write_json_atomic(path, obj) -> None:
    """Write JSON (NaN as null) atomically."""
    text = json.dumps(json_ready(obj), indent=2, sort_keys=True, allow_nan=False) + "\n"
    _replace_atomically(Path(path), lambda f: f.write(text))


def write_table(path, table) -> None:
    """Write a CSV of named columns (a dict of arrays or a DataFrame) atomically, floats in
    :data:`FLOAT_FORMAT`."""
    import pandas as pd

    df = table if isinstance(table, pd.DataFrame) else pd.DataFrame(table)
    _replace_atomically(Path(path),
                        lambda f: df.to_csv(f, index=False, float_format=FLOAT_FORMAT))
