"""File formats at the edge of bkflow: LAMMPS dumps, CSV tables and JSON, read and written.

Which file of a run directory holds what is ``bkflow.store.layout``'s business, and how a
file is touched safely (regular files only, inside the directory bkflow was given, written
atomically) ``bkflow.store.files``'s; this module only knows formats. Tables are read and
written with pandas; LAMMPS dumps are read by ``read_regular_frames``, a vectorised reader of
the regular dumps bkflow writes (for speed: MDAnalysis's reader, used for any other dump,
parses line by line, and reading a full-scene run's dumps with it costs as much as running
the run; the two are checked against each other in tests/lammps/test_scenes.py), unwrapped
with the image flags. Positions come back to the 9 significant digits the dumps are written
with (1e-7 l at the 200 l a layer drifts by
t = 8000), far below S_x = 0.01 l and the Psi resolution that matters.
"""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bkflow.store.files import atomic_file, regular


def float_text(x) -> str:
    """A float as every table bkflow writes it: the shortest text that reads back as the same
    double (Python's repr: 0.1, where ``%.17g`` writes 0.10000000000000001)."""
    return repr(float(x))


#: one float format for every table bkflow writes (pandas' ``float_format``): ``float_text``
FLOAT_FORMAT = float_text


@dataclass(frozen=True)
class Frames:
    """Frames of a dump: steps (F,) and unwrapped positions (F, N, 2) ordered by atom id;
    ``breaks`` (F, N): the column ``brk`` of fix bk/slips ``breaks`` (each contact's first
    break in the slip), None without it."""

    steps: np.ndarray
    positions: np.ndarray
    breaks: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.steps)


def read_text(path, **kw) -> str:
    return regular(path).read_text(**kw)


def read_bytes(path) -> bytes:
    return regular(path).read_bytes()


def read_columns(path, columns) -> dict[str, np.ndarray]:
    """The named float columns of a CSV file (pandas); a clear ValueError when one is absent."""
    import pandas as pd

    df = pd.read_csv(regular(path))
    missing = set(columns) - set(df.columns)
    if missing:
        raise ValueError(f"{path}: no column(s) {', '.join(sorted(missing))}")
    return {c: df[c].to_numpy(dtype=float) for c in columns}


def read_table(path):
    """A CSV table as a pandas DataFrame, every float the very double that was written
    (``float_text``): pandas 3 parses floats exactly; before it, only its round-trip parser
    does (``float_precision``, an option pandas 3 deprecates)."""
    import pandas as pd

    exact = {} if int(pd.__version__.split(".")[0]) >= 3 else {"float_precision": "round_trip"}
    return pd.read_csv(regular(path), **exact)


def read_frames(path, n_atoms: int | None = None) -> Frames:
    """All frames of a LAMMPS text dump with columns id x y (z) ix iy (iz), unwrapped.

    An empty file (a scene that recorded no event) gives zero frames of ``n_atoms`` atoms.
    bkflow's own dumps (every frame the same atoms, the same columns) are read by
    ``read_regular_frames``; anything else, a cut file included, by MDAnalysis.
    """
    path = regular(path)
    if path.stat().st_size == 0:
        return Frames(np.empty(0, dtype=np.int64), np.empty((0, n_atoms or 0, 2)))
    frames = read_regular_frames(path)
    if frames is not None:
        if n_atoms is not None and frames.positions.shape[1] != n_atoms:
            raise ValueError(f"{path}: {frames.positions.shape[1]} atoms, expected {n_atoms}")
        return frames
    with open(path, "rb") as f:
        head = f.read(4096)
    if b" brk" in head:  # fix bk/slips breaks: only the regular reader reads that column
        raise ValueError(f"{path}: a frame or its column brk cannot be read")
    return read_frames_mdanalysis(path, n_atoms)


_HEAD = (b"ITEM: TIMESTEP", None, b"ITEM: NUMBER OF ATOMS", None, b"ITEM: BOX BOUNDS")


def read_regular_frames(path) -> Frames | None:
    """The frames of a LAMMPS text dump whose frames all have the same layout (the number of
    atoms and the column line of the first), read in one vectorised pass; None for any other
    file (it is then MDAnalysis's to read, or to refuse).

    Why not MDAnalysis here: its reader parses each line in Python, 18 ms per frame of 900
    atoms (reading a full-scene run's dumps so costs as much as running it); this reads the
    same frames ~50x faster, in double precision (MDAnalysis keeps single), and
    tests/lammps/test_scenes.py checks the two agree on every frame."""
    lines = read_bytes(path).split(b"\n")
    if lines and lines[-1] == b"":
        lines.pop()
    layout = _regular_layout(lines)
    if layout is None:
        return None
    n, cols = layout
    heads = _frame_heads(lines, n)
    if heads is None:
        return None
    steps, box = heads
    n_frames = len(steps)
    table = _atom_table(lines, n, cols, n_frames)
    if table is None:
        return None
    get = {c: table[c].to_numpy().reshape(n_frames, n) for c in ("id", "x", "y", "ix", "iy")}
    lengths = box[:, :, 1] - box[:, :, 0]  # (F, 2)
    pos = np.stack([get["x"] + get["ix"] * lengths[:, :1], get["y"] + get["iy"] * lengths[:, 1:]],
                   axis=-1)
    order = np.argsort(get["id"], axis=1, kind="stable")
    pos = np.take_along_axis(pos, order[:, :, None], axis=1)
    brk = None
    if "brk" in table:
        brk = np.take_along_axis(table["brk"].to_numpy().reshape(n_frames, n), order, axis=1)
    return Frames(steps, pos, brk)


def _regular_layout(lines: list[bytes]) -> tuple[int, list[bytes]] | None:
    """(atoms per frame, column names) of a dump's ``lines`` whose first frame has the header
    of bkflow's dumps (id, x, y, ix, iy among the columns) and that are whole frames of it;
    None otherwise."""
    if len(lines) < 9 or lines[0] != _HEAD[0] or lines[2] != _HEAD[2] \
            or not lines[4].startswith(_HEAD[4]) or not lines[8].startswith(b"ITEM: ATOMS "):
        return None
    try:
        n = int(lines[3])
    except ValueError:
        return None
    per = n + 9
    if n < 1 or len(lines) % per:
        return None
    cols = lines[8].split()[2:]
    if not {b"id", b"x", b"y", b"ix", b"iy"} <= set(cols):
        return None
    return n, cols


def _frame_heads(lines: list[bytes], n: int) -> tuple[np.ndarray, np.ndarray] | None:
    """The steps (F,) and the boxes' x and y bounds (F, 2, 2) of the frames of ``n`` atoms
    in ``lines``, when every frame's header is the first's but for its step and box; None
    otherwise."""
    per = n + 9
    n_frames = len(lines) // per
    head = [lines[k * per: k * per + 9] for k in range(n_frames)]
    if any(h[0] != lines[0] or h[2] != lines[2] or h[3] != lines[3] or h[4] != lines[4]
           or h[8] != lines[8] for h in head):
        return None
    try:
        steps = np.array([int(h[1]) for h in head], dtype=np.int64)
        box = np.array([[float(v) for v in h[5 + d].split()[:2]] for h in head
                        for d in (0, 1)]).reshape(n_frames, 2, 2)
    except ValueError:
        return None
    return steps, box


def _atom_table(lines: list[bytes], n: int, cols: list[bytes], n_frames: int):
    """The atom lines of every frame as one DataFrame of float columns ``cols`` (pandas' C
    parser), or None when one is missing or is not a number."""
    import pandas as pd

    per = n + 9
    body = b"\n".join(b"\n".join(lines[k * per + 9:(k + 1) * per]) for k in range(n_frames))
    try:
        table = pd.read_csv(io_bytes(body), sep=" ", header=None, names=[c.decode() for c in cols],
                            engine="c", dtype=float)
    except (ValueError, pd.errors.ParserError):
        return None
    if len(table) != n_frames * n or table.isna().to_numpy().any():
        return None
    return table


def io_bytes(data: bytes):
    import io as _io

    return _io.BytesIO(data)


def read_frames_mdanalysis(path, n_atoms: int | None = None) -> Frames:
    """All frames of a LAMMPS text dump through MDAnalysis's reader (unwrapped with the image
    flags, single precision)."""
    import MDAnalysis as mda

    path = Path(path)
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


@dataclass(frozen=True)
class Front:
    """One slip's rupture front, as fix bk/fronts wrote it: the steps of its stress maximum
    and minimum, the steps sampled in between (S,) and the x velocity (slip rate) of every
    particle at each (S, N), by atom id; ``truncated`` when its first samples were dropped."""

    step_max: int
    step_min: int
    steps: np.ndarray
    vx: np.ndarray
    truncated: bool


_FRONTS_MAGIC = b"BKFRONT1"


def read_fronts(path) -> list[Front]:
    """The events of a fix bk/fronts file (plugins/fix_bk_fronts.cpp documents the format);
    a ValueError when the file is cut or is not one."""
    data = read_bytes(path)
    if len(data) < 16 or data[:8] != _FRONTS_MAGIC:
        raise ValueError(f"{path}: not a fix bk/fronts file")
    n = int(np.frombuffer(data, "<i8", 1, 8)[0])
    pos, out = 16, []
    while pos < len(data):
        if pos + 32 > len(data):
            raise ValueError(f"{path}: cut inside an event header")
        smax, smin, s, flags = (int(v) for v in np.frombuffer(data, "<i8", 4, pos))
        pos += 32
        need = 8 * s + 4 * s * n
        if s < 0 or pos + need > len(data):
            raise ValueError(f"{path}: cut inside an event ({len(data) - pos} of {need} bytes)")
        steps = np.frombuffer(data, "<i8", s, pos).copy()
        vx = np.frombuffer(data, "<f4", s * n, pos + 8 * s).reshape(s, n).copy()
        pos += need
        out.append(Front(smax, smin, steps, vx, bool(flags & 1)))
    return out


def read_json(path) -> dict:
    return json.loads(read_text(path))


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
    """Write JSON (NaN as null) atomically."""
    text = json.dumps(json_ready(obj), indent=2, sort_keys=True, allow_nan=False) + "\n"
    with atomic_file(path) as f:
        f.write(text)


def write_parquet(path, df) -> None:
    """Write a DataFrame as Parquet (pyarrow), atomically: the typed, columnar copy of a
    table that pandas, polars, R's arrow, DuckDB and Julia read without bkflow."""
    with atomic_file(path, binary=True) as f:
        df.to_parquet(f, engine="pyarrow", index=False)


def write_table(path, table) -> None:
    """Write a CSV of named columns (a dict of arrays or a DataFrame) atomically, each float
    in ``FLOAT_FORMAT``: the shortest text that ``read_table`` reads back as the same double."""
    import pandas as pd

    df = table if isinstance(table, pd.DataFrame) else pd.DataFrame(table)
    with atomic_file(path) as f:
        df.to_csv(f, index=False, float_format=FLOAT_FORMAT)
